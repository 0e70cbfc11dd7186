//! Reference moduli of a polycrystal of one crystal stiffness: orientation averages over
//! a given set of grain rotations (Voigt, Reuss, Hill; Hill 1952), and for a random
//! (uniform on SO(3)) texture the Voigt–Reuss–Hill moduli, the Hashin–Shtrikman bounds
//! for a crystal of any symmetry (Hashin & Shtrikman 1962; Walpole 1966; Watt &
//! Peselnick 1980; Berryman 2011) and the self-consistent estimate (Hershey 1954;
//! Kröner 1958). Cubic closed forms are kept separately as independent checks.
//! docs/polycrystal-bounds.md gives the formulas and conventions.
//!
//! Internally tensors are in Mandel (Kelvin) form, W C W with W = diag(1,1,1,√2,√2,√2):
//! there a rotation is an orthogonal 6×6 matrix, the compliance is the plain inverse, and
//! the isotropic projectors J = ⅓ i⊗i (i = (1,1,1,0,0,0)) and K = I − J are orthogonal.

use super::elastic::{
    check_positive_definite, isotropic_from_bulk_shear, reuss_average, voigt_average,
    IsotropicModuli,
};
use super::rotate::bond_matrix;
use super::symmetry::CubicProjection;
use super::Stiffness6;
use crate::{Error, Mat3, Result};

const SQRT_2: f64 = std::f64::consts::SQRT_2;
/// Mandel weights W = diag(1, 1, 1, √2, √2, √2).
const MANDEL_W: [f64; 6] = [1.0, 1.0, 1.0, SQRT_2, SQRT_2, SQRT_2];

/// Mandel form W C W of a Voigt stiffness.
fn to_mandel(c: &Stiffness6) -> Stiffness6 {
    Stiffness6::from_fn(|a, b| MANDEL_W[a] * c[(a, b)] * MANDEL_W[b])
}

/// Voigt stiffness W⁻¹ C_M W⁻¹ of a Mandel-form stiffness.
fn from_mandel(m: &Stiffness6) -> Stiffness6 {
    Stiffness6::from_fn(|a, b| m[(a, b)] / (MANDEL_W[a] * MANDEL_W[b]))
}

/// The orthogonal 6×6 Mandel rotation W M W⁻¹ of Q (M the Bond matrix, [`bond_matrix`]):
/// rotate(C, Q) in Mandel form is R C_M Rᵀ, and the same R rotates a Mandel compliance.
fn mandel_rotation(q: &Mat3) -> Stiffness6 {
    let m = bond_matrix(q);
    Stiffness6::from_fn(|a, b| MANDEL_W[a] * m[(a, b)] / MANDEL_W[b])
}

/// Inverse of a symmetric positive definite 6×6 matrix (Cholesky), symmetrised.
fn spd_inverse(m: &Stiffness6, what: &str) -> Result<Stiffness6> {
    let sym = 0.5 * (m + m.transpose());
    match sym.cholesky() {
        Some(ch) => {
            let inv = ch.inverse();
            Ok(0.5 * (inv + inv.transpose()))
        }
        None => Err(Error::Degenerate(format!(
            "{what}: matrix is not positive definite (Cholesky failed)"
        ))),
    }
}

/// Coefficients (α, β) of the isotropic projection α J + β K of a Mandel-form 4th-order
/// tensor A: α = J::A, β = K::A / 5 (the orientation average of A over SO(3)). For a
/// stiffness α = 3K_V and β = 2G_V; for a compliance α = 1/(3K_R), β = 1/(2G_R).
fn isotropic_coefficients(a: &Stiffness6) -> (f64, f64) {
    let mut ja = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            ja += a[(i, j)];
        }
    }
    ja /= 3.0;
    (ja, (a.trace() - ja) / 5.0)
}

/// The Mandel-form isotropic tensor α J + β K.
fn isotropic_mandel(alpha: f64, beta: f64) -> Stiffness6 {
    let mut m = Stiffness6::identity() * beta;
    for i in 0..3 {
        for j in 0..3 {
            m[(i, j)] += (alpha - beta) / 3.0;
        }
    }
    m
}

