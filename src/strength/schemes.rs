//! Strength schemes: a bond's [`Strength`] as a function of its initial orientation, of the
//! same three kinds as the stiffness schemes ([`crate::schemes`]).
//!
//! - [`StrengthScheme::Isotropic`]: one strength for every bond.
//! - [`StrengthScheme::CrossAnisotropic`]: strengths along and across an axis, blended by
//!   the bond's angle θ to the axis with the weight of Šmilauer's elliptic stiffness scheme
//!   (Šmilauer Eqs. 8–9, [`crate::schemes::cross_anisotropic::CrossAnisotropic::moduli`]):
//!   s(θ) = sin²θ·s_across + cos²θ·s_along, field by field (friction included).
//! - [`StrengthScheme::Cubic`]: the crystal's symmetry through Truszkowska 2018's spheroid
//!   envelopes (Eqs. 8–15), as the cubic stiffness scheme scales its magnitudes: the tensile
//!   and bending strengths are the base values times the envelope of the model's normal
//!   family (aspect ratio `a_tensile`), cohesion and twisting times the envelope of its shear
//!   family (`a_shear`), evaluated at m = R·n; friction is not scaled.

use super::Strength;
use crate::schemes::cubic::{CubicModel, ROTATION_TOLERANCE};
use crate::tensor::unit_vector;
use crate::{Error, Mat3, Result, Vec3};

/// The strength of a bond by its orientation. Types, not flags: each variant carries only
/// its own parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum StrengthScheme {
    /// The same strength for every orientation.
    Isotropic(Strength),
    /// Šmilauer-style interpolation between along-axis and across-axis strengths.
    CrossAnisotropic(CrossStrength),
    /// Cubic symmetry by Truszkowska 2018's spheroid envelopes.
    Cubic(CubicStrength),
}

/// Strengths along and across a unit axis (the cross-anisotropic scheme).
#[derive(Clone, Debug, PartialEq)]
pub struct CrossStrength {
    /// Strength of a bond parallel to the axis (θ = 0; Šmilauer's "b" direction).
    pub along: Strength,
    /// Strength of a bond perpendicular to the axis (θ = 90°; Šmilauer's "a", in-plane).
    pub across: Strength,
    /// Unit axis (lab frame), e.g. the bedding normal of a transversely isotropic rock.
    pub axis: Vec3,
}

/// Cubic strength: base strengths scaled by Truszkowska 2018's spheroid envelopes.
#[derive(Clone, Debug, PartialEq)]
pub struct CubicStrength {
    /// Which families scale the normal-type (tensile, bending) and shear-type (cohesion,
    /// twisting) strengths: Z > 1 takes <111> for normal and <100> for shear, Z < 1 the
    /// reverse (Truszkowska 2018 Sec. 3), as [`crate::schemes::cubic::CubicSpheroid`].
    pub model: CubicModel,
    /// Aspect ratio of the spheroids scaling tensile and bending (1: no anisotropy).
    pub a_tensile: f64,
    /// Aspect ratio of the spheroids scaling cohesion and twisting (1: no anisotropy).
    pub a_shear: f64,
    /// Base strength (the values at envelope 1).
    pub base: Strength,
    /// Lab → crystal rotation R (the envelopes are evaluated at R·n).
    pub rotation: Mat3,
}

impl StrengthScheme {
    /// The scheme checked: strengths finite and ≥ 0, a non-zero finite axis (normalised
    /// here), aspect ratios finite and > 0, a proper rotation.
    pub fn checked(self) -> Result<StrengthScheme> {
        Ok(match self {
            StrengthScheme::Isotropic(s) => {
                StrengthScheme::Isotropic(s.checked("isotropic strength")?)
            }
            StrengthScheme::CrossAnisotropic(c) => {
                let axis = unit_vector(&c.axis).ok_or_else(|| {
                    Error::Model(format!(
                        "cross-anisotropic strength: axis [{}, {}, {}] must be finite and non-zero",
                        c.axis.x, c.axis.y, c.axis.z
                    ))
                })?;
                StrengthScheme::CrossAnisotropic(CrossStrength {
                    along: c
                        .along
                        .checked("cross-anisotropic strength along the axis")?,
                    across: c
                        .across
                        .checked("cross-anisotropic strength across the axis")?,
                    axis,
                })
            }
            StrengthScheme::Cubic(c) => {
                for (name, a) in [("a_tensile", c.a_tensile), ("a_shear", c.a_shear)] {
                    if !(a.is_finite() && a > 0.0) {
                        return Err(Error::Model(format!(
                            "cubic strength: {name} (spheroid aspect ratio) must be finite and > 0, got {a}"
                        )));
                    }
                }
                let r = &c.rotation;
                let proper = r.iter().all(|x| x.is_finite())
                    && (r.transpose() * r - Mat3::identity()).amax() <= ROTATION_TOLERANCE
                    && r.determinant() > 0.0;
                if !proper {
                    return Err(Error::Model(format!(
                        "cubic strength: rotation {r:?} is not a proper rotation \
                         (|RᵀR − I| ≤ {ROTATION_TOLERANCE:e} and det R > 0 expected)"
                    )));
                }
                StrengthScheme::Cubic(CubicStrength {
                    base: c.base.checked("cubic strength")?,
                    ..c
                })
            }
        })
    }

    /// The strength of a bond with lab-frame unit normal `n` (even in `n`).
    pub fn strength(&self, n: &Vec3) -> Strength {
        match self {
            StrengthScheme::Isotropic(s) => *s,
            StrengthScheme::CrossAnisotropic(c) => {
                // sin²θ as in CrossAnisotropic::moduli (Šmilauer Eqs. 8–9).
                let cos2 = n.dot(&c.axis).powi(2).min(1.0);
                Strength::blend(&c.across, &c.along, 1.0 - cos2)
            }
            StrengthScheme::Cubic(c) => {
                let m = c.rotation * n;
                let f_n = c.model.normal_family().envelope(&m, c.a_tensile);
                let f_s = c.model.shear_family().envelope(&m, c.a_shear);
                Strength {
                    tensile: c.base.tensile * f_n,
                    cohesion: c.base.cohesion * f_s,
                    friction: c.base.friction,
                    bending: c.base.bending * f_n,
                    twisting: c.base.twisting * f_s,
                }
            }
        }
    }
}
