//! LIGGGHTS export (data file and input decks).
