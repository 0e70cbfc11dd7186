//! The C++ bridge (`make -C cpp check`), alone in its test binary because it runs `make` in cpp/.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod cpp;