/// Refuses a stiffness that is not a valid crystal tensor (see [`check_positive_definite`]).
fn check_crystal(c: &Stiffness6) -> Result<()> {
    check_positive_definite(c, "crystal stiffness")
}

/// Voigt, Reuss and Hill averages of a crystal stiffness over a set of grain
/// orientations (all 6×6 Voigt, Pa).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientationAverages {
    /// ⟨C⟩: uniform strain (Voigt 1889).
    pub voigt: Stiffness6,
    /// ⟨S⟩⁻¹: uniform stress (Reuss 1929), S = C⁻¹ averaged in Mandel form.
    pub reuss: Stiffness6,
    /// (Voigt + Reuss)/2 (Hill 1952).
    pub hill: Stiffness6,
}

/// The Voigt, Reuss and Hill averages of `c` (Voigt, Pa) over grains rotated by
/// `rotations`: grain g has stiffness rotate(C, Q_g) (Q_g maps crystal-frame vectors to
/// the lab; for an orientation R mapping lab to crystal pass Rᵀ, as in
/// [`super::rotate`]). `weights` (e.g. grain volumes) are normalised; `None` weighs all
/// grains equally. The compliance is averaged in Mandel form (no Voigt factors of 2 or 4
/// to track): ⟨S⟩ = Σ w_g R_g S_M R_gᵀ, Reuss = ⟨S⟩⁻¹ (Hill 1952).
///
/// Refused (Invalid): no rotations, a rotation with max |QᵀQ − I| > 1e-9 or det ≤ 0,
/// weights of the wrong length, negative, non-finite or summing to zero, a stiffness that
/// is not positive definite.
pub fn orientation_averages(
    c: &Stiffness6,
    rotations: &[Mat3],
    weights: Option<&[f64]>,
) -> Result<OrientationAverages> {
    check_crystal(c)?;
    if rotations.is_empty() {
        return Err(Error::Invalid(
            "orientation average: no orientations given".into(),
        ));
    }
    let weights: Vec<f64> = match weights {
        None => vec![1.0; rotations.len()],
        Some(w) => {
            if w.len() != rotations.len() {
                return Err(Error::Invalid(format!(
                    "orientation average: {} weights for {} orientations, expected one each",
                    w.len(),
                    rotations.len()
                )));
            }
            if let Some((g, x)) = w
                .iter()
                .enumerate()
                .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
            {
                return Err(Error::Invalid(format!(
                    "orientation average: weight {x} of orientation {g}, expected a finite \
                     value ≥ 0"
                )));
            }
            w.to_vec()
        }
    };
    let total: f64 = weights.iter().sum();
    if total <= 0.0 {
        return Err(Error::Invalid(
            "orientation average: the weights sum to zero".into(),
        ));
    }
    for (g, q) in rotations.iter().enumerate() {
        let deviation = (q.transpose() * q - Mat3::identity()).amax();
        let det = q.determinant();
        if !(deviation <= 1e-9 && det > 0.0) {
            return Err(Error::Invalid(format!(
                "orientation average: orientation {g} is not a rotation \
                 (max |QᵀQ − I| = {deviation:.3e}, det = {det:.6}); expected an orthogonal \
                 matrix with det +1"
            )));
        }
    }
    let cm = to_mandel(&(0.5 * (c + c.transpose())));
    let sm = spd_inverse(&cm, "crystal stiffness")?;
    let mut c_sum = Stiffness6::zeros();
    let mut s_sum = Stiffness6::zeros();
    for (q, &w) in rotations.iter().zip(&weights) {
        let r = mandel_rotation(q);
        c_sum += (w / total) * (r * cm * r.transpose());
        s_sum += (w / total) * (r * sm * r.transpose());
    }
    let voigt = from_mandel(&(0.5 * (c_sum + c_sum.transpose())));
    let reuss = from_mandel(&spd_inverse(&s_sum, "averaged compliance")?);
    Ok(OrientationAverages {
        voigt,
        reuss,
        hill: 0.5 * (voigt + reuss),
    })
}

/// The isotropic projection of C (Voigt, Pa): its average over uniformly random
/// orientations, 3K_V J + 2G_V K, computed in Mandel form (J::C, K::C/5). Its moduli are
/// those of [`voigt_average`] (Hill 1952).
pub fn isotropic_projection(c: &Stiffness6) -> Stiffness6 {
    let (alpha, beta) = isotropic_coefficients(&to_mandel(c));
    from_mandel(&isotropic_mandel(alpha, beta))
}

