//! Validation of anisobond against other DEM codes: the same problem (packing, bonds,
//! per-bond springs, time step, masses, damping, strain path) run in the other code and in
//! anisobond's own solvers, with the differences checked against tolerances.
//!
//! - `engine.rs`: the [`Engine`] trait every engine implements — what it is given (a
//!   [`Problem`]: packing, bonds, springs, model, [`TestKind`]), what it returns, how it
//!   reports progress —, the free-specimen decks' [`Launch`] and runners ([`Decks`]), and
//!   [`validate`], the one entry every client calls.
//! - `harness.rs`: what every engine shares — checks, history comparisons, the reference
//!   integrator's run of an engine's history, timings, the report and its JSON, the checks
//!   table, the summary and CSV; an engine adds only a runner.
//! - [`yade`]: YADE 2023.02a against the reference integrator ([`crate::dem`]) and the
//!   relaxed solver ([`crate::homogenize::relaxed_tensor`]) — `anisobond validate yade`.
//! - [`liggghts`]: the LIGGGHTS driver (`pair_style anisobond`) and stock LIGGGHTS
//!   (`bond_style harmonic`) against the same — `anisobond validate liggghts`.
//! - [`specimen`]: the specimen test every engine runs — a free bonded specimen loaded
//!   between platens by the engine, its platen stiffness against the specimen solve
//!   ([`crate::specimen`]) — `anisobond validate ENGINE --specimen`.
//! - [`strength`]: the strength test every engine runs — direct tension of a free bar to
//!   failure, peak stress and first broken bonds against the integrator with the same law —
//!   `anisobond validate ENGINE --strength`.
//! - [`lammps`]: the exported LAMMPS (BPM) element tests against the relaxed solver, one and
//!   two MPI processes — `anisobond validate lammps`.

pub(crate) mod engine;
pub(crate) mod harness;
pub mod lammps;
pub mod liggghts;
pub mod specimen;
pub mod strength;
pub mod yade;

pub use engine::{
    validate, validate_specimen, validate_strength, Decks, Engine, Launch, Problem, Progress,
    SpecimenRunner, StrengthRunner, TestKind, Tolerances,
};
pub use harness::{
    checks_summary, failure_lines, outcome, summary, unsettled_lines, write_report_files,
    write_report_json, EngineDetails, Report, SharedDetails,
};
pub use harness::{Check, DampedTensors, HistoryComparison, HistoryPair, Timing};
