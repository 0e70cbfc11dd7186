//! Isotropic scheme. To be written.
