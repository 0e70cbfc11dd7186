//! From per-bond springs to the assembly's 6×6 stiffness tensor.
//!
//! - [`mean_field`]: the continuous orientation integral (Truszkowska 2018 App. A;
//!   Šmilauer's microplane integral), no packing needed.
//! - [`voigt`]: the sum over the actual bonds (uniform strain; Kruyt 2014 Eq. 27).
//! - [`relaxed`]: the exact quasi-static tensor from one sparse equilibrium solve.
//! - [`laf`]: Kruyt 2014's local-adjustment-field estimates (stress- and energy-based).
//! - [`cholesky`], [`two_level`]: the relaxed solve's direct solver and CG preconditioner.
//! - [`network`]: the linearised bond network the last two share.
//! - [`geometric`]: the initial-stress stiffness of a pre-loaded network;
//!   [`buckling`]: the linearised buckling load of a clamped bar (Kumar 2016 Sec. 5).
//! - [`prestress`]: the tangent of an assembly deformed from a loaded state (geometric terms).
//! - [`report`]: the SPEC tensor report (JSON).

pub mod buckling;
pub mod cholesky;
pub mod geometric;
pub mod laf;
pub mod mean_field;
pub mod network;
pub mod prestress;
pub mod relaxed;
pub mod report;
pub mod sparse;
pub mod two_level;
pub mod voigt;

use crate::tensor::{Stiffness6, VOIGT_PAIRS};
use crate::Vec3;

/// The lattice tensor of one bond per unit l²:
/// C_ijkl = k_n·n_in_jn_kn_l + k_t·[sym(δ_ik n_j n_l) − n_in_jn_kn_l], symmetrised in (ij)
/// and (kl) (Šmilauer's lattice tensor; Kruyt 2014 Eq. 27 with S = k_t I + (k_n − k_t) nn).
pub fn bond_lattice_tensor(n: &Vec3, kn: f64, kt: f64) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    let d = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
    for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
        for (b, &(k, l)) in VOIGT_PAIRS.iter().enumerate().skip(a) {
            let nnnn = n[i] * n[j] * n[k] * n[l];
            let sym = 0.25
                * (d(i, k) * n[j] * n[l]
                    + d(j, k) * n[i] * n[l]
                    + d(i, l) * n[j] * n[k]
                    + d(j, l) * n[i] * n[k]);
            let v = kn * nnnn + kt * (sym - nnnn);
            c[(a, b)] = v;
            c[(b, a)] = v;
        }
    }
    c
}