/// Random-texture Hill moduli: K_H = (K_V + K_R)/2, G_H = (G_V + G_R)/2 (Hill 1952), with
/// [`voigt_average`] and [`reuss_average`]'s closed forms.
pub fn hill_average(c: &Stiffness6) -> Result<IsotropicModuli> {
    let v = voigt_average(c);
    let r = reuss_average(c)?;
    Ok(IsotropicModuli::from_bulk_shear(
        0.5 * (v.bulk + r.bulk),
        0.5 * (v.shear + r.shear),
    ))
}

/// Hill's constraint moduli (K*, G*) of a spherical inclusion in an isotropic medium
/// (K0, G0): K* = 4G0/3, G* = G0(9K0 + 8G0)/(6(K0 + 2G0)) (Hill 1965; Walpole 1966).
pub fn constraint_moduli(k0: f64, g0: f64) -> (f64, f64) {
    (
        4.0 * g0 / 3.0,
        g0 * (9.0 * k0 + 8.0 * g0) / (6.0 * (k0 + 2.0 * g0)),
    )
}

/// The Hashin–Shtrikman estimate for a random aggregate of crystals `c` with the isotropic
/// comparison medium (K0, G0) (Pa): C_HS = ⟨(C + C*)⁻¹⟩⁻¹ − C*, C* Hill's constraint
/// tensor ([`constraint_moduli`]), ⟨·⟩ the average over random orientations, which for an
/// isotropic C* is the isotropic projection of the crystal-frame (C + C*)⁻¹ (Walpole 1966;
/// Willis 1977). It is an upper bound when C0 − C is positive semidefinite, a
/// lower bound when C − C0 is ([`hashin_shtrikman_bounds`]), the self-consistent
/// estimate when C0 = C_HS ([`self_consistent`]). K0 = G0 = 0 gives Reuss.
///
/// Refused (Invalid): a stiffness that is not positive definite, K0 or G0 negative or
/// non-finite.
pub fn hashin_shtrikman_estimate(c: &Stiffness6, k0: f64, g0: f64) -> Result<IsotropicModuli> {
    check_crystal(c)?;
    if !(k0.is_finite() && g0.is_finite() && k0 >= 0.0 && g0 >= 0.0) {
        return Err(Error::Invalid(format!(
            "Hashin–Shtrikman comparison medium K0 = {k0} Pa, G0 = {g0} Pa: expected finite \
             moduli ≥ 0"
        )));
    }
    let (k, g) = hs_estimate_mandel(&to_mandel(&(0.5 * (c + c.transpose()))), k0, g0)?;
    Ok(IsotropicModuli::from_bulk_shear(k, g))
}

/// [`hashin_shtrikman_estimate`] on a checked Mandel-form crystal stiffness.
fn hs_estimate_mandel(cm: &Stiffness6, k0: f64, g0: f64) -> Result<(f64, f64)> {
    let (ks, gs) = if g0 == 0.0 {
        (0.0, 0.0)
    } else {
        constraint_moduli(k0, g0)
    };
    let a = spd_inverse(
        &(cm + isotropic_mandel(3.0 * ks, 2.0 * gs)),
        "crystal stiffness plus constraint tensor",
    )?;
    let (alpha, beta) = isotropic_coefficients(&a);
    Ok((1.0 / (3.0 * alpha) - ks, 1.0 / (2.0 * beta) - gs))
}

/// One Hashin–Shtrikman bound: the bound on K and on G and the comparison media
/// (K0, G0) (Pa) that give them (each modulus is optimised on its own, so the two media
/// may differ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HashinShtrikmanBound {
    /// Bound on the bulk modulus (Pa).
    pub bulk: f64,
    /// Bound on the shear modulus (Pa).
    pub shear: f64,
    /// (K0, G0) of the comparison medium giving [`Self::bulk`].
    pub bulk_comparison: [f64; 2],
    /// (K0, G0) of the comparison medium giving [`Self::shear`].
    pub shear_comparison: [f64; 2],
}

