//! Bond table CSV. To be written.
