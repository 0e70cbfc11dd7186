//! Elastic constants of a 6×6 Voigt stiffness (Pa, engineering shear strain): positive
//! definiteness, compliance, engineering constants (E, ν, G), isotropic moduli and
//! averages, cubic ratios (Truszkowska 2018) and Šmilauer's cross-anisotropic inversion.

use super::Stiffness6;
use crate::{Error, Mat3, Result};

/// Zener anisotropy ratio Z = 2C44 / (C11 − C12) of a cubic tensor (1 when isotropic;
/// Truszkowska 2018 Sec. 2).
pub fn zener_ratio(c11: f64, c12: f64, c44: f64) -> f64 {
    2.0 * c44 / (c11 - c12)
}

/// Poisson's ratio for uniaxial stress along <100> of a cubic tensor, ν = C12/(C11 + C12)
/// (Truszkowska 2018).
pub fn poisson_100(c11: f64, c12: f64) -> f64 {
    c12 / (c11 + c12)
}

/// Mandel scaling W = diag(1,1,1,√2,√2,√2): W C6 W is the Mandel (Kelvin) form, whose
/// eigenvalues are the rotation-invariant Kelvin moduli.
fn mandel(c: &Stiffness6) -> Stiffness6 {
    let s = std::f64::consts::SQRT_2;
    let w = [1.0, 1.0, 1.0, s, s, s];
    Stiffness6::from_fn(|a, b| w[a] * c[(a, b)] * w[b])
}

/// Kelvin moduli of C (Pa), ascending: the eigenvalues of the Mandel form of the
/// symmetric part of C (Kelvin 1856; invariant under rotation, unlike the eigenvalues of
/// the Voigt matrix, but with the same signs by Sylvester's law of inertia).
pub fn kelvin_moduli(c: &Stiffness6) -> [f64; 6] {
    let sym = 0.5 * (c + c.transpose());
    let eig = nalgebra::SymmetricEigen::new(mandel(&sym)).eigenvalues;
    let mut v = [0.0; 6];
    v.copy_from_slice(eig.as_slice());
    v.sort_by(f64::total_cmp);
    v
}

/// Refuses a stiffness that is not a valid elastic tensor: non-finite entries,
/// asymmetry beyond 1e-6 of its largest entry, or a Kelvin modulus ([`kelvin_moduli`])
/// ≤ 1e-12 × the largest (strain energy ½ eᵀCe not positive). `what` names the tensor
/// (e.g. "target tensor") in the message, which states the smallest eigenvalue.
pub fn check_positive_definite(c: &Stiffness6, what: &str) -> Result<()> {
    if c.iter().any(|x| !x.is_finite()) {
        return Err(Error::Invalid(format!(
            "{what}: stiffness has non-finite entries"
        )));
    }
    let scale = c.amax();
    if scale == 0.0 {
        return Err(Error::Invalid(format!(
            "{what}: stiffness is all zeros, expected a positive definite tensor"
        )));
    }
    let asym = (c - c.transpose()).amax();
    if asym > 1e-6 * scale {
        return Err(Error::Invalid(format!(
            "{what}: stiffness is not symmetric: max |C_ij − C_ji| = {asym:.4e} Pa \
             (largest entry {scale:.4e} Pa)"
        )));
    }
    let moduli = kelvin_moduli(c);
    let (smallest, largest) = (moduli[0], moduli[5]);
    if smallest <= 1e-12 * largest.abs() {
        return Err(Error::Invalid(format!(
            "{what}: stiffness is not positive definite: smallest eigenvalue \
             (Kelvin modulus) {smallest:.4e} Pa, largest {largest:.4e} Pa"
        )));
    }
    Ok(())
}

/// Compliance S = C⁻¹ (1/Pa, engineering shear strain), after
/// [`check_positive_definite`] (of the symmetrised C). `what` names C in errors.
pub fn compliance(c: &Stiffness6, what: &str) -> Result<Stiffness6> {
    check_positive_definite(c, what)?;
    let sym = 0.5 * (c + c.transpose());
    match sym.cholesky() {
        Some(ch) => Ok(ch.inverse()),
        None => Err(Error::Invalid(format!(
            "{what}: Cholesky factorisation failed (not positive definite)"
        ))),
    }
}

