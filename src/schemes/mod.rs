//! Per-bond stiffness schemes: a bond's normal and shear stiffness as a function of its
//! initial orientation.
//!
//! Every scheme implements [`StiffnessScheme`], which gives the *magnitudes* along a lab
//! unit normal; [`Geometry`] turns a magnitude into a spring constant for a bond of given
//! radii and length (the `[geometry]` table of the model file).
//!
//! - `cubic.rs`: overlapping spheroids with cubic symmetry (Truszkowska et al. 2018, Eqs. 6–16,
//!   Sec. 6.1 extension).
//! - `cross_anisotropic.rs`: Šmilauer's elliptic microplane scheme (Woo DEM).
//! - `isotropic.rs`: constant magnitudes (Kumar 2016's Σ_N, Σ_T and the plain baseline).

pub(crate) mod cross_anisotropic;
pub(crate) mod cubic;
pub(crate) mod geometry;
pub(crate) mod isotropic;

pub use cross_anisotropic::{
    axis_from_strike_dip, dependent_c44, inverse_block, microplane_matrix, CrossAnisotropic,
};
pub use cubic::AxisFamily;
pub use cubic::{
    envelope_100, envelope_110, envelope_111, orthonormalize_rotation, rotation_from_euler_zyz_deg,
    spheroid_radius, CubicModel, CubicSpheroid, AXES_100, AXES_110, AXES_111,
};
pub use geometry::Springs;
pub use geometry::{BondLength, BondRadius, Convention, Geometry, Moments};
pub use isotropic::Isotropic;

use crate::Vec3;

crate::names::named! {
    /// The schemes by their `kind` in the model file (`[scheme] kind = "cubic"`): the one
    /// list the model reader, its messages and the reports use.
    pub enum SchemeKind ("[scheme] kind") {
        /// `cubic.rs`: Truszkowska 2018's overlapping spheroids.
        Cubic = "cubic", "overlapping spheroids with cubic symmetry (Truszkowska 2018)";
        /// `cross_anisotropic.rs`: Šmilauer's elliptic scheme, given by its target tensor.
        CrossAnisotropic = "cross-anisotropic",
            "Šmilauer's elliptic scheme for a transversely isotropic target tensor";
        /// `isotropic.rs`: constant magnitudes.
        Isotropic = "isotropic", "constant normal and shear magnitudes";
    }
}

/// Normal and shear magnitudes of a bond along one direction, in the unit of the model's
/// geometry convention (Pa/m for `area`, Pa for `modulus` and `kumar`, N/m for `spring`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Magnitudes {
    /// Normal magnitude.
    pub normal: f64,
    /// Shear (tangential) magnitude.
    pub shear: f64,
}

/// A direction-dependent bond stiffness law.
pub trait StiffnessScheme: Send + Sync {
    /// Short name for reports (`cubic zener-above-1`, `cross-anisotropic`, …).
    fn name(&self) -> String;

    /// Normal and shear magnitudes for a bond with lab-frame unit normal `n`.
    /// Must be even in `n` (a bond has no sign).
    fn magnitudes(&self, n: &Vec3) -> Magnitudes;

    /// Unit normals (lab frame) of great circles across which [`Self::magnitudes`] may have a
    /// kink; the orientation quadrature splits the sphere along them so that Gauss rules
    /// converge exponentially. Empty for smooth schemes.
    fn kink_planes(&self) -> Vec<Vec3> {
        Vec::new()
    }
}
