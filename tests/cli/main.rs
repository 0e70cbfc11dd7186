//! The `anisobond` command end to end: commands, refusals, reader refusals, `pack` routes.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod bond_tables;
mod commands;
mod outputs;
mod reader_refusals;
mod refusals;
mod routes;
