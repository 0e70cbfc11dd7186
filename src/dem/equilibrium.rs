//! The stop rule of the damped (quasi-static) relaxations: static equilibrium measured
//! directly, by YADE's unbalanced force and its rotational analogue, in addition to the
//! steadiness of the stress. A steady stress alone is not equilibrium: with a time step far
//! below the critical one the particles barely move per step, the stress hardly changes over
//! any window, and a steadiness test stops at the affine (Voigt) response.

use super::sim::Simulation;
use crate::tensor::Voigt6;
use crate::{Error, Result};
use std::collections::VecDeque;

/// Default tolerance on the unbalanced force and torque (see [`Unbalance`]).
///
/// Chosen by measurement (element tests, time step 0.8 × critical, Cundall damping 0.4,
/// 2,000 particles): stopped on the unbalanced force alone, the tensor is within 1.5e-4 of
/// the exact relaxed one at 1e-1, 2e-5 at 1e-2 and 5e-6 (the floor of the geometric terms)
/// from 1e-3 on; the default steadiness test (1e-7 over 10 steps) is met at 2e-6–1.4e-5, so
/// 1e-4 leaves default runs unchanged while a time step 1e-6 × critical stays at 0.5–2.
pub const DEFAULT_UNBALANCED_TOLERANCE: f64 = 1e-4;

/// Residual of the static equations of the free particles: the unbalanced force (YADE's
/// `unbalancedForce()`: mean resultant force over mean bond force,
/// [`Simulation::unbalanced_force`]) and torque ([`Simulation::unbalanced_torque`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Unbalance {
    /// Unbalanced force ratio.
    pub force: f64,
    /// Unbalanced torque ratio.
    pub torque: f64,
}

impl Unbalance {
    /// The residual of `sim` at its last force evaluation.
    pub fn of(sim: &Simulation) -> Self {
        Unbalance {
            force: sim.unbalanced_force(),
            torque: sim.unbalanced_torque(),
        }
    }

    /// Both ratios at most `tolerance`.
    pub fn within(&self, tolerance: f64) -> bool {
        self.force <= tolerance && self.torque <= tolerance
    }

    /// "unbalanced force F, torque T (required ≤ tol)".
    pub fn describe(&self, tolerance: f64) -> String {
        format!(
            "unbalanced force {:.3e} and torque {:.3e} (required ≤ {tolerance:.1e})",
            self.force, self.torque
        )
    }
}

/// Errors unless `tolerance` is finite and > 0.
pub fn check_tolerance(tolerance: f64) -> Result<()> {
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(Error::Invalid(format!(
            "unbalanced-force tolerance must be finite and > 0, got {tolerance}"
        )));
    }
    Ok(())
}

/// What to change when a relaxation runs out of steps: the time step relative to the
/// critical estimate when it is far below it (the usual cause: every step moves the
/// particles too little), and the step limit.
pub fn budget_advice(sim: &Simulation) -> String {
    let dt = sim.time_step();
    let crit = sim.stability().critical_time_step;
    let ratio = dt / crit;
    if crit.is_finite() && ratio < 0.1 {
        format!(
            "the time step {dt:.3e} s is only {ratio:.1e} × the critical estimate {crit:.3e} s, \
             so the particles barely move per step: use a time step near {:.3e} s (the default; \
             this one needs about {:.0}× as many steps to relax) or raise the step limit \
             (--max-steps)",
            sim.recommended_time_step(),
            (sim.recommended_time_step() / dt).max(1.0)
        )
    } else {
        format!(
            "raise the step limit (--max-steps) or the damping (time step {dt:.3e} s = \
             {ratio:.2} × the critical estimate {crit:.3e} s, set by particle {})",
            sim.stability().stiffest_particle
        )
    }
}

/// The steadiness test of the relaxations: the last `window` + 1 values of a Voigt vector
/// (the stress), and how far the older ones lie from the newest.
#[derive(Clone, Debug)]
pub struct SteadyWindow {
    recent: VecDeque<Voigt6>,
    window: usize,
}

/// The spread of a full [`SteadyWindow`]: the largest distance ‖s − s_new‖ of a value in the
/// window from the newest, and the newest value's norm ‖s_new‖.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// Largest ‖s − s_new‖ over the window.
    pub change: f64,
    /// ‖s_new‖.
    pub norm: f64,
}

impl Spread {
    /// `change / norm`, or infinity when the newest value is zero.
    pub fn relative(&self) -> f64 {
        if self.norm > 0.0 {
            self.change / self.norm
        } else {
            f64::INFINITY
        }
    }
}

impl SteadyWindow {
    /// An empty window over `window` steps (at least 1).
    pub fn new(window: usize) -> Self {
        let window = window.max(1);
        SteadyWindow {
            recent: VecDeque::with_capacity(window + 1),
            window,
        }
    }

    /// Steps of the window (at least 1).
    pub fn steps(&self) -> usize {
        self.window
    }

    /// Add the newest value (dropping the oldest beyond `window` + 1); the spread once the
    /// window is full, `None` before.
    pub fn push(&mut self, value: Voigt6) -> Option<Spread> {
        self.recent.push_back(value);
        if self.recent.len() > self.window + 1 {
            self.recent.pop_front();
        }
        (self.recent.len() == self.window + 1).then(|| Spread {
            change: self
                .recent
                .iter()
                .map(|s| (s - value).norm())
                .fold(0.0, f64::max),
            norm: value.norm(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_window_spread() {
        let mut w = SteadyWindow::new(0);
        assert_eq!(w.steps(), 1);
        let a = Voigt6::new(3.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let b = Voigt6::new(0.0, 4.0, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(w.push(a), None);
        let s = w.push(b).unwrap();
        assert_eq!((s.change, s.norm, s.relative()), (5.0, 4.0, 1.25));
        let z = w.push(Voigt6::zeros()).unwrap();
        assert_eq!((z.change, z.relative()), (4.0, f64::INFINITY));
    }
}
