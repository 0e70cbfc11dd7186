//! Bond stiffness assignment. To be written.
