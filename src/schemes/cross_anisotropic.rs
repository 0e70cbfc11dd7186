//! Cross-anisotropic (transversely isotropic) "elliptic" scheme of Šmilauer (Woo
//! DEM `Cp2_FrictMat_FrictPhys_CrossAnisotropy`).
//!
//! Lattice moduli depend on the angle θ between the bond normal and the cross-anisotropy
//! axis through the elliptic interpolation w(θ) = sin²θ (Šmilauer Eqs. 8,
//! Eq. 9): E′(θ) = sin²θ·E^a′ + cos²θ·E^b′, with E^a′ the in-plane modulus (bond
//! normal perpendicular to the axis) and E^b′ the out-of-plane one (bond along the axis).
//! Moduli are kept in the paper's order 𝓔′ = (E_N^a′, E_N^b′, E_T^a′, E_T^b′).
//!
//! The microplane tensor is 𝓒 = μ·A·𝓔′ with 𝓒 = (C11, C33, C13, C12), A the exact 1/35
//! matrix ([`microplane_matrix`]) and μ the lattice scaling ([`crate::bonds::lattice_scaling`]); inverted,
//! 𝓔′ = A⁻¹𝓒/μ (Šmilauer Eqs. 21, Eq. 22). C44 is dependent
//! ([`dependent_c44`], Eq. 12). A bond's springs are k = E′·π̂r²/(2r′) (Eq. 14),
//! i.e. the `modulus` geometry convention with the centre distance as bond length.

use crate::schemes::{Magnitudes, StiffnessScheme};
use crate::{Error, Result, Vec3};

/// The five rows of Šmilauer's 1/35 matrix (Šmilauer Eq. 10): rows
/// (C11, C33, C13, C12, C44) of the microplane tensor, columns (E_N^a, E_N^b, E_T^a, E_T^b),
/// entries exact integers divided by 35. Re-derived in docs/references.md (the converted paper
/// garbles the C2323 integrand, not the matrix).
pub fn microplane_matrix() -> [[f64; 4]; 5] {
    const ROWS: [[i32; 4]; 5] = [
        [36, 6, 20, 8],   // C11
        [12, 30, 16, 12], // C33
        [8, 6, -8, -6],   // C13
        [12, 2, -12, -2], // C12
        [8, 6, 13, 8],    // C44
    ];
    let mut out = [[0.0; 4]; 5];
    for (row, src) in out.iter_mut().zip(ROWS.iter()) {
        for (x, &k) in row.iter_mut().zip(src.iter()) {
            *x = k as f64 / 35.0;
        }
    }
    out
}

/// Exact inverse of the 4×4 block of [`microplane_matrix`] (rows C11, C33, C13, C12): maps
/// (C11, C33, C13, C12) to (E_N^a, E_N^b, E_T^a, E_T^b) (Šmilauer Eq. 13;
/// docs/references.md). All entries are multiples of 1/4, hence exact in `f64`.
pub fn inverse_block() -> [[f64; 4]; 4] {
    [
        [0.75, -0.25, 0.25, 0.75],
        [-0.5, 1.0, 1.5, -0.5],
        [0.75, -0.25, 1.5, -3.0],
        [-0.5, 1.0, -6.0, 4.5],
    ]
}

/// The dependent out-of-plane shear modulus of the elliptic scheme,
/// C44 = (C11 + C33)/4 − C13/2 (Šmilauer Eq. 12).
pub fn dependent_c44(c11: f64, c33: f64, c13: f64) -> f64 {
    0.25 * (c11 + c33) - 0.5 * c13
}

/// Unit cross-anisotropy axis from strike α and dip β in degrees (Woo's convention, Šmilauer
/// "Videos"): (cos α sin β, −sin α sin β, cos β). Dip 0 gives the z axis.
pub fn axis_from_strike_dip(strike_deg: f64, dip_deg: f64) -> Vec3 {
    let (sa, ca) = strike_deg.to_radians().sin_cos();
    let (sb, cb) = dip_deg.to_radians().sin_cos();
    Vec3::new(ca * sb, -sa * sb, cb)
}

/// Šmilauer's elliptic cross-anisotropic scheme: E_N′(θ), E_T′(θ) interpolated between the
/// in-plane (a) and out-of-plane (b) lattice moduli by sin²θ, θ the angle from `axis`.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossAnisotropic {
    /// Lattice moduli (E_N^a′, E_N^b′, E_T^a′, E_T^b′) in Pa (Šmilauer order).
    pub e_prime: [f64; 4],
    /// Unit cross-anisotropy axis (lab frame).
    pub axis: Vec3,
}

