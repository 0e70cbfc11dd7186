//! Mean-field (continuous orientation average) stiffness. To be written.
