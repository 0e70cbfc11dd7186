//! Packing generation. To be written.
