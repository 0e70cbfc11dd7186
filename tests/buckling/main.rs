//! Free-boundary bars and their buckling: cutting from periodic packings or packing in a
//! container, the geometric stiffness, linearised buckling against Euler/Engesser/Mazzilli, `anisobond buckle`.
//! See tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod container;
mod cut;
mod dem;
mod euler;
mod geometric;
mod refusals;