const MODULUS_NAMES: [&str; 4] = ["E_N^a'", "E_N^b'", "E_T^a'", "E_T^b'"];

/// The lattice moduli 𝓔′ = A⁻¹𝓒/μ (Šmilauer Eq. 22) that reproduce the transversely
/// isotropic target (C11, C33, C13, C12) (Pa) on a lattice with scaling `mu`, or why the
/// elliptic scheme cannot (non-finite input, μ ≤ 0, a target that is not positive definite
/// with the dependent C44, a negative lattice modulus): the admissible domain of
/// [`CrossAnisotropic::from_target`], which the calibration tests without an error value.
pub fn target_lattice_moduli(
    c11: f64,
    c33: f64,
    c13: f64,
    c12: f64,
    mu: f64,
) -> std::result::Result<[f64; 4], String> {
    let c = [c11, c33, c13, c12];
    let names = ["C11", "C33", "C13", "C12"];
    for (name, &v) in names.iter().zip(c.iter()) {
        if !v.is_finite() {
            return Err(format!(
                "cross-anisotropic target {name} = {v}: expected a finite value in Pa"
            ));
        }
    }
    if !mu.is_finite() || mu <= 0.0 {
        return Err(format!(
            "cross-anisotropic lattice scaling mu must be finite and > 0, got {mu}"
        ));
    }
    let target = format!("C11={c11:e}, C33={c33:e}, C13={c13:e}, C12={c12:e} Pa");
    let c44 = dependent_c44(c11, c33, c13);
    let c66 = 0.5 * (c11 - c12);
    // Eigen-conditions of a transversely isotropic stiffness: C66 > 0 (i.e. C11 > C12),
    // C44 > 0, and the (C11 + C12, √2·C13; √2·C13, C33) block positive definite.
    let checks = [
        (
            c66 > 0.0,
            format!("C66 = (C11 - C12)/2 = {c66:e} must be > 0"),
        ),
        (
            c44 > 0.0,
            format!("the dependent C44 = (C11 + C33)/4 - C13/2 = {c44:e} must be > 0"),
        ),
        (
            c11 + c12 > 0.0,
            format!("C11 + C12 = {:e} must be > 0", c11 + c12),
        ),
        (c33 > 0.0, format!("C33 = {c33:e} must be > 0")),
        (
            (c11 + c12) * c33 > 2.0 * c13 * c13,
            format!(
                "(C11 + C12)·C33 = {:e} must exceed 2·C13² = {:e}",
                (c11 + c12) * c33,
                2.0 * c13 * c13
            ),
        ),
    ];
    for (ok, why) in checks {
        if !ok {
            return Err(format!(
                "cross-anisotropic target {target} is not a positive definite transversely \
                 isotropic stiffness: {why}"
            ));
        }
    }
    let inv = inverse_block();
    let mut e = [0.0; 4];
    for (ek, row) in e.iter_mut().zip(inv.iter()) {
        *ek = row.iter().zip(c.iter()).map(|(a, b)| a * b).sum::<f64>() / mu;
    }
    for (name, &v) in MODULUS_NAMES.iter().zip(e.iter()) {
        if v < 0.0 {
            return Err(format!(
                "cross-anisotropic target {target} needs a negative lattice modulus \
                 {name} = {v:e} Pa (E' = A^-1 C / mu, mu = {mu:e}); the elliptic scheme cannot \
                 reproduce it"
            ));
        }
    }
    Ok(e)
}

impl CrossAnisotropic {
    /// The scheme from lattice moduli 𝓔′ = (E_N^a′, E_N^b′, E_T^a′, E_T^b′) (Pa) and an axis
    /// (normalised here). Refuses a zero or non-finite axis and moduli that are not finite or
    /// would make E_N′(θ) or E_T′(θ) negative somewhere (each is a convex combination of its
    /// a and b values, so both must be ≥ 0).
    pub fn from_moduli(e: [f64; 4], axis: Vec3) -> Result<Self> {
        let len = axis.norm();
        if !len.is_finite() || len == 0.0 {
            return Err(Error::Model(format!(
                "cross-anisotropic axis must be a finite non-zero vector, got [{}, {}, {}]",
                axis.x, axis.y, axis.z
            )));
        }
        for (name, &value) in MODULUS_NAMES.iter().zip(e.iter()) {
            if !value.is_finite() || value < 0.0 {
                return Err(Error::Model(format!(
                    "cross-anisotropic lattice modulus {name} = {value} Pa: must be finite and \
                     >= 0, otherwise the bond stiffness is negative for some orientations"
                )));
            }
        }
        Ok(CrossAnisotropic {
            e_prime: e,
            axis: axis / len,
        })
    }

