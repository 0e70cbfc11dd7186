//! Stiffness tensors: elastic constants, fits, rotations and symmetry classes against closed forms and docs/references.md.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod elastic;
mod fit;
mod method_names;
mod polycrystal;
mod rotate;
mod symmetry;
