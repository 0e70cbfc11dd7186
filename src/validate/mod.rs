//! Validation of anisobond against other DEM codes: the same problem (packing, bonds,
//! per-bond springs, time step, masses, damping, strain path) run in the other code and in
//! anisobond's own solvers, with the differences checked against tolerances.
//!
//! - [`harness`]: what every engine shares — checks, history comparisons, timings, the
//!   report and its JSON, the checks table and CSV; an engine adds only a runner.
//! - [`yade`]: YADE 2023.02a against the reference integrator ([`crate::dem`]) and the
//!   relaxed solver ([`crate::homogenize::relaxed`]) — `anisobond validate yade`.
//! - [`liggghts`]: the LIGGGHTS driver (`pair_style anisobond`) and stock LIGGGHTS
//!   (`bond_style harmonic`) against the same — `anisobond validate liggghts`.
//! - [`lammps`]: the exported LAMMPS (BPM) element tests against the relaxed solver, one and
//!   two MPI processes — `anisobond validate lammps`.

pub mod harness;
pub mod lammps;
pub mod liggghts;
pub mod yade;
