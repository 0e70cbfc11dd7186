//! Homogenisation: Voigt sum, relaxed (static) tensor and its solvers, cubic mean field, against closed forms and docs/references.md.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod amg;
mod kruyt;
mod local;
mod manybody;
mod meanfield_cubic;
mod prestress;
mod relaxed;
mod relaxed_solvers;
mod system;
mod voigt;
