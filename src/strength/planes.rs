//! Planes of weakness: a family of parallel planes n·x = offset + k·spacing (k integer);
//! a bond whose segment crosses one of them is a joint bond and takes the joint's strength
//! (the smooth-joint idea of PFC, Park & Min, IJRMMS 76 (2015) 243–255: bonds across a
//! bedding or foliation plane obey the joint's tensile strength, cohesion c_w and friction
//! μ_w, resolved on the plane, [`super::criteria::joint`]). The joint's stresses are its
//! bond's forces over an area chosen per family ([`JointSection`]): the bond's section, or
//! that section cut by the plane (with which a lattice follows Jaeger's single plane of
//! weakness exactly, docs/strength.md, "Jaeger's single plane of weakness in a lattice").

use super::Strength;
use crate::schemes::cross_anisotropic::axis_from_strike_dip;
use crate::tensor::unit_vector;
use crate::{Error, Result, Vec3};
use serde::{Deserialize, Serialize};

/// The area a joint bond's forces are divided by to give the stresses on its plane
/// (`section = "bond" | "cut"` of a `[[strength.planes]]` family).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum JointSection {
    /// The bond's own section A = π̂R_b² (the default): σ_n = F_n/A, τ = |F_s|/A.
    #[default]
    Bond,
    /// The bond's section cut by the plane: a cylinder of section A cut by a plane whose
    /// normal p makes |n·p| with the bond's unit normal n has an ellipse of area A/|n·p|, so
    /// σ_n = F_n|n·p|/A, τ = |F_s||n·p|/A. The plane's bonded area per crossing bond then
    /// does not depend on the bond's inclination, and an aligned lattice follows Jaeger's
    /// formula with cohesion c_w·A/d² (docs/strength.md).
    Cut,
}

impl JointSection {
    /// The name written in a model file (`bond`, `cut`).
    pub fn name(self) -> &'static str {
        match self {
            JointSection::Bond => "bond",
            JointSection::Cut => "cut",
        }
    }

    /// The joint's area for a bond of section `bond_area` (m²) and unit normal `bond_normal`
    /// across a plane of unit normal `plane_normal`: `bond_area` (Bond) or
    /// `bond_area`/|n·p| (Cut; +∞ for a bond parallel to the plane, which crosses none).
    pub fn area(self, bond_area: f64, bond_normal: &Vec3, plane_normal: &Vec3) -> f64 {
        match self {
            JointSection::Bond => bond_area,
            JointSection::Cut => {
                let c = bond_normal.dot(plane_normal).abs();
                if c > 0.0 {
                    bond_area / c
                } else {
                    f64::INFINITY
                }
            }
        }
    }
}

/// A family of parallel planes of weakness and its joint strength.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneFamily {
    /// Unit plane normal (lab frame).
    pub normal: Vec3,
    /// Distance between neighbouring planes (m), > 0.
    pub spacing: f64,
    /// Signed distance of the plane k = 0 from the origin along `normal` (m).
    pub offset: f64,
    /// The joint's strength: tensile, cohesion c_w and friction μ_w = tan φ_w (bending and
    /// twisting are not used by the joint criterion).
    pub joint: Strength,
    /// The area the joint's stresses are taken on ([`JointSection::Bond`] unless set by
    /// [`PlaneFamily::with_section`]).
    pub section: JointSection,
}

impl PlaneFamily {
    /// A checked family from a normal (normalised here), spacing, offset and joint
    /// strength. Refuses a zero or non-finite normal, a spacing not finite and > 0, a
    /// non-finite offset and joint strengths not finite and ≥ 0.
    pub fn new(normal: Vec3, spacing: f64, offset: f64, joint: Strength) -> Result<Self> {
        let unit = unit_vector(&normal).ok_or_else(|| {
            Error::Model(format!(
                "plane of weakness: normal [{}, {}, {}] must be finite and non-zero",
                normal.x, normal.y, normal.z
            ))
        })?;
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(Error::Model(format!(
                "plane of weakness: spacing = {spacing}, expected a finite value > 0 m"
            )));
        }
        if !offset.is_finite() {
            return Err(Error::Model(format!(
                "plane of weakness: offset = {offset}, expected a finite value in m"
            )));
        }
        Ok(PlaneFamily {
            normal: unit,
            spacing,
            offset,
            joint: joint.checked("plane of weakness joint strength")?,
            section: JointSection::Bond,
        })
    }

    /// The family with its joint stresses taken on `section`.
    pub fn with_section(self, section: JointSection) -> Self {
        PlaneFamily { section, ..self }
    }

    /// The plane normal from strike and dip (degrees), in the convention of the
    /// cross-anisotropic axis ([`axis_from_strike_dip`]: (cos α sin β, −sin α sin β, cos β);
    /// dip 0 gives horizontal planes, normal z).
    pub fn normal_from_strike_dip(strike_deg: f64, dip_deg: f64) -> Vec3 {
        axis_from_strike_dip(strike_deg, dip_deg)
    }

    /// The slab index ⌊(n·x − offset)/spacing⌋ of point `x`: points between planes k and
    /// k + 1 have index k; a point exactly on plane k belongs to slab k.
    pub fn slab(&self, x: &Vec3) -> f64 {
        ((self.normal.dot(x) - self.offset) / self.spacing).floor()
    }

    /// Whether the segment from `a` to `b` crosses a plane of the family: the two ends lie
    /// in different slabs. A segment with its upper end exactly on a plane crosses it; one
    /// whose lower end is exactly on a plane (and the upper end below the next) does not.
    pub fn crosses(&self, a: &Vec3, b: &Vec3) -> bool {
        self.slab(a) != self.slab(b)
    }
}