/// Orthotropic engineering constants in the tensor's axes, from the compliance S = C⁻¹.
///
/// Poisson convention: ν_ij = −ε_j/ε_i under uniaxial stress along i, i.e.
/// ν_ij = −S_ji·E_i (= −S_ij·E_i, S symmetric), so ν_ij/E_i = ν_ji/E_j (Šmilauer Eq.
/// orthotropic-normal-compliance). The diagonal of `nu` is 0 (not a Poisson ratio).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineeringConstants {
    /// Young's moduli E_1, E_2, E_3 = 1/S_ii (Pa).
    pub e: [f64; 3],
    /// Poisson ratios ν_ij (see the struct doc); zero diagonal.
    pub nu: Mat3,
    /// Shear moduli G23, G13, G12 = 1/S_44, 1/S_55, 1/S_66 (Pa).
    pub g: [f64; 3],
}

impl EngineeringConstants {
    /// Engineering constants of C via S = C⁻¹; error if C is not positive definite.
    /// For a C that is not orthotropic in these axes the couplings S_14… are dropped, so
    /// [`Self::to_stiffness`] returns only C's orthotropic approximation.
    pub fn from_stiffness(c: &Stiffness6) -> Result<Self> {
        let s = compliance(c, "stiffness for engineering constants")?;
        let e = [1.0 / s[(0, 0)], 1.0 / s[(1, 1)], 1.0 / s[(2, 2)]];
        let nu = Mat3::from_fn(|i, j| if i == j { 0.0 } else { -s[(j, i)] * e[i] });
        let g = [1.0 / s[(3, 3)], 1.0 / s[(4, 4)], 1.0 / s[(5, 5)]];
        Ok(Self { e, nu, g })
    }

    /// The orthotropic stiffness with these constants: S_ii = 1/E_i, S_ij = −ν_ij/E_i,
    /// S_44,55,66 = 1/G, C = S⁻¹. Error if a modulus is not positive and finite, if
    /// ν_ij/E_i and ν_ji/E_j differ by more than 1e-6 relative (then they are averaged
    /// otherwise), or if the resulting tensor is not positive definite.
    pub fn to_stiffness(&self) -> Result<Stiffness6> {
        for (name, v) in [
            ("E1", self.e[0]),
            ("E2", self.e[1]),
            ("E3", self.e[2]),
            ("G23", self.g[0]),
            ("G13", self.g[1]),
            ("G12", self.g[2]),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Invalid(format!(
                    "engineering constants: {name} = {v}, expected a positive modulus (Pa)"
                )));
            }
        }
        if self.nu.iter().any(|x| !x.is_finite()) {
            return Err(Error::Invalid(
                "engineering constants: non-finite Poisson ratio".into(),
            ));
        }
        let mut s = Stiffness6::zeros();
        for i in 0..3 {
            s[(i, i)] = 1.0 / self.e[i];
            s[(i + 3, i + 3)] = 1.0 / self.g[i];
            for j in (i + 1)..3 {
                let sij = -self.nu[(i, j)] / self.e[i];
                let sji = -self.nu[(j, i)] / self.e[j];
                let scale = (1.0 / self.e[i]).max(1.0 / self.e[j]);
                if (sij - sji).abs() > 1e-6 * scale {
                    return Err(Error::Invalid(format!(
                        "engineering constants: ν{a}{b}/E{a} = {x:.6e} but ν{b}{a}/E{b} = \
                         {y:.6e}; they must be equal (symmetric compliance)",
                        a = i + 1,
                        b = j + 1,
                        x = -sij,
                        y = -sji
                    )));
                }
                let v = 0.5 * (sij + sji);
                s[(i, j)] = v;
                s[(j, i)] = v;
            }
        }
        let c = compliance(&s, "compliance from engineering constants")?;
        check_positive_definite(&c, "stiffness from engineering constants")?;
        Ok(c)
    }
}

