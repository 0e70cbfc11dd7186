//! Against YADE 2023.02a itself (skipped with a reason when `yade` is absent, failing under CI), and `export yade`.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod dem_twoparticle;
mod element;
mod export_cli;
mod in_place_scene;
mod periodic_image;
mod specimen;
mod strength_tension;
mod strength_validate;
mod two_sphere;
mod validate;
mod yade_files;