/// Lower and upper Hashin–Shtrikman bounds of a random aggregate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HashinShtrikmanBounds {
    /// From comparison media with C − C0 positive semidefinite.
    pub lower: HashinShtrikmanBound,
    /// From comparison media with C0 − C positive semidefinite.
    pub upper: HashinShtrikmanBound,
}

/// Directions θ scanned on the boundary of the admissible comparison media before the
/// golden-section refinement.
const BOUND_SCAN: usize = 512;

/// The admissible comparison medium on the ray C0 = t (cos θ J + sin θ K) (Mandel form):
/// for the upper bound the least t with t B − C ⪰ 0, t = λ_max(B^{-½} C B^{-½}); for the
/// lower the largest t with C − t B ⪰ 0, t = λ_min(…). Returns (K0, G0) = (t cos θ / 3,
/// t sin θ / 2).
fn boundary_medium(cm: &Stiffness6, theta: f64, upper: bool) -> (f64, f64) {
    let (s, c) = theta.sin_cos();
    let half = isotropic_mandel(1.0 / c.sqrt(), 1.0 / s.sqrt());
    let m = half * cm * half;
    let eig = nalgebra::SymmetricEigen::new(0.5 * (m + m.transpose())).eigenvalues;
    let t = if upper { eig.max() } else { eig.min() };
    (t * c / 3.0, t * s / 2.0)
}

/// The best bound on the ray family: minimises (upper) or maximises (lower) the chosen
/// modulus of the HS estimate over θ ∈ (0, π/2) by a scan and a golden-section
/// refinement around the best scanned direction. Every θ gives a valid bound, so the
/// search only decides how tight it is. Returns (value, K0, G0).
fn optimise_bound(cm: &Stiffness6, upper: bool, shear: bool) -> Result<(f64, f64, f64)> {
    let half_pi = std::f64::consts::FRAC_PI_2;
    let eval = |theta: f64| -> Result<(f64, f64, f64)> {
        let (k0, g0) = boundary_medium(cm, theta, upper);
        let (k, g) = hs_estimate_mandel(cm, k0, g0)?;
        let v = if shear { g } else { k };
        // Search minimises: negate for the lower bound (maximised).
        Ok((if upper { v } else { -v }, k0, g0))
    };
    let step = half_pi / BOUND_SCAN as f64;
    let mut best = (f64::INFINITY, 0usize);
    for i in 1..BOUND_SCAN {
        let f = eval(i as f64 * step)?.0;
        if f < best.0 {
            best = (f, i);
        }
    }
    let mut a = (best.1 - 1) as f64 * step;
    let mut b = (best.1 + 1) as f64 * step;
    if a <= 0.0 {
        a = 0.5 * step.min(1e-6);
    }
    if b >= half_pi {
        b = half_pi - 0.5 * step.min(1e-6);
    }
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = b - ratio * (b - a);
    let mut x2 = a + ratio * (b - a);
    let mut f1 = eval(x1)?.0;
    let mut f2 = eval(x2)?.0;
    for _ in 0..200 {
        if b - a <= 1e-15 * half_pi {
            break;
        }
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - ratio * (b - a);
            f1 = eval(x1)?.0;
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + ratio * (b - a);
            f2 = eval(x2)?.0;
        }
    }
    // The best of the refined point and the scan (never worse than the scan).
    let refined = eval(if f1 <= f2 { x1 } else { x2 })?;
    let scanned = eval(best.1 as f64 * step)?;
    let (f, k0, g0) = if refined.0 <= scanned.0 {
        refined
    } else {
        scanned
    };
    if !f.is_finite() {
        return Err(Error::Degenerate(
            "Hashin–Shtrikman bound is not finite".into(),
        ));
    }
    Ok((if upper { f } else { -f }, k0, g0))
}

