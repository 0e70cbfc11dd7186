//! Exports of a packing and model to other tools.

pub mod vtk;
