//! Export of a bonded model to other tools, ready to run there.
//!
//! - [`yade`]: the packing, the bond table, the model, the reusable Python module
//!   `anisobond_yade.py` (embedded in the binary) and a `run.py` that performs the six-path
//!   element test in YADE 2023.02a (`yade -n -x DIR/run.py`).
//! - [`liggghts`]: LIGGGHTS 3.8 data file and input decks: the driver deck with per-bond
//!   anisotropic bonds (`pair_style anisobond`, cpp/liggghts) and a stock `bond_style
//!   harmonic` deck (normal springs only).
//! - [`vtk`]: VTK XML (.vtu) files of particles and bonds for ParaView.

pub mod liggghts;
pub mod vtk;
pub mod yade;
