//! The first peak of a loading curve (issue 32): after bonds break, broken pairs can lock
//! up as frictional contacts and the stress rise again (re-hardening), so a specimen's
//! strength is the largest stress before the stress first drops, not the curve's maximum.
//! One rule for the virtual laboratory (`study::strength_test`) and for the engines'
//! strength test (`validate::strength`).

/// Where the peak lies on a recorded curve ([`first_peak`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PeakPick {
    /// Index of the first peak: the largest stress before the first drop (the global
    /// maximum when the curve never dropped).
    pub first: usize,
    /// Index of the global maximum (the first of equal maxima).
    pub max: usize,
    /// Whether the stress fell below (1 − drop) × its running maximum after bonds broke;
    /// false: `first` is the global maximum of a curve that never dropped.
    pub dropped: bool,
}

/// The first peak of a curve of (stress, broken bonds) points: the largest stress before
/// the first point where bonds have broken and the stress is below (1 − `drop`) × the
/// running maximum. Re-hardening after that drop (broken pairs locking up as frictional
/// contacts) raises the global maximum but not the first peak. `None` for an empty curve.
pub fn first_peak(series: &[(f64, usize)], drop: f64) -> Option<PeakPick> {
    let mut max = 0usize;
    let mut first = None;
    for (k, &(stress, broken)) in series.iter().enumerate() {
        if first.is_none() && broken > 0 && stress < (1.0 - drop) * series[max].0 {
            first = Some(max);
        }
        if stress > series[max].0 {
            max = k;
        }
    }
    (!series.is_empty()).then(|| PeakPick {
        first: first.unwrap_or(max),
        max,
        dropped: first.is_some(),
    })
}
