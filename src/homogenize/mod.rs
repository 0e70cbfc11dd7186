//! From per-bond springs to the assembly's 6×6 stiffness tensor.
//!
//! - `mean_field.rs`: the continuous orientation integral (Truszkowska 2018 App. A;
//!   Šmilauer's microplane integral), no packing needed.
//! - `voigt.rs`: the sum over the actual bonds (uniform strain; Kruyt 2014 Eq. 27).
//! - `relaxed.rs`: the exact quasi-static tensor from one sparse equilibrium solve.
//! - `local.rs`: the relaxed solution's local fields under a macroscopic strain (per-particle
//!   fluctuation, rotation, Love–Weber stress, fitted strain; bond forces) and their
//!   statistics per label.
//! - `laf.rs`: Kruyt 2014's local-adjustment-field estimates (stress- and energy-based).
//! - `cholesky.rs`, `two_level.rs`, `amg.rs`: the relaxed solve's direct solver and CG
//!   preconditioners (two-level; smoothed-aggregation multigrid).
//! - `network.rs`: the linearised bond network the last two share; `bond_springs.rs`: its K
//!   applied bond by bond (the CG's product, off-diagonal blocks never formed).
//! - `term_operator.rs`: the many-body term's Hessian, load and affine tensor for the relaxed
//!   solve, in factored form; `term_preconditioner.rs`: the two-level coarse space with it
//!   (rigid and uniform-strain modes per aggregate).
//! - `geometric.rs`: the initial-stress stiffness of a pre-loaded network;
//!   `buckling.rs`: the linearised buckling load of a clamped bar (Kumar 2016 Sec. 5).
//! - `prestress.rs`: the tangent of an assembly deformed from a loaded state (geometric terms).
//! - `report.rs`: the SPEC tensor report (JSON).
//! - `system.rs`: the relaxed solve's K, G, H and V handed out (CSR), for other solvers.

pub(crate) mod amg;
mod amg_blocks;
pub(crate) mod bond_springs;
pub(crate) mod buckling;
pub(crate) mod cholesky;
pub(crate) mod fused;
pub(crate) mod geometric;
pub(crate) mod laf;
pub(crate) mod local;
pub(crate) mod mean_field;
pub(crate) mod network;
pub(crate) mod prestress;
pub(crate) mod relaxed;
pub(crate) mod report;
pub(crate) mod sparse;
pub(crate) mod system;
pub(crate) mod term_operator;
pub(crate) mod term_preconditioner;
pub(crate) mod two_level;
pub(crate) mod voigt;

pub use amg::Amg;
pub use buckling::UpdatedGeometryResult;
pub use buckling::{
    clamped_bar_buckling, euler_stress, extensible_stress, mazzilli_stress, BucklingOptions,
    BucklingResult, ClampedBar, PreBuckling, RoundBar,
};
pub use cholesky::BlockCholesky;
pub use geometric::geometric_stiffness;
pub use laf::laf_tensor;
pub use laf::LafResult;
pub use local::{
    local_fields, local_fields_with_term, DegenerateFit, GroupStatistics, LocalFields,
    LocalOptions, LocalReport, Unfitted, UnfittedReason,
};
pub use mean_field::mean_field;
pub use mean_field::{
    equal_sphere_prefactor, mean_field_converged, orientation_average, SphereQuadrature,
    DEFAULT_ORDER,
};
pub use network::bond_geometric_stiffness;
pub use network::{Element, NullSpaceReport};
pub use network::{LeverArm, Network};
pub use prestress::PrestressedTensor;
pub use prestress::{prestressed_tensor, stress_measure_correction, Prestress};
pub use relaxed::{
    relaxed_tensor, relaxed_tensor_with_term, CgPreconditioner, RelaxedOptions, RelaxedResult,
    RelaxedSolver, DEFAULT_PARTICLES_PER_AGGREGATE, MAX_AGGREGATES,
};
pub use report::Uncertainty;
pub use report::{CubicSummary, TensorReport};
pub use sparse::BlockSparse;
pub use system::{relaxed_system, RelaxedSystem};
pub use two_level::TwoLevel;
pub use voigt::voigt_tensor;

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
