//! Studies against the papers' numbers; the `#[ignore]`d ones print tables (run one with a name filter).
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod grips;
mod kruyt;
mod papers;
mod servo;
mod table3;
