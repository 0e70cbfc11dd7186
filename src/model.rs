//! Model files. To be written.