/// Moduli of an isotropic solid (Pa and dimensionless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IsotropicModuli {
    /// Bulk modulus K.
    pub bulk: f64,
    /// Shear modulus G.
    pub shear: f64,
    /// Young's modulus E = 9KG/(3K + G).
    pub young: f64,
    /// Poisson's ratio ν = (3K − 2G)/(2(3K + G)).
    pub poisson: f64,
}

impl IsotropicModuli {
    /// All four moduli from K and G.
    pub fn from_bulk_shear(bulk: f64, shear: f64) -> Self {
        Self {
            bulk,
            shear,
            young: 9.0 * bulk * shear / (3.0 * bulk + shear),
            poisson: (3.0 * bulk - 2.0 * shear) / (2.0 * (3.0 * bulk + shear)),
        }
    }
}

/// The isotropic stiffness with Young's modulus `e` (Pa) and Poisson's ratio `nu`:
/// C11 = λ + 2μ, C12 = λ, C44 = μ, λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)). Error unless
/// e > 0 and −1 < ν < ½ (positive definite).
pub fn isotropic_stiffness(e: f64, nu: f64) -> Result<Stiffness6> {
    if !(e.is_finite() && e > 0.0) {
        return Err(Error::Invalid(format!(
            "isotropic stiffness: Young's modulus {e} Pa, expected > 0"
        )));
    }
    if !(nu > -1.0 && nu < 0.5) {
        return Err(Error::Invalid(format!(
            "isotropic stiffness: Poisson's ratio {nu}, expected −1 < ν < 0.5"
        )));
    }
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    Ok(isotropic_from_lame(lambda, mu))
}

/// The isotropic stiffness with bulk modulus `k` and shear modulus `g` (Pa), no checks
/// (λ = K − 2G/3).
pub fn isotropic_from_bulk_shear(k: f64, g: f64) -> Stiffness6 {
    isotropic_from_lame(k - 2.0 * g / 3.0, g)
}

fn isotropic_from_lame(lambda: f64, mu: f64) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            c[(i, j)] = lambda;
        }
        c[(i, i)] = lambda + 2.0 * mu;
        c[(i + 3, i + 3)] = mu;
    }
    c
}

/// Voigt-average (uniform strain) isotropic moduli of an arbitrary C:
/// K_V = (C11+C22+C33 + 2(C12+C13+C23))/9, G_V = (C11+C22+C33 − (C12+C13+C23)
/// + 3(C44+C55+C66))/15 (Hill 1952). Exact for an isotropic C.
pub fn voigt_average(c: &Stiffness6) -> IsotropicModuli {
    let a = c[(0, 0)] + c[(1, 1)] + c[(2, 2)];
    let b = c[(1, 2)] + c[(0, 2)] + c[(0, 1)];
    let d = c[(3, 3)] + c[(4, 4)] + c[(5, 5)];
    IsotropicModuli::from_bulk_shear((a + 2.0 * b) / 9.0, (a - b + 3.0 * d) / 15.0)
}

/// Reuss-average (uniform stress) isotropic moduli of C, from S = C⁻¹:
/// 1/K_R = S11+S22+S33 + 2(S12+S13+S23), 15/G_R = 4(S11+S22+S33) − 4(S12+S13+S23)
/// + 3(S44+S55+S66) (Hill 1952). Error if C is not positive definite.
pub fn reuss_average(c: &Stiffness6) -> Result<IsotropicModuli> {
    let s = compliance(c, "stiffness for the Reuss average")?;
    let a = s[(0, 0)] + s[(1, 1)] + s[(2, 2)];
    let b = s[(1, 2)] + s[(0, 2)] + s[(0, 1)];
    let d = s[(3, 3)] + s[(4, 4)] + s[(5, 5)];
    Ok(IsotropicModuli::from_bulk_shear(
        1.0 / (a + 2.0 * b),
        15.0 / (4.0 * a - 4.0 * b + 3.0 * d),
    ))
}

