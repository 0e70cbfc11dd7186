//! Law (b): the parallel bond of Potyondy & Cundall (2004), Truszkowska 2018 Eq. 3:
//! dF = k̄_n A du_n + k̄_s A du_s, dM = −k̄_s J dθ_twist − k̄_n I dθ_bend, all incremental and
//! rotated with the contact, with A = πR_b², I = πR_b⁴/4, J = πR_b⁴/2.
//!
//! From the assigned springs k_n = k̄_n A and k_s = k̄_s A (the `area` convention) the moment
//! springs follow as k_r = k_n·I/A = k_n R_b²/4 and k_tw = k_s·J/A = k_s R_b²/2. The normal
//! force is written in total form k_n(δ − δ₀), identical to the increments' sum for a
//! linear spring.

use super::{LinearBondKernel, MomentForm};
use crate::bonds::BondStiffness;
use crate::Result;

/// Law (b) for springs `k` (uses k_n, k_s and the bond radius R_b; the moment springs are
/// derived from them, any k_r/k_tw in `k` are ignored).
pub fn parallel_bond_law(k: &BondStiffness) -> Result<LinearBondKernel> {
    let kr: Vec<f64> =
        k.kn.iter()
            .zip(&k.radius)
            .map(|(kn, r)| kn * r * r / 4.0)
            .collect();
    let ktw: Vec<f64> =
        k.ks.iter()
            .zip(&k.radius)
            .map(|(ks, r)| ks * r * r / 2.0)
            .collect();
    LinearBondKernel::new(
        "parallel-bond",
        [&k.kn, &k.ks, &kr, &ktw],
        MomentForm::Incremental,
        None,
    )
}
