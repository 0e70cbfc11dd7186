//! The reference integrator: contact laws, frictional contacts, element tests, grips, servo control, stop rule, particle lanes.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod contacts;
mod element;
mod grips_disordered;
mod grips_lattice;
mod grips_motion;
mod lanes;
mod laws;
mod manybody;
mod prestress;
mod servo_element;
mod stop_rule;
