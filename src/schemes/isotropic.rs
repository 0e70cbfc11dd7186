//! Isotropic scheme: the same normal and shear magnitude for every bond orientation.
//!
//! With the `kumar` geometry convention the magnitudes are Kumar 2016's size-independent
//! Σ_N, Σ_T (Eqs. 1–3: K_N = 2Σ_N·R*, R* = R_pR_q/(R_p + R_q)); with `area`, `modulus` or
//! `spring` they are the plain isotropic baseline.

use super::{Magnitudes, StiffnessScheme};
use crate::{Error, Result, Vec3};

/// Constant normal and shear magnitudes (unit set by the geometry convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Isotropic {
    /// Normal magnitude (Σ_N for the `kumar` convention).
    pub normal: f64,
    /// Shear magnitude (Σ_T for the `kumar` convention).
    pub shear: f64,
}

impl Isotropic {
    /// An isotropic scheme; both magnitudes must be finite and ≥ 0.
    pub fn new(normal: f64, shear: f64) -> Result<Self> {
        for (label, k) in [("normal", normal), ("shear", shear)] {
            if !k.is_finite() || k < 0.0 {
                return Err(Error::Model(format!(
                    "isotropic scheme: {label} magnitude must be finite and ≥ 0, got {k}"
                )));
            }
        }
        Ok(Isotropic { normal, shear })
    }
}

impl StiffnessScheme for Isotropic {
    fn name(&self) -> String {
        super::SchemeKind::Isotropic.to_string()
    }

    fn magnitudes(&self, _n: &Vec3) -> Magnitudes {
        Magnitudes {
            normal: self.normal,
            shear: self.shear,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_bad_magnitudes() {
        assert!(Isotropic::new(-1.0, 1.0).is_err());
        assert!(Isotropic::new(1.0, f64::NAN).is_err());
        assert!(Isotropic::new(f64::INFINITY, 1.0).is_err());
        let err = Isotropic::new(1.0, -2.0).unwrap_err().to_string();
        assert!(err.contains("shear"), "{err}");
    }

    #[test]
    fn constant_and_smooth() {
        let s = Isotropic::new(3.0, 1.5).unwrap();
        for n in [Vec3::x(), Vec3::new(0.6, 0.0, -0.8), -Vec3::z()] {
            assert_eq!(
                s.magnitudes(&n),
                Magnitudes {
                    normal: 3.0,
                    shear: 1.5
                }
            );
        }
        assert!(s.kink_planes().is_empty());
        assert_eq!(s.name(), "isotropic");
    }
}