    /// The scheme that reproduces the transversely isotropic target (C11, C33, C13, C12) (Pa)
    /// about `axis` on a lattice with scaling `mu`: 𝓔′ = A⁻¹𝓒/μ (Šmilauer
    /// Eq. 22). C44 is not free: it becomes (C11 + C33)/4 − C13/2.
    /// Refuses non-finite input, μ ≤ 0, a target that is not positive definite together with
    /// that C44, and a target that needs a negative lattice modulus.
    pub fn from_target(
        c11: f64,
        c33: f64,
        c13: f64,
        c12: f64,
        axis: Vec3,
        mu: f64,
    ) -> Result<Self> {
        let e = target_lattice_moduli(c11, c33, c13, c12, mu).map_err(Error::Model)?;
        Self::from_moduli(e, axis)
    }

    /// The lattice moduli (E_N′(θ), E_T′(θ)) in Pa along unit normal `n`, θ the angle to the
    /// axis: E′(θ) = sin²θ·E^a′ + cos²θ·E^b′ (Šmilauer Eqs. 8–9).
    pub fn moduli(&self, n: &Vec3) -> (f64, f64) {
        let cos2 = n.dot(&self.axis).powi(2).min(1.0);
        let sin2 = 1.0 - cos2;
        let [ena, enb, eta, etb] = self.e_prime;
        (sin2 * ena + cos2 * enb, sin2 * eta + cos2 * etb)
    }

    /// The microplane constants (C11, C33, C13, C12, C44) = μ·A·𝓔′ in Pa, in the axis frame
    /// (Šmilauer Eq. 21): what a lattice with scaling μ gives under uniform
    /// strain.
    pub fn microplane_constants(&self, mu: f64) -> [f64; 5] {
        let a = microplane_matrix();
        let mut out = [0.0; 5];
        for (o, row) in out.iter_mut().zip(a.iter()) {
            *o = mu
                * row
                    .iter()
                    .zip(self.e_prime.iter())
                    .map(|(x, y)| x * y)
                    .sum::<f64>();
        }
        out
    }
}

impl StiffnessScheme for CrossAnisotropic {
    fn name(&self) -> String {
        super::SchemeKind::CrossAnisotropic.to_string()
    }

    /// (E_N′(θ), E_T′(θ)) in Pa, for the `modulus` geometry convention:
    /// k = E′·π̂r²/(2r′) (Šmilauer Eq. 14).
    fn magnitudes(&self, n: &Vec3) -> Magnitudes {
        let (normal, shear) = self.moduli(n);
        Magnitudes { normal, shear }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moduli_interpolate_between_in_plane_and_axis_values() {
        let s = CrossAnisotropic::from_moduli([10.0, 2.0, 3.0, 1.0], Vec3::new(0.0, 0.0, 5.0))
            .expect("valid moduli");
        assert_eq!(s.moduli(&Vec3::z()), (2.0, 1.0)); // along the axis: b
        assert_eq!(s.moduli(&Vec3::x()), (10.0, 3.0)); // in-plane: a
        let n = Vec3::new(1.0, 0.0, 1.0) / 2f64.sqrt(); // θ = 45°
        let (en, et) = s.moduli(&n);
        assert!((en - 6.0).abs() < 1e-14 && (et - 2.0).abs() < 1e-14);
        assert_eq!(s.moduli(&-n), s.moduli(&n));
    }

    #[test]
    fn bad_moduli_and_axis_are_refused() {
        assert!(CrossAnisotropic::from_moduli([1.0, 1.0, 1.0, 1.0], Vec3::zeros()).is_err());
        assert!(CrossAnisotropic::from_moduli([1.0; 4], Vec3::new(f64::NAN, 0.0, 1.0)).is_err());
        let e = CrossAnisotropic::from_moduli([1.0, 1.0, -0.1, 1.0], Vec3::z()).unwrap_err();
        assert!(e.to_string().contains("E_T^a'"), "{e}");
        assert!(CrossAnisotropic::from_moduli([1.0, f64::INFINITY, 0.0, 0.0], Vec3::z()).is_err());
    }
}
