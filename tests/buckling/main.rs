//! Free-boundary bars and their buckling: cutting, geometric stiffness, linearised buckling.
//! See tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod explore;
