//! Polycrystals (issue 34, docs/polycrystal.md): a grain map of the packing — each particle's
//! grain — and each grain's crystal orientation, so that a bond inside grain g gets the
//! model's scheme turned into that grain's frame and a bond across a boundary the springs of
//! a documented rule ([`BoundaryRule`]: mean, series, or the grain holding its contact point;
//! `crate::bonds::assign_stiffness_by_grain`).
//!
//! - `centres.rs`: seeded grain centres, uniform in the periodic cell or the specimen's box;
//!   the grain count from a mean grain size in particle diameters.
//! - `assign.rs`: each particle to its nearest centre (minimum image in a periodic cell):
//!   a Voronoi tessellation of the centres.
//! - `orientation.rs`: Bunge Euler angles, uniform random rotations (Shoemake), fibre textures.
//! - `files.rs`: a user's grain ids per particle and Bunge angles per grain.
//! - `spec.rs`: the `[grains]` table of a model file and the grains it builds on a packing.
//! - `map.rs`: [`Grains`], the grain of every particle and the orientation of every grain.
//! - `strength.rs`: bond strengths with the boundary strength factor
//!   ([`assign_strength_by_grain`]).
//!
//! Convention: a grain's orientation is the Bunge matrix g, which maps **sample (lab)
//! coordinates to crystal coordinates** (v_crystal = g·v_sample), the same sense as the cubic
//! scheme's `rotation` (lab → crystal).

pub(crate) mod assign;
pub(crate) mod centres;
pub(crate) mod files;
pub(crate) mod map;
pub(crate) mod orientation;
pub(crate) mod spec;
pub(crate) mod strength;

pub use assign::nearest_centres;
pub use centres::{count_for_mean_size, seeded_centres, GrainRegion};
pub use files::{read_euler_file, read_grain_file};
pub use map::Grains;
pub use orientation::{bunge_deg, bunge_matrix, fibre_orientation, uniform_orientation};
pub use spec::{BoundaryRule, GrainMap, GrainsSpec, Orientations};
pub use strength::assign_strength_by_grain;
