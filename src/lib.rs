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

pub mod bonds;
pub mod calibrate;
pub mod dem;
pub mod error;
pub mod export;
#[cfg(feature = "ffi")]
pub mod ffi;
pub mod homogenize;
pub mod io;
pub mod model;
pub mod packing;
#[cfg(feature = "plot")]
pub mod plot;
pub mod schemes;
pub mod tensor;
#[cfg(feature = "engines")]
pub mod validate;

pub use error::{Error, Result};

/// 3-vector of `f64` (positions in m, unit normals, …).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3×3 matrix of `f64` (rotations, stress in Pa, …).
pub type Mat3 = nalgebra::Matrix3<f64>;