/// Hashin–Shtrikman bounds on K and G of a random, statistically isotropic aggregate of
/// equiaxed grains of the crystal `c` (any symmetry; Voigt, Pa), by isotropic comparison
/// media C0 (Hashin & Shtrikman 1962; Walpole 1966; Watt & Peselnick 1980).
///
/// A C0 with C0 − C ⪰ 0 (Mandel form) gives an upper bound, one with C − C0 ⪰ 0 a lower
/// bound ([`hashin_shtrikman_estimate`]); since C0 is isotropic, C0 − Q·C ⪰ 0 for every
/// grain rotation Q iff C0 − C ⪰ 0 in the crystal frame. The estimate increases with
/// C0, so the best bounds lie on the boundary of the admissible set, which is a curve in
/// (K0, G0) traced by the rays C0 = t(cos θ J + sin θ K) with t the extreme generalised
/// eigenvalue. For cubic crystals the optimum is the corner K0 = K, G0 = max or min of
/// (C11 − C12)/2, C44 (the classical 1962 choice; [`cubic_hashin_shtrikman`]). For
/// lower symmetry the boundary has no single best point: each bound is the optimum of its
/// modulus over θ (Berryman 2011 maps these bounding curves), found by a 512-direction
/// scan and golden-section refinement, so the value is the tightest HS bound with an
/// isotropic comparison medium to the search's precision, and any missed optimum would
/// leave a looser but still valid bound.
pub fn hashin_shtrikman_bounds(c: &Stiffness6) -> Result<HashinShtrikmanBounds> {
    check_crystal(c)?;
    let cm = to_mandel(&(0.5 * (c + c.transpose())));
    let bound = |upper: bool| -> Result<HashinShtrikmanBound> {
        let (bulk, kk0, kg0) = optimise_bound(&cm, upper, false)?;
        let (shear, gk0, gg0) = optimise_bound(&cm, upper, true)?;
        Ok(HashinShtrikmanBound {
            bulk,
            shear,
            bulk_comparison: [kk0, kg0],
            shear_comparison: [gk0, gg0],
        })
    };
    Ok(HashinShtrikmanBounds {
        lower: bound(false)?,
        upper: bound(true)?,
    })
}

/// Checked cubic constants (Pa): finite, C11 − C12 > 0, C44 > 0, C11 + 2C12 > 0.
fn check_cubic(c11: f64, c12: f64, c44: f64) -> Result<()> {
    if !(c11.is_finite() && c12.is_finite() && c44.is_finite())
        || c11 - c12 <= 0.0
        || c44 <= 0.0
        || c11 + 2.0 * c12 <= 0.0
    {
        return Err(Error::Invalid(format!(
            "cubic constants C11 = {c11} Pa, C12 = {c12} Pa, C44 = {c44} Pa: expected \
             C11 − C12 > 0, C44 > 0, C11 + 2C12 > 0 (positive definite)"
        )));
    }
    Ok(())
}

/// Closed-form Hashin–Shtrikman shear bounds of a random cubic polycrystal, Hashin &
/// Shtrikman 1962 (J. Mech. Phys. Solids 10, 343), with G1 = (C11 − C12)/2, G2 = C44,
/// K = (C11 + 2C12)/3, β_i = −3(K + 2G_i)/(5G_i(3K + 4G_i)):
/// G(G1) = G1 + 3[5/(G2 − G1) − 4β1]⁻¹, G(G2) = G2 + 2[5/(G1 − G2) − 6β2]⁻¹; the lower
/// bound is the one from min(G1, G2), the upper from max. The bulk modulus is exactly K.
/// Returns (lower, upper) in Pa. An independent check of [`hashin_shtrikman_bounds`].
pub fn cubic_hashin_shtrikman(c11: f64, c12: f64, c44: f64) -> Result<(f64, f64)> {
    check_cubic(c11, c12, c44)?;
    let (g1, g2) = (0.5 * (c11 - c12), c44);
    if g1 == g2 {
        return Ok((g1, g1));
    }
    let k = (c11 + 2.0 * c12) / 3.0;
    let beta = |g: f64| -3.0 * (k + 2.0 * g) / (5.0 * g * (3.0 * k + 4.0 * g));
    let from_g1 = g1 + 3.0 / (5.0 / (g2 - g1) - 4.0 * beta(g1));
    let from_g2 = g2 + 2.0 / (5.0 / (g1 - g2) - 6.0 * beta(g2));
    Ok((from_g1.min(from_g2), from_g1.max(from_g2)))
}