/// The exact moduli of an isotropic C (K = λ + 2μ/3 = (C11 + 2C12)/3, G = C44, from the
/// group means); error if C differs from the isotropic tensor with these moduli by more
/// than `relative_tolerance` ([`super::relative_difference`]).
pub fn isotropic_moduli(c: &Stiffness6, relative_tolerance: f64) -> Result<IsotropicModuli> {
    let c11 = (c[(0, 0)] + c[(1, 1)] + c[(2, 2)]) / 3.0;
    let c12 = (c[(1, 2)] + c[(0, 2)] + c[(0, 1)]) / 3.0;
    let c44 = (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]) / 3.0;
    let k = (c11 + 2.0 * c12) / 3.0;
    let iso = isotropic_from_bulk_shear(k, c44);
    let diff = super::relative_difference(c, &iso);
    if diff.is_nan() || diff > relative_tolerance {
        return Err(Error::Invalid(format!(
            "stiffness is not isotropic: relative difference {diff:.3e} from the nearest \
             isotropic tensor exceeds {relative_tolerance:.1e}"
        )));
    }
    Ok(IsotropicModuli::from_bulk_shear(k, c44))
}

/// Šmilauer's inversion of cross-anisotropic (transversely isotropic about z)
/// engineering constants to stiffness (Šmilauer, Eq. CC-from-EGnu):
/// returns (C11, C12, C13, C33, C44) in Pa.
///
/// With e = E_x/E_z and m = 1 − ν_xy − 2ν_xz²/e:
/// C11 = E_x(1 − ν_xz²/e)/((1+ν_xy)m), C12 = E_x(ν_xy + ν_xz²/e)/((1+ν_xy)m),
/// C13 = E_z ν_xz/m, C33 = E_z(1 − ν_xy)/m, C44 = G_yz. Poisson convention as in
/// [`EngineeringConstants`]: ν_xz = −ε_z/ε_x under uniaxial stress along x.
///
/// The converted text of the paper prints e·ν_xz² (e = E_x/E_z) and C13 = E_x ν_xy/m;
/// both contradict a direct inversion of the paper's own compliance matrix and its
/// numerical table (they give C33 ≈ 650 MPa instead of 52.8 for I_R = 1.8), whereas the
/// forms above reproduce the table (122, 37.9, 26.7, 52.8, 30.8 MPa). Errors on
/// non-positive moduli or m ≤ 0 / 1 + ν_xy ≤ 0 (not positive definite).
pub fn cross_anisotropic_from_engineering(
    e_x: f64,
    e_z: f64,
    nu_xy: f64,
    nu_xz: f64,
    g_yz: f64,
) -> Result<[f64; 5]> {
    for (name, v) in [("E_x", e_x), ("E_z", e_z), ("G_yz", g_yz)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Invalid(format!(
                "cross-anisotropic constants: {name} = {v}, expected a positive modulus (Pa)"
            )));
        }
    }
    if !(nu_xy.is_finite() && nu_xz.is_finite()) {
        return Err(Error::Invalid(
            "cross-anisotropic constants: non-finite Poisson ratio".into(),
        ));
    }
    let e = e_x / e_z;
    let nu_xz_nu_zx = nu_xz * nu_xz / e;
    let m = 1.0 - nu_xy - 2.0 * nu_xz_nu_zx;
    if !(m > 0.0 && 1.0 + nu_xy > 0.0) {
        return Err(Error::Invalid(format!(
            "cross-anisotropic constants: ν_xy = {nu_xy}, ν_xz = {nu_xz}, E_x/E_z = {e} give \
             1 − ν_xy − 2ν_xz²E_z/E_x = {m:.4} and 1 + ν_xy = {:.4}; both must be > 0 \
             (positive definite stiffness)",
            1.0 + nu_xy
        )));
    }
    let c11 = e_x * (1.0 - nu_xz_nu_zx) / ((1.0 + nu_xy) * m);
    let c12 = e_x * (nu_xy + nu_xz_nu_zx) / ((1.0 + nu_xy) * m);
    let c13 = e_z * nu_xz / m;
    let c33 = e_z * (1.0 - nu_xy) / m;
    Ok([c11, c12, c13, c33, g_yz])
}
