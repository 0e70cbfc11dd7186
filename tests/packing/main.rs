//! Packings and bonds: generation, neighbour search, bonding rules, Kumar 2016's routes (periodic and in a container) and the fast jammed route.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod bonds_rules;
mod container;
mod generate;
mod neighbours;
mod routes_jam_fast;
mod routes_kumar;
