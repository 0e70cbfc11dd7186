//! Voigt (uniform-strain, affine) stiffness: the sum over the actual bonds,
//! C = (1/V)·Σ_b |l_b|²·[k_n nnnn + k_t(sym(δnn) − nnnn)] (Šmilauer's lattice tensor;
//! Kruyt 2014 Eq. 27 with S = k_t I + (k_n − k_t) nn). Bending and twisting springs do
//! not enter: under uniform strain the particles do not rotate relative to each other.

use super::bond_lattice_tensor;
use crate::bonds::{BondSet, BondStiffness};
use crate::tensor::Stiffness6;
use rayon::prelude::*;

/// Bonds per parallel work item; fixed so that the summation order, hence the result, does
/// not depend on the number of threads.
const CHUNK: usize = 4096;

/// The Voigt tensor (Pa) of `bonds` with springs `k` in a volume `volume` (m³).
pub fn voigt_tensor(bonds: &BondSet, k: &BondStiffness, volume: f64) -> Stiffness6 {
    let n = bonds.len();
    let partial: Vec<Stiffness6> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut acc = Stiffness6::zeros();
            for b in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let l2 = bonds.length[b] * bonds.length[b];
                acc += bond_lattice_tensor(&bonds.normal[b], k.kn[b] * l2, k.ks[b] * l2);
            }
            acc
        })
        .collect();
    partial.iter().fold(Stiffness6::zeros(), |a, b| a + b) / volume
}
