//! Per-bond stiffness schemes (cubic, isotropic, cross-anisotropic) against the papers' tables, closed forms and symmetry.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod cross_anisotropic;
mod cubic;
mod isotropic;
