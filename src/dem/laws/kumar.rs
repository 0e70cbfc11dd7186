//! Law (c): Kumar et al. 2016, Eqs. 1–8. With R* = R_iR_j/(R_i + R_j) (Eq. 1):
//! N = −2Σ_N R* δ_N n (Eq. 2), T = −2Σ_T R* δ_T t (Eq. 3), resisting moments
//! M_N = −4Σ_T R*³ θ_N (twist, Eq. 7) and M_T = −2Σ_N R*³ θ_T (bending, Eq. 8), and viscous
//! bond damping η = 2ξ√(m k) (Eqs. 5–6; ξ_n = 0.05, ξ_t = 0.025 in the paper).
//!
//! Written through the assigned springs k_n = 2Σ_N R*, k_s = 2Σ_T R*:
//! k_bend = k_n R*², k_twist = 2 k_s R*². Moments accumulate incrementally.

use super::{LinearBondKernel, MomentForm, ViscousDamping};
use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::Result;

/// Kumar's damping fractions: ξ_n = 0.05, ξ_t = 0.025 (Kumar 2016, after Eq. 6).
pub const KUMAR_DAMPING: ViscousDamping = ViscousDamping {
    normal: 0.05,
    tangential: 0.025,
};

/// Law (c) for springs `k` on `bonds` of `packing`; `damping` = None disables the viscous
/// bond damping (use [`KUMAR_DAMPING`] for the paper's).
pub fn kumar_law(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    damping: Option<ViscousDamping>,
) -> Result<LinearBondKernel> {
    let r_star: Vec<f64> = (0..bonds.len())
        .map(|b| {
            let (ri, rj) = (
                packing.radii[bonds.i[b] as usize],
                packing.radii[bonds.j[b] as usize],
            );
            ri * rj / (ri + rj)
        })
        .collect();
    let kr: Vec<f64> = k.kn.iter().zip(&r_star).map(|(kn, r)| kn * r * r).collect();
    let ktw: Vec<f64> =
        k.ks.iter()
            .zip(&r_star)
            .map(|(ks, r)| 2.0 * ks * r * r)
            .collect();
    LinearBondKernel::new(
        "kumar",
        [&k.kn, &k.ks, &kr, &ktw],
        MomentForm::Incremental,
        damping,
    )
}