/// Hershey's self-consistent shear modulus of a random cubic polycrystal (Hershey 1954;
/// Kröner 1958): the positive root of G³ + αG² + βG + γ = 0, α = (5C11 + 4C12)/8,
/// β = −C44(7C11 − 4C12)/8, γ = −C44(C11 − C12)(C11 + 2C12)/8 (one positive root by
/// Descartes' rule, as γ < 0), found by bisection to the last bit. K_SC = (C11 + 2C12)/3.
/// Returns G (Pa). An independent check of [`self_consistent`].
pub fn cubic_self_consistent_shear(c11: f64, c12: f64, c44: f64) -> Result<f64> {
    check_cubic(c11, c12, c44)?;
    let alpha = (5.0 * c11 + 4.0 * c12) / 8.0;
    let beta = -c44 * (7.0 * c11 - 4.0 * c12) / 8.0;
    let gamma = -c44 * (c11 - c12) * (c11 + 2.0 * c12) / 8.0;
    let p = |g: f64| ((g + alpha) * g + beta) * g + gamma;
    let (mut lo, mut hi) = (0.0, c44.max(0.5 * (c11 - c12)));
    while p(hi) < 0.0 {
        hi *= 2.0;
    }
    for _ in 0..2000 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if p(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Stopping rule of [`self_consistent_with`]: relative change of K and G per step.
pub const SELF_CONSISTENT_TOLERANCE: f64 = 1e-14;
/// Iteration limit of [`self_consistent`].
pub const SELF_CONSISTENT_MAX_ITERATIONS: usize = 1000;

/// The self-consistent (Hershey–Kröner–Eshelby) moduli of a random aggregate of the
/// crystal `c` (Voigt, Pa): the isotropic C_SC = ⟨(C + C*(C_SC))⁻¹⟩⁻¹ − C*(C_SC), i.e. the
/// Hashin–Shtrikman estimate whose comparison medium is itself (Hershey 1954; Kröner
/// 1958), by fixed-point iteration from the Hill moduli, with
/// [`SELF_CONSISTENT_TOLERANCE`] and [`SELF_CONSISTENT_MAX_ITERATIONS`].
pub fn self_consistent(c: &Stiffness6) -> Result<IsotropicModuli> {
    self_consistent_with(c, SELF_CONSISTENT_TOLERANCE, SELF_CONSISTENT_MAX_ITERATIONS)
}

/// [`self_consistent`] with its stopping rule: stop when |ΔK|/K and |ΔG|/G of one
/// fixed-point step are both ≤ `tolerance`; Error::NotConverged (naming the last change)
/// after `max_iterations` steps without it. Converged moduli are checked positive.
pub fn self_consistent_with(
    c: &Stiffness6,
    tolerance: f64,
    max_iterations: usize,
) -> Result<IsotropicModuli> {
    check_crystal(c)?;
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(Error::Invalid(format!(
            "self-consistent tolerance {tolerance}: expected a finite value > 0"
        )));
    }
    let cm = to_mandel(&(0.5 * (c + c.transpose())));
    let start = hill_average(c)?;
    let (mut k, mut g) = (start.bulk, start.shear);
    let mut change = f64::INFINITY;
    for _ in 0..max_iterations {
        let (k1, g1) = hs_estimate_mandel(&cm, k, g)?;
        if !(k1.is_finite() && g1.is_finite() && k1 > 0.0 && g1 > 0.0) {
            return Err(Error::NotConverged(format!(
                "self-consistent estimate left the positive moduli: K = {k1:.6e} Pa, \
                 G = {g1:.6e} Pa"
            )));
        }
        change = ((k1 - k) / k1).abs().max(((g1 - g) / g1).abs());
        k = k1;
        g = g1;
        if change <= tolerance {
            return Ok(IsotropicModuli::from_bulk_shear(k, g));
        }
    }
    Err(Error::NotConverged(format!(
        "self-consistent estimate: relative change {change:.3e} after {max_iterations} \
         iterations, expected ≤ {tolerance:.1e}"
    )))
}

/// Universal anisotropy index A^U = 5 G_V/G_R + K_V/K_R − 6 ≥ 0, zero only for local
/// isotropy (Ranganathan & Ostoja-Starzewski 2008, Phys. Rev. Lett. 101, 055504).
pub fn universal_anisotropy_index(c: &Stiffness6) -> Result<f64> {
    let v = voigt_average(c);
    let r = reuss_average(c)?;
    Ok(5.0 * v.shear / r.shear + v.bulk / r.bulk - 6.0)
}

/// The isotropic stiffness (Voigt, Pa) of moduli `m`.
pub fn isotropic_tensor(m: &IsotropicModuli) -> Stiffness6 {
    isotropic_from_bulk_shear(m.bulk, m.shear)
}

/// What a polycrystal study compares against: the random-texture moduli of a crystal
/// (Pa), serialised with the unit in each key. Built by [`PolycrystalReference::of`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PolycrystalReference {
    /// Voigt bulk modulus K_V.
    pub voigt_bulk_pa: f64,
    /// Voigt shear modulus G_V.
    pub voigt_shear_pa: f64,
    /// Reuss bulk modulus K_R.
    pub reuss_bulk_pa: f64,
    /// Reuss shear modulus G_R.
    pub reuss_shear_pa: f64,
    /// Hill bulk modulus (K_V + K_R)/2.
    pub hill_bulk_pa: f64,
    /// Hill shear modulus (G_V + G_R)/2.
    pub hill_shear_pa: f64,
    /// Hashin–Shtrikman lower bound on K.
    pub hs_lower_bulk_pa: f64,
    /// Hashin–Shtrikman lower bound on G.
    pub hs_lower_shear_pa: f64,
    /// Hashin–Shtrikman upper bound on K.
    pub hs_upper_bulk_pa: f64,
    /// Hashin–Shtrikman upper bound on G.
    pub hs_upper_shear_pa: f64,
    /// Self-consistent bulk modulus.
    pub self_consistent_bulk_pa: f64,
    /// Self-consistent shear modulus.
    pub self_consistent_shear_pa: f64,
    /// Zener ratio 2C44/(C11 − C12) when the crystal is cubic in its axes (entries within
    /// 1e-9 of its cubic projection), else null.
    pub zener: Option<f64>,
    /// Universal anisotropy index A^U ([`universal_anisotropy_index`]).
    pub universal_anisotropy: f64,
}

