#![warn(missing_docs)]
//! # anisobond
//!
//! Bonded-particle DEM models of *anisotropic* elastic solids.
//!
//! Data flows one way: [`packing`] (spheres, periodic cell) → [`bonds`] (which pairs are
//! glued, their branch vectors) → [`schemes`] (per-bond normal/shear stiffness from the
//! bond's orientation, Truszkowska 2018 and Šmilauer) → [`tensor`] / [`homogenize`]
//! (the assembly's 6×6 stiffness) → export.
//!
//! Units are SI throughout: m, N, Pa, N/m for springs, N·m/rad for rotational springs.
//! Stiffness tensors are 6×6 Voigt matrices in the order 11, 22, 33, 23, 13, 12 acting on
//! engineering strain. The library never prints; the `anisobond` binary does.
//!
//! From a packing file to the relaxed stiffness tensor: read the packing, bond it by a model
//! into an [`Assembly`], ask for a tensor by [`Method`]:
//!
//! ```
//! # fn main() -> anisobond::Result<()> {
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("packing.txt");
//! # let opts = anisobond::packing::generate::GenerateOptions { n_particles: 300, ..Default::default() };
//! # anisobond::packing::io::write_packing(&path, &anisobond::packing::generate::generate(&opts, &|_| {})?)?;
//! use anisobond::prelude::*;
//! let packing = read_packing(&path)?;
//! let assembly = Assembly::new(packing, Model::truszkowska_mrv())?;
//! let relaxed = assembly.tensor(&Method::relaxed())?;
//! println!("C11 = {:.3} GPa", relaxed.report.cubic.c11 / 1e9);
//! # assert!(relaxed.report.cubic.c11 > 0.0);
//! # Ok(())
//! # }
//! ```

pub mod assembly;
pub mod bonds;
pub mod calibrate;
pub mod cavity;
pub mod dem;
pub mod error;
pub mod export;
#[cfg(feature = "ffi")]
pub mod ffi;
pub mod history;
pub mod homogenize;
pub mod io;
pub(crate) mod keys;
pub mod model;
pub mod names;
pub mod packing;
#[cfg(feature = "plot")]
pub mod plot;
#[cfg(feature = "python")]
pub mod python;
pub mod schemes;
pub mod specimen;
pub mod strength;
pub mod study;
pub mod tensor;
#[cfg(feature = "engines")]
pub mod validate;

pub use assembly::{Assembly, Method};
pub use error::{Error, Result};

/// The names most programs need: `use anisobond::prelude::*;`.
pub mod prelude {
    pub use crate::assembly::{Assembly, Detail, Method, TensorResult};
    pub use crate::homogenize::relaxed::RelaxedOptions;
    pub use crate::homogenize::report::TensorReport;
    pub use crate::model::Model;
    pub use crate::packing::io::{read_packing, write_packing};
    pub use crate::packing::Packing;
    pub use crate::tensor::{Stiffness6, Voigt6};
    pub use crate::{Error, Mat3, Vec3};
}

/// 3-vector of `f64` (positions in m, unit normals, …).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3×3 matrix of `f64` (rotations, stress in Pa, …).
pub type Mat3 = nalgebra::Matrix3<f64>;
