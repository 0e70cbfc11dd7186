//! Export to other DEM codes.

pub mod liggghts;
