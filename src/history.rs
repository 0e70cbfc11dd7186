//! The stress history every producer shares: the DEM element tests, the YADE and LIGGGHTS
//! readers and the validations record [`HistoryRow`]s or a [`StressHistory`], and the plots
//! take a [`StressHistory`]. One type, so a new engine's reader adds no history type.

use crate::tensor::Voigt6;

/// One recorded state of a strain path.
#[derive(Clone, Debug, PartialEq)]
pub struct HistoryRow {
    /// Voigt index of the strain path (0–5).
    pub path: usize,
    /// Step number (0 = before the first step).
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Cell strain (Voigt, engineering shear).
    pub strain: Voigt6,
    /// Love stress, symmetric part (Voigt, Pa, tension positive).
    pub stress: Voigt6,
}

/// A stress history as columns: step, time (s), strain and stress (Pa) in Voigt order
/// 11 22 33 23 13 12 (engineering shear, tension positive).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StressHistory {
    /// Step numbers.
    pub step: Vec<u64>,
    /// Time of every step (s); empty when the source has no time (LIGGGHTS' decks), see
    /// [`StressHistory::with_time_step`].
    pub time: Vec<f64>,
    /// Strain.
    pub strain: Vec<[f64; 6]>,
    /// Stress (Pa).
    pub stress: Vec<[f64; 6]>,
}

impl StressHistory {
    /// The history of `rows` (in their order).
    pub fn from_rows<'a>(rows: impl IntoIterator<Item = &'a HistoryRow>) -> StressHistory {
        let mut h = StressHistory::default();
        for r in rows {
            h.step.push(r.step as u64);
            h.time.push(r.time);
            h.strain.push(r.strain.into());
            h.stress.push(r.stress.into());
        }
        h
    }

    /// The same history with time = step × `dt` (s).
    pub fn with_time_step(mut self, dt: f64) -> StressHistory {
        self.time = self.step.iter().map(|&s| s as f64 * dt).collect();
        self
    }
}
