//! The reference DEM integrator: bonded spheres in a periodic cell deformed by a velocity
//! gradient (or free), four bond laws, Cundall local and viscous bond damping, the Love
//! stress, energies, and the element tests that measure the 6×6 stiffness dynamically.
//!
//! - `state.rs`: structure-of-arrays particles, the deforming cell, bond topology + CSR.
//! - [`laws`]: the [`BondLaw`] trait and laws (a) YADE cohesive, (b) parallel bond,
//!   (c) Kumar 2016, (d) LAMMPS bpm/rotational.
//! - `sim.rs`: [`Simulation`], YADE's NewtonIntegrator step by step.
//! - `breakage.rs`: [`BondCriteria`], one failure criterion per bond by law; bonds break
//!   after a force evaluation ([`Simulation::set_breakage`], [`BreakEvent`]).
//! - `element.rs`: six strain paths → Truszkowska 2018 Eq. 27 → C.
//! - `equilibrium.rs`: the stop rule of every damped relaxation (unbalanced force/torque).
//! - `buckling.rs`: quasi-static compression of a clamped bar (Kumar 2016 Sec. 5).
//!
//! Every parallel loop writes per-item results and every reduction sums fixed chunks in
//! order, so a history is bit-for-bit the same on any number of threads.

pub(crate) mod breakage;
pub(crate) mod buckling;
pub(crate) mod contacts;
pub(crate) mod element;
pub(crate) mod equilibrium;
pub(crate) mod grips;
pub mod laws;
pub(crate) mod manybody;
pub(crate) mod measure;
#[cfg(target_arch = "x86_64")]
mod particle_lanes;
pub(crate) mod quat;
pub(crate) mod servo;
pub(crate) mod sim;
pub(crate) mod state;
pub(crate) mod stress_tests;

pub use breakage::{BondCriteria, BondCriterion, BreakEvent};
pub use buckling::{compress_clamped_bar, CompressionOptions, Loading};
pub use buckling::{CompressionPoint, CompressionResult};
pub use contacts::{Contact, ContactLaw, Contacts, PairSet};
pub use element::{dynamic_tensor, path_gradient, relax_path, to_voigt, ElementTestOptions};
pub use element::{DynamicTensor, ElementRecord, PathResult};
pub use equilibrium::Unbalance;
pub use equilibrium::DEFAULT_UNBALANCED_TOLERANCE;
pub use grips::{grip_motion, gripped_setup, gripped_tensor, GrippedOptions, GrippedTensor};
pub use grips::{GrippedBlock, GrippedPath, GrippedSetup, Heterogeneity};
pub use laws::BondLaw;
pub use measure::{MeasureOptions, StrainIntegrator};
pub use measure::{MeasurementSphere, MeasurementSpheres};
pub use quat::Quat;
pub use servo::ServoOutcome;
pub use servo::{servo_until_converged, ComponentControl, ServoOptions, StressServo};
pub use sim::PrescribedMotion;
pub use sim::{DemOptions, Energies, ExternalForces, Simulation, StabilityReport};
pub use state::{BondLoad, BondLoads, BondTopology, DeformingCell};
pub use state::{MassOptions, Particles};
pub use stress_tests::{
    expected_test_constants, stiffness_from_tests, stress_controlled_tensor,
    transversely_isotropic, StressTestOptions,
};
pub use stress_tests::{ShearTest, StressControlledResult, UniaxialTest};

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

/// Largest run, in particles × time steps, that the drivers taking a step count or a
/// duration from their caller accept (bar compression, the cavity's wave run). At the
/// measured ≈ 2e-7 s per particle and step on one core this is some two days; beyond it a
/// run is refused with its size instead of running for ever (issue 29).
pub const MAX_PARTICLE_STEPS: f64 = 1e12;

/// Refuse a run of `steps` time steps on `particles` particles that is beyond
/// [`MAX_PARTICLE_STEPS`] (or whose step count is not a finite number ≥ 0: a float, so that a
/// count derived from a duration is checked before it is converted); `what` names the run
/// and the option that sets its length.
pub fn check_run_size(what: &str, particles: usize, steps: f64) -> Result<()> {
    let work = particles as f64 * steps;
    if !(steps.is_finite() && steps >= 0.0 && work <= MAX_PARTICLE_STEPS) {
        return Err(crate::Error::Invalid(format!(
            "{what}: {steps:.3e} time steps on {particles} particles = {work:.3e} particle-steps, \
             beyond the limit of {MAX_PARTICLE_STEPS:e} (about {:.0} hours at 2e-7 s per \
             particle and step)",
            MAX_PARTICLE_STEPS * 2e-7 / 3600.0
        )));
    }
    Ok(())
}
