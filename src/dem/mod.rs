//! The reference DEM integrator: bonded spheres in a periodic cell deformed by a velocity
//! gradient (or free), four bond laws, Cundall local and viscous bond damping, the Love
//! stress, energies, and the element tests that measure the 6×6 stiffness dynamically.
//!
//! - [`state`]: structure-of-arrays particles, the deforming cell, bond topology + CSR.
//! - [`laws`]: the [`laws::BondLaw`] trait and laws (a) YADE cohesive, (b) parallel bond,
//!   (c) Kumar 2016, (d) LAMMPS bpm/rotational.
//! - [`sim`]: [`sim::Simulation`], YADE's NewtonIntegrator step by step.
//! - [`element`]: six strain paths → Truszkowska 2018 Eq. 27 → C.
//! - [`equilibrium`]: the stop rule of every damped relaxation (unbalanced force/torque).
//! - [`buckling`]: quasi-static compression of a clamped bar (Kumar 2016 Sec. 5).
//!
//! Every parallel loop writes per-item results and every reduction sums fixed chunks in
//! order, so a history is bit-for-bit the same on any number of threads.

pub mod buckling;
pub mod element;
pub mod equilibrium;
pub mod grips;
pub mod laws;
pub mod measure;
#[cfg(target_arch = "x86_64")]
mod particle_lanes;
pub mod quat;
pub mod servo;
pub mod sim;
pub mod state;
pub mod stress_tests;

pub use laws::BondLaw;
pub use sim::{DemOptions, Energies, ExternalForces, Simulation, StabilityReport};
pub use state::{MassOptions, Particles};

use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::Result;

/// Which bond law the integrator uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LawKind {
    /// (a) YADE 2023.02a cohesive law (orientation-based moments).
    #[default]
    Yade,
    /// (b) Potyondy–Cundall parallel bond (Truszkowska 2018 Eq. 3).
    ParallelBond,
    /// (c) Kumar 2016 Eqs. 2–8 with his viscous bond damping.
    Kumar,
    /// (d) LAMMPS `bond_style bpm/rotational` (`break no smooth no normalize no`, undamped),
    /// k_r = k_n, k_s = k_s, k_t = k_tw, k_b = k_r.
    LammpsBpm,
}

/// Build the bond law `kind` for the springs `k` of `bonds`.
pub fn build_law(
    kind: LawKind,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
) -> Result<Box<dyn BondLaw>> {
    Ok(match kind {
        LawKind::Yade => Box::new(laws::yade::yade_cohesive_law(k)?),
        LawKind::ParallelBond => Box::new(laws::parallel_bond::parallel_bond_law(k)?),
        LawKind::Kumar => Box::new(laws::kumar::kumar_law(
            packing,
            bonds,
            k,
            Some(laws::kumar::KUMAR_DAMPING),
        )?),
        LawKind::LammpsBpm => Box::new(laws::lammps_bpm::lammps_bpm_law(k)?),
    })
}
