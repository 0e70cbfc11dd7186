//! Cubic spheroid scheme (Truszkowska 2018). To be written.
