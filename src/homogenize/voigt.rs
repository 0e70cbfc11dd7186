//! Voigt (uniform-strain) sum over bonds. To be written.
