//! The cavity application of issue 22: Christoffel wave speeds, the pressurised hole in a
//! slab cut from a periodic packing against Lamé, and the `cavity` command.
//! See tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod continuum;
mod external;
mod fronts;
mod lame;
mod refusals;
mod tilted;
mod waves;
