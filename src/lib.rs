#![warn(missing_docs)]
#![warn(unnameable_types)]
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
//! # let opts = anisobond::packing::GenerateOptions { n_particles: 300, ..Default::default() };
//! # anisobond::packing::write_packing(&path, &anisobond::packing::generate(&opts, &|_| {})?)?;
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
pub mod grains;
pub mod history;
pub mod homogenize;
pub mod io;
pub(crate) mod keys;
pub mod manybody;
pub mod model;
pub mod names;
pub mod packing;
#[cfg(feature = "plot")]
pub mod plot;
#[cfg(feature = "python")]
#[allow(unnameable_types)] // its pyo3 classes are named from Python, not from Rust
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

pub mod prelude {
    //! The names a program starts from: `use anisobond::prelude::*;`.
    //!
    //! A packing ([`Packing`], [`read_packing`]) and a [`Model`] make an [`Assembly`] (its
    //! [`BondSet`] and springs); a [`Method`] (by name: [`MethodKind`], with
    //! [`MethodOptions`]) gives its tensor; the studies ([`buckling`], [`cavity`], [`demo`],
    //! [`domain`], [`strength_test`]) run with their options into their reports; with the `engines` feature,
    //! an engine runner (`Yade`, `Lammps`, `Liggghts`) checks a problem through `validate`.

    pub use crate::assembly::{
        Assembly, Detail, EqualSpheres, Method, MethodKind, MethodOptions, TensorResult,
    };
    pub use crate::bonds::{BondSet, BondStiffness, BondingRule};
    pub use crate::calibrate::DomainOptions;
    pub use crate::homogenize::{RelaxedOptions, TensorReport};
    pub use crate::model::{Model, SchemeSpec};
    pub use crate::names::Named;
    pub use crate::packing::{read_packing, write_packing, Packing, PeriodicCell};
    pub use crate::schemes::SchemeKind;
    pub use crate::study::buckling::{self, BucklingReport, BucklingStudyOptions};
    pub use crate::study::cavity::{self, CavityReport, CavityStudyOptions};
    pub use crate::study::demo::{self, DemoOptions, DemoReport};
    pub use crate::study::domain::{self, DomainOn, DomainReport};
    pub use crate::study::polycrystal::{self, PolycrystalOptions, PolycrystalReport};
    pub use crate::study::strength_test::{self, StrengthTestOptions, StrengthTestReport};
    pub use crate::study::OptionNames;
    pub use crate::tensor::{Stiffness6, Voigt6};
    #[cfg(feature = "engines")]
    pub use crate::validate::{
        lammps::Lammps, liggghts::Liggghts, validate, validate_specimen, yade::Yade, Engine,
        Problem, TestKind, Tolerances,
    };
    pub use crate::{Error, Mat3, Result, Vec3};
}

/// 3-vector of `f64` (positions in m, unit normals, …).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3×3 matrix of `f64` (rotations, stress in Pa, …).
pub type Mat3 = nalgebra::Matrix3<f64>;
