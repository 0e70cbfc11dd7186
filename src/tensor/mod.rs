//! 6×6 Voigt stiffness tensors (order 11, 22, 33, 23, 13, 12; engineering shear strain;
//! `C6[a,b] = C_ijkl` with no factors of 2 or √2; energy w = ½ eᵀC6e).

/// A 6×6 Voigt stiffness matrix (Pa).
pub type Stiffness6 = nalgebra::Matrix6<f64>;
/// A 6-vector in Voigt order (stress in Pa, or engineering strain).
pub type Voigt6 = nalgebra::Vector6<f64>;

/// Voigt index of the tensor index pair (i, j), order 11, 22, 33, 23, 13, 12.
pub const fn voigt_index(i: usize, j: usize) -> usize {
    match (i, j) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (1, 2) | (2, 1) => 3,
        (0, 2) | (2, 0) => 4,
        _ => 5,
    }
}

/// Tensor index pair of Voigt index `a` (inverse of [`voigt_index`]).
pub const VOIGT_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];

/// `v / |v|`, or `None` when |v| is zero or not finite (each caller refuses that in its own
/// words).
pub(crate) fn unit_vector(v: &crate::Vec3) -> Option<crate::Vec3> {
    let len = v.norm();
    (len.is_finite() && len > 0.0).then(|| v / len)
}

/// The symmetric strain tensor of a Voigt engineering strain (ε_ij = e_a/2 off the diagonal).
pub fn strain_tensor(e: &Voigt6) -> crate::Mat3 {
    let mut m = crate::Mat3::zeros();
    for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
        if i == j {
            m[(i, i)] = e[a];
        } else {
            m[(i, j)] = 0.5 * e[a];
            m[(j, i)] = 0.5 * e[a];
        }
    }
    m
}

pub(crate) mod compare;
pub(crate) mod elastic;
pub(crate) mod fit;
pub(crate) mod fourth;
pub(crate) mod polycrystal;
pub(crate) mod rotate;
pub(crate) mod symmetry;
pub(crate) mod waves;

pub use compare::relative_difference;
pub use elastic::{
    check_positive_definite, compliance, cross_anisotropic_from_engineering,
    isotropic_from_bulk_shear, isotropic_moduli, isotropic_stiffness, kelvin_moduli, poisson_100,
    reuss_average, voigt_average, zener_ratio, EngineeringConstants, IsotropicModuli,
};
pub use fit::{fit_symmetric, fit_symmetric_eq27};
pub use fourth::{from_fourth_order, rotate_fourth_order, to_fourth_order, Tensor4};
pub use polycrystal::{
    constraint_moduli, cubic_hashin_shtrikman, cubic_self_consistent_shear,
    hashin_shtrikman_bounds, hashin_shtrikman_estimate, hill_average, isotropic_projection,
    isotropic_tensor, orientation_averages, self_consistent, self_consistent_with,
    universal_anisotropy_index, HashinShtrikmanBound, HashinShtrikmanBounds, OrientationAverages,
    PolycrystalReference, SELF_CONSISTENT_MAX_ITERATIONS, SELF_CONSISTENT_TOLERANCE,
};
pub use rotate::{
    bond_matrix, orthonormalize_rotation, rotate, rotation_to_z, rotation_x, rotation_y, rotation_z,
};
pub(crate) use symmetry::{cubic_tensor, transverse_tensor};
pub use symmetry::{
    CubicProjection, CubicUncertainty, TransverseProjection, TransverseUncertainty,
    OFF_SYMMETRY_TERMS,
};
pub use waves::{acoustic_tensor, phase_velocities, PhaseVelocities, WaveMode};
