//! Readers and writers: model files, packing files (LAMMPS data files with their Bonds), output sets, VTK, PNG plots, and the readers' fuzzing.
//! One module per former `tests/*.rs` file; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod data_bonds;
mod fuzz_readers;
mod model_files;
mod output_set;
mod packing_files;
mod plot_png;
mod vtk_export;