impl PolycrystalReference {
    /// All reference moduli of a random aggregate of crystal `c` (Voigt, Pa).
    pub fn of(c: &Stiffness6) -> Result<Self> {
        check_crystal(c)?;
        let v = voigt_average(c);
        let r = reuss_average(c)?;
        let hs = hashin_shtrikman_bounds(c)?;
        let sc = self_consistent(c)?;
        let cubic = CubicProjection::from_stiffness(c);
        let is_cubic = super::relative_difference(c, &cubic.to_matrix()) <= 1e-9;
        let report = Self {
            voigt_bulk_pa: v.bulk,
            voigt_shear_pa: v.shear,
            reuss_bulk_pa: r.bulk,
            reuss_shear_pa: r.shear,
            hill_bulk_pa: 0.5 * (v.bulk + r.bulk),
            hill_shear_pa: 0.5 * (v.shear + r.shear),
            hs_lower_bulk_pa: hs.lower.bulk,
            hs_lower_shear_pa: hs.lower.shear,
            hs_upper_bulk_pa: hs.upper.bulk,
            hs_upper_shear_pa: hs.upper.shear,
            self_consistent_bulk_pa: sc.bulk,
            self_consistent_shear_pa: sc.shear,
            zener: is_cubic.then_some(cubic.zener),
            universal_anisotropy: 5.0 * v.shear / r.shear + v.bulk / r.bulk - 6.0,
        };
        let values = [
            report.voigt_bulk_pa,
            report.voigt_shear_pa,
            report.reuss_bulk_pa,
            report.reuss_shear_pa,
            report.hs_lower_bulk_pa,
            report.hs_lower_shear_pa,
            report.hs_upper_bulk_pa,
            report.hs_upper_shear_pa,
            report.self_consistent_bulk_pa,
            report.self_consistent_shear_pa,
            report.universal_anisotropy,
        ];
        if values.iter().any(|x| !x.is_finite()) {
            return Err(Error::Degenerate(
                "polycrystal reference: a modulus is not finite".into(),
            ));
        }
        Ok(report)
    }

    /// The report as pretty JSON.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string_pretty(self)
            .map_err(|e| Error::Invalid(format!("polycrystal reference to JSON: {e}")))
    }
}
