//! Bond strength: how strong each bond is, by its orientation and position, and when it
//! breaks under each bond law (issue 32; docs/strength.md).
//!
//! Data flow, beside the stiffness's: a [`StrengthScheme`] gives a bond its [`Strength`]
//! (stresses in Pa and a friction coefficient) from its initial unit normal, as the
//! stiffness schemes give magnitudes ([`crate::schemes`]); a [`PlaneFamily`] (a plane of
//! weakness) replaces it by the joint's strength for the bonds whose segment crosses one of
//! its planes; an optional [`Scatter`] multiplies each bond's strengths by a seeded random
//! factor. [`assign_strength`] does this for every bond into [`BondStrengths`] (structure of
//! arrays, like [`crate::bonds::BondStiffness`]). Each law then turns a bond's stresses into
//! its own limits ([`criteria`]: YADE's adhesions, LAMMPS's `f_rc f_sc τ_bc τ_tc`, the
//! parallel bond's section, the joint's forces) and judges the bond's local loads with a pure
//! function returning a [`Failure`].
//!
//! Sign convention of every criterion: the normal force F_n is compression positive, as
//! YADE's `normalForce` and [`crate::dem::laws::BondLaw::bond_forces`]; a tensile bond has
//! F_n < 0.

pub mod criteria;
pub mod jaeger;
pub mod peak;
pub mod planes;
pub mod scatter;
pub mod schemes;
pub mod spec;

pub use criteria::{Failure, LocalLoads, Mode};
pub use planes::{JointSection, PlaneFamily};
pub use scatter::Scatter;
pub use schemes::StrengthScheme;
pub use spec::StrengthSpec;

use crate::{Error, Result, Vec3};
use rayon::prelude::*;

/// The strength of one bond, as stresses on its cross-section (Pa) and a friction
/// coefficient. Each law reads the fields it has (docs/strength.md, "Units per law").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strength {
    /// Tensile strength σ_t (Pa): the normal stress at which a bond in pure tension breaks.
    pub tensile: f64,
    /// Cohesion c (Pa): the shear strength at zero normal stress.
    pub cohesion: f64,
    /// Friction coefficient μ = tan φ (dimensionless) of the Coulomb term μ·σ_n (compression
    /// positive); used by YADE's CohFrict law and by joints.
    pub friction: f64,
    /// Bending limit σ_b (Pa): the extreme-fibre normal stress of a bending moment,
    /// |M_b| = σ_b·I/R_b (LAMMPS τ_bc, YADE's rolling adhesion).
    pub bending: f64,
    /// Twisting limit τ_t (Pa): the extreme-fibre shear stress of a twisting moment,
    /// |M_t| = τ_t·J/R_b (LAMMPS τ_tc, YADE's twisting adhesion).
    pub twisting: f64,
}

impl Strength {
    /// Tensile σ_t and cohesion c (Pa) with no friction, the bending limit σ_t and the
    /// twisting limit c.
    pub fn new(tensile: f64, cohesion: f64) -> Strength {
        Strength {
            tensile,
            cohesion,
            friction: 0.0,
            bending: tensile,
            twisting: cohesion,
        }
    }

    /// The fields by name, in a fixed order (for checks and messages).
    pub fn fields(&self) -> [(&'static str, f64); 5] {
        [
            ("tensile", self.tensile),
            ("cohesion", self.cohesion),
            ("friction", self.friction),
            ("bending", self.bending),
            ("twisting", self.twisting),
        ]
    }

    /// Refuses a field that is not finite and ≥ 0, naming `what` and the field.
    pub fn checked(self, what: &str) -> Result<Strength> {
        for (name, v) in self.fields() {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::Model(format!(
                    "{what}: {name} = {v}, expected a finite value >= 0 (Pa; friction = tan φ)"
                )));
            }
        }
        Ok(self)
    }

    /// `w·a + (1 − w)·b` field by field (friction included).
    pub fn blend(a: &Strength, b: &Strength, w: f64) -> Strength {
        let mix = |x: f64, y: f64| w * x + (1.0 - w) * y;
        Strength {
            tensile: mix(a.tensile, b.tensile),
            cohesion: mix(a.cohesion, b.cohesion),
            friction: mix(a.friction, b.friction),
            bending: mix(a.bending, b.bending),
            twisting: mix(a.twisting, b.twisting),
        }
    }

    /// The strengths (not the friction) times `factor`: the random scatter of a bond.
    pub fn scaled(&self, factor: f64) -> Strength {
        Strength {
            tensile: self.tensile * factor,
            cohesion: self.cohesion * factor,
            friction: self.friction,
            bending: self.bending * factor,
            twisting: self.twisting * factor,
        }
    }
}

/// Marks a bond of [`BondStrengths::joint`] that crosses no plane of weakness.
pub const NO_JOINT: u16 = u16::MAX;

