//! The specimen solve (`anisobond::specimen`, `anisobond specimen`): a finite bonded
//! specimen between platens, against closed forms, an energy identity, symmetry and the
//! periodic relaxed tensor.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod closed_forms;
mod groups;
mod multigrid;
mod periodic;
mod slab;
