//! Packing file formats. To be written.
