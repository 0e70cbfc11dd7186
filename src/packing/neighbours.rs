//! Neighbour search by cell lists. To be written.
