//! Validation of anisobond against other DEM codes: the same problem run there and here,
//! with the differences reported against stated tolerances.

pub mod liggghts;
