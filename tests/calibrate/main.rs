//! Calibration: mean-field and relaxed inversions, and the `calibrate` command.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod manybody;
mod meanfield;
mod relaxed;
mod strength;
