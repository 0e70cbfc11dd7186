//! The many-body term (issue 33; docs/manybody.md): uniform-strain closed forms, forces and
//! Hessian against finite differences, rotation invariance, thread-count determinism,
//! refusals of degenerate particles and bad inputs.
//! One module per file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod closed_forms;
mod derivatives;
mod engines;
mod model_file;
mod refusals;
mod setup;
