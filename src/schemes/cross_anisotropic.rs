//! Cross-anisotropic elliptic scheme (Šmilauer). To be written.
