//! Against LIGGGHTS 3.8 and the anisobond LIGGGHTS driver (skipped with a reason when LIGGGHTS/MPI are absent, failing under CI).
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod bench;
mod data_files;
mod driver;
mod dumps;
mod grains;
mod harmonic;
mod in_place;
mod manybody;
mod ppf_export;
mod specimen;
mod strength_contacts;
mod strength_export;
mod strength_tension;
mod strength_validate;
mod validate;
mod walled_specimen;
