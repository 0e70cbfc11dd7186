//! Law (a): YADE 2023.02a's cohesive bond, reproduced step for step.
//!
//! `Ig2_Sphere_Sphere_ScGeom6D(avoidGranularRatcheting=False)` +
//! `Ip2_CohFrictMat_CohFrictMat_CohFrictPhys` + `Law2_ScGeom6D_CohFrictPhys_CohesionMoment`
//! with per-interaction k_n, k_s, k_r, k_tw, `unp` = the initial penetration depth
//! (stress-free gap bonds), `unpMax = −1`, adhesions so large that nothing breaks,
//! `momentRotationLaw = True`, `useIncrementalForm = False`, no creep:
//!
//! - F_n = k_n·(δ − δ₀) along the current normal, δ = R_i + R_j − |l| (compression > 0);
//! - F_s: the previous shear force rotated with the contact (normal change n_old × n and
//!   the mean spin dt·½ n_old·(ω_i + ω_j) about n_old), minus k_s·(tangential relative
//!   velocity at the mid-gap contact point)·dt;
//! - M = k_tw·θ_tw·n + k_r·θ_b from the relative rotation (q_i q_i0*)(q_j0 q_j*);
//! - force −F_n n − F_s on i at the contact point, its opposite on j; torque −M on i, +M on j.

use super::{LinearBondKernel, MomentForm};
use crate::bonds::BondStiffness;
use crate::Result;

/// Law (a) for springs `k` (k_r, k_tw as given; zero disables that moment).
pub fn yade_cohesive_law(k: &BondStiffness) -> Result<LinearBondKernel> {
    LinearBondKernel::new(
        "yade",
        [&k.kn, &k.ks, &k.kr, &k.ktw],
        MomentForm::Orientation,
        None,
    )
}
