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

/// How a damped relaxation was settling at its end ([`StressHistory::settling`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settling {
    /// Stress change over the last window (Pa, max over components).
    pub last_change: f64,
    /// Its ratio to the change over the window before (∞ when that was zero).
    pub ratio: f64,
}

impl Settling {
    /// The change still to come if the decay went on geometrically, |Δ₂|·q/(1 − q) (Pa);
    /// `None` when it does not decay (q ≥ 1).
    pub fn remaining(&self) -> Option<f64> {
        if self.last_change == 0.0 {
            Some(0.0)
        } else {
            (self.ratio < 1.0).then(|| self.last_change * self.ratio / (1.0 - self.ratio))
        }
    }
}

impl StressHistory {
    /// How the relaxation that ends at `end_step` was settling: the stress change over the
    /// last `window` steps and its ratio to the change over the `window` before (max norm
    /// over components, Pa). `None` when the history has no row at `end_step`,
    /// `end_step − window` or `end_step − 2·window`.
    pub fn settling(&self, end_step: u64, window: u64) -> Option<Settling> {
        let at = |step: u64| -> Option<[f64; 6]> {
            let r = self.step.iter().position(|&s| s == step)?;
            Some(self.stress[r])
        };
        let window = window.max(1);
        let back = end_step.checked_sub(2 * window)?;
        let (s0, s1, s2) = (at(back)?, at(end_step - window)?, at(end_step)?);
        let norm =
            |a: [f64; 6], b: [f64; 6]| (0..6).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
        let (d1, d2) = (norm(s1, s0), norm(s2, s1));
        Some(Settling {
            last_change: d2,
            ratio: if d2 == 0.0 { 0.0 } else { d2 / d1 },
        })
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    /// σ(t) = A(1 − qᵗ) sampled every window: the remaining change at step n is A·qⁿ
    /// exactly (closed form), which the geometric extrapolation recovers.
    #[test]
    fn settling_of_a_geometric_decay_gives_its_remaining_change() {
        let (a, q) = (5.0e6, 0.6_f64);
        let mut h = StressHistory::default();
        for k in 0..=10u64 {
            h.step.push(100 * k);
            h.strain.push([0.0; 6]);
            h.stress
                .push([a * (1.0 - q.powi(k as i32)), 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        let s = h.settling(1000, 100).unwrap();
        assert!((s.ratio - q).abs() < 1e-12, "{s:?}");
        let exact = a * q.powi(10);
        assert!(
            (s.remaining().unwrap() - exact).abs() < 1e-9 * a,
            "{s:?} vs {exact}"
        );
        // A linear drift does not decay: no estimate; a settled run: zero.
        let mut lin = h.clone();
        for (k, row) in lin.stress.iter_mut().enumerate() {
            row[0] = 3.0 * k as f64;
        }
        assert_eq!(lin.settling(1000, 100).unwrap().remaining(), None);
        let flat = StressHistory {
            stress: vec![[1.0; 6]; 11],
            ..h.clone()
        };
        assert_eq!(flat.settling(1000, 100).unwrap().remaining(), Some(0.0));
        // Rows missing at the window's steps: cannot tell.
        assert!(h.settling(1000, 150).is_none() && h.settling(100, 100).is_none());
    }
}