/// Every bond's strength, structure of arrays aligned with a [`crate::bonds::BondSet`]:
/// what an integrator's bond loop reads, one column per field.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BondStrengths {
    /// σ_t (Pa).
    pub tensile: Vec<f64>,
    /// c (Pa).
    pub cohesion: Vec<f64>,
    /// μ = tan φ.
    pub friction: Vec<f64>,
    /// σ_b (Pa).
    pub bending: Vec<f64>,
    /// τ_t (Pa).
    pub twisting: Vec<f64>,
    /// The index of the plane family ([`StrengthSpec::planes`]) whose plane the bond
    /// crosses, or [`NO_JOINT`]: a joint bond is judged by [`criteria::joint`] on that
    /// family's plane.
    pub joint: Vec<u16>,
    /// Unit normals of the plane families by index (`joint[b]` indexes it): the plane a
    /// joint bond's force is resolved on ([`criteria::resolve_on_plane`]).
    pub plane_normals: Vec<Vec3>,
    /// The joint section of the plane families by index, aligned with `plane_normals`: the
    /// area a joint bond's stresses are taken on ([`JointSection`]).
    pub plane_sections: Vec<JointSection>,
}

impl BondStrengths {
    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.tensile.len()
    }

    /// True when there are no bonds.
    pub fn is_empty(&self) -> bool {
        self.tensile.is_empty()
    }

    /// The strength of bond `b`.
    pub fn get(&self, b: usize) -> Strength {
        Strength {
            tensile: self.tensile[b],
            cohesion: self.cohesion[b],
            friction: self.friction[b],
            bending: self.bending[b],
            twisting: self.twisting[b],
        }
    }

    /// The plane family of bond `b` when it is a joint bond.
    pub fn joint_of(&self, b: usize) -> Option<usize> {
        match self.joint[b] {
            NO_JOINT => None,
            k => Some(k as usize),
        }
    }

    /// One value per bond from its index and strength, in parallel (the order of the
    /// result is the bonds'): a law's limits for its bond loop, e.g.
    /// `strengths.map(|b, s| BpmLimits::of(&s, radius[b], pi_hat))`.
    pub fn map<T: Send>(&self, f: impl Fn(usize, Strength) -> T + Sync) -> Vec<T> {
        (0..self.len())
            .into_par_iter()
            .map(|b| f(b, self.get(b)))
            .collect()
    }

    fn push(&mut self, s: Strength, joint: u16) {
        self.tensile.push(s.tensile);
        self.cohesion.push(s.cohesion);
        self.friction.push(s.friction);
        self.bending.push(s.bending);
        self.twisting.push(s.twisting);
        self.joint.push(joint);
    }
}

/// Every bond's strength by `spec`: the scheme's strength along the bond's unit normal, or
/// the joint strength of the first plane family (in `spec.planes` order) whose plane the
/// segment from `start[b]` to `start[b] + branch[b]` crosses, times the bond's scatter
/// factor. `start` is the first sphere's centre and `branch` the vector to the (image of
/// the) second (m), one per bond. Parallel; the result does not depend on the thread count
/// (each bond's random factor comes from the seed and the bond's index only).
pub fn strengths_along(
    spec: &StrengthSpec,
    start: &[Vec3],
    branch: &[Vec3],
) -> Result<BondStrengths> {
    if start.len() != branch.len() {
        return Err(Error::Invalid(format!(
            "strength: {} bond starts but {} branch vectors (one of each per bond)",
            start.len(),
            branch.len()
        )));
    }
    if spec.planes.len() >= NO_JOINT as usize {
        return Err(Error::Model(format!(
            "strength: {} plane families; at most {} are supported",
            spec.planes.len(),
            NO_JOINT - 1
        )));
    }
    for (b, l) in branch.iter().enumerate() {
        let len = l.norm();
        if !(len.is_finite() && len > 0.0) {
            return Err(Error::Invalid(format!(
                "strength: bond {b} has a branch vector of length {len}, expected finite and > 0 m"
            )));
        }
    }
    let per_bond: Vec<(Strength, u16)> = (0..start.len())
        .into_par_iter()
        .map(|b| {
            let l = branch[b];
            let joint = spec
                .planes
                .iter()
                .position(|p| p.crosses(&start[b], &(start[b] + l)));
            let (base, tag) = match joint {
                Some(k) => (spec.planes[k].joint, k as u16),
                None => (spec.scheme.strength(&(l / l.norm())), NO_JOINT),
            };
            let factor = spec.scatter.as_ref().map_or(1.0, |s| s.factor(b as u64));
            (base.scaled(factor), tag)
        })
        .collect();
    let mut out = BondStrengths {
        plane_normals: spec.planes.iter().map(|p| p.normal).collect(),
        plane_sections: spec.planes.iter().map(|p| p.section).collect(),
        ..Default::default()
    };
    for (s, tag) in per_bond {
        out.push(s, tag);
    }
    Ok(out)
}

/// [`strengths_along`] for the bonds of a packing: starts at sphere i's centre, branch
/// vectors normal·length (the periodic image of j included, as [`crate::bonds::BondSet`]
/// stores them).
pub fn assign_strength(
    packing: &crate::packing::Packing,
    bonds: &crate::bonds::BondSet,
    spec: &StrengthSpec,
) -> Result<BondStrengths> {
    let start: Vec<Vec3> = bonds
        .i
        .iter()
        .map(|&i| packing.positions[i as usize])
        .collect();
    let branch: Vec<Vec3> = bonds
        .normal
        .iter()
        .zip(&bonds.length)
        .map(|(n, l)| n * *l)
        .collect();
    strengths_along(spec, &start, &branch)
}
