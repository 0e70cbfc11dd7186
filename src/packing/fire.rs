//! FIRE, the fast inertial relaxation engine (Bitzek et al. 2006): damped dynamics whose
//! velocity is mixed towards the force, v ← (1 − α)v + α|v| F/|F|, with a time step that
//! grows while the power P = F·v stays positive and a reset (v = 0, smaller step) when it
//! turns. The one implementation behind every energy minimisation of the packing routes;
//! the system minimised (force pass, integration, stopping rule) is a [`FireSystem`].

use crate::Result;

/// The constants of FIRE (Bitzek et al. 2006, Sec. "FIRE"; their symbols in brackets), for
/// unit masses and unit contact stiffness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FireParameters {
    /// Initial time step.
    pub dt_start: f64,
    /// Largest time step (Δt_max).
    pub dt_max: f64,
    /// Smallest time step after repeated resets (not in Bitzek's scheme: a floor so that a
    /// long run of resets cannot freeze the system).
    pub dt_min: f64,
    /// Steps with P > 0 before the step grows and α shrinks (N_min).
    pub n_delay: usize,
    /// Growth factor of the step (f_inc).
    pub f_inc: f64,
    /// Shrink factor of the step on a reset (f_dec).
    pub f_dec: f64,
    /// Mixing coefficient after a reset (α_start).
    pub alpha_start: f64,
    /// Decay factor of α (f_α).
    pub f_alpha: f64,
}

/// Fixed periodic cell (overlap removal, quasi-static compression steps): Bitzek et al.'s
/// recommended constants with Δt_max = 10·Δt_start = 0.2.
pub(crate) const FIRE_FIXED_CELL: FireParameters = FireParameters {
    dt_start: 0.02,
    dt_max: 0.2,
    dt_min: 1e-4,
    n_delay: 5,
    f_inc: 1.1,
    f_dec: 0.5,
    alpha_start: 0.1,
    f_alpha: 0.99,
};

/// Cell as a degree of freedom (pressure-controlled jamming): Δt_max twice the fixed cell's,
/// still stable (ω_max·Δt < 2 with ω_max² ≈ 2·Z_max for unit masses and stiffness), which
/// halves the iterations of the slow creep near jamming.
pub(crate) const FIRE_VARIABLE_CELL: FireParameters = FireParameters {
    dt_max: 0.4,
    ..FIRE_FIXED_CELL
};

/// What one FIRE iteration does, for [`FireSystem::advance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FireStep {
    /// Time step Δt of this iteration.
    pub dt: f64,
    /// Mixing coefficient α of this iteration.
    pub alpha: f64,
    /// P ≤ 0: step the positions back by ½Δt·v, then zero the velocities before the kick.
    pub reset: bool,
}

impl FireStep {
    /// Back step of a reset, x ← x − `back()`·v: ½Δt on a reset, else 0.
    pub fn back(&self) -> f64 {
        if self.reset {
            0.5 * self.dt
        } else {
            0.0
        }
    }

    /// The mixing coefficient α|v|/|F| of v ← (1 − α)v + α|v|F/|F| (0 without force), from
    /// the norms |v| after the kick v ← v + Δt·F and |F|.
    pub fn mix(&self, v_norm: f64, f_norm: f64) -> f64 {
        if f_norm > 0.0 {
            self.alpha * v_norm / f_norm
        } else {
            0.0
        }
    }
}

/// A system minimised by [`minimise`].
pub(crate) trait FireSystem {
    /// The stopping rule, asked before every iteration with the iterations done so far:
    /// true ends the minimisation as converged.
    fn converged(&mut self, iterations: usize) -> bool;
    /// The power P = Σ F·v of the current state.
    fn power(&self) -> f64;
    /// One iteration with `step`: the reset if asked (x ← x − [`FireStep::back`]·v, v ← 0),
    /// the kick v ← v + Δt·F, the mixing ([`FireStep::mix`]), the drift x ← x + Δt·v, then
    /// the force pass at the new positions.
    fn advance(&mut self, step: &FireStep) -> Result<()>;
}

/// How a [`minimise`] call ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FireRun {
    /// Iterations done.
    pub iterations: usize,
    /// The stopping rule was met (else the iteration limit was reached).
    pub converged: bool,
}

/// The adaptive part of FIRE: time step, mixing coefficient, steps since the last reset.
struct FireState {
    dt: f64,
    alpha: f64,
    n_positive: usize,
}

impl FireState {
    fn new(p: &FireParameters) -> Self {
        FireState {
            dt: p.dt_start,
            alpha: p.alpha_start,
            n_positive: 0,
        }
    }

    /// Adapt Δt and α to the power P (Bitzek et al. 2006): after more than N_min steps with
    /// P > 0, Δt ← min(f_inc·Δt, Δt_max) and α ← f_α·α; on P ≤ 0, a reset with
    /// Δt ← max(f_dec·Δt, Δt_min) and α ← α_start.
    fn next(&mut self, p: &FireParameters, power: f64) -> FireStep {
        let reset = if power > 0.0 {
            self.n_positive += 1;
            if self.n_positive > p.n_delay {
                self.dt = (self.dt * p.f_inc).min(p.dt_max);
                self.alpha *= p.f_alpha;
            }
            false
        } else {
            self.n_positive = 0;
            self.dt = (self.dt * p.f_dec).max(p.dt_min);
            self.alpha = p.alpha_start;
            true
        };
        FireStep {
            dt: self.dt,
            alpha: self.alpha,
            reset,
        }
    }
}

/// Minimise `system` with FIRE (Bitzek et al. 2006) and the constants `params`: until its
/// stopping rule holds or after `max_iterations` iterations (not an error here).
pub(crate) fn minimise(
    params: &FireParameters,
    system: &mut impl FireSystem,
    max_iterations: usize,
) -> Result<FireRun> {
    let mut state = FireState::new(params);
    let mut iterations = 0usize;
    loop {
        if system.converged(iterations) {
            return Ok(FireRun {
                iterations,
                converged: true,
            });
        }
        if iterations >= max_iterations {
            return Ok(FireRun {
                iterations,
                converged: false,
            });
        }
        iterations += 1;
        let step = state.next(params, system.power());
        system.advance(&step)?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A harmonic well E = ½|x|² in 3 dimensions: FIRE reaches |x| < 1e-8.
    struct Well {
        x: [f64; 3],
        v: [f64; 3],
    }

    impl FireSystem for Well {
        fn converged(&mut self, _: usize) -> bool {
            self.x.iter().map(|a| a * a).sum::<f64>().sqrt() < 1e-8
        }
        fn power(&self) -> f64 {
            (0..3).map(|k| -self.x[k] * self.v[k]).sum()
        }
        fn advance(&mut self, step: &FireStep) -> Result<()> {
            let f = self.x.map(|a| -a);
            for ((x, v), f) in self.x.iter_mut().zip(self.v.iter_mut()).zip(f) {
                if step.reset {
                    *x -= *v * step.back();
                    *v = 0.0;
                }
                *v += f * step.dt;
            }
            let v_norm = self.v.iter().map(|a| a * a).sum::<f64>().sqrt();
            let f_norm = f.iter().map(|a| a * a).sum::<f64>().sqrt();
            let mix = step.mix(v_norm, f_norm);
            for ((x, v), f) in self.x.iter_mut().zip(self.v.iter_mut()).zip(f) {
                *v = *v * (1.0 - step.alpha) + f * mix;
                *x += *v * step.dt;
            }
            Ok(())
        }
    }

    #[test]
    fn fire_finds_the_minimum_of_a_harmonic_well() {
        for params in [FIRE_FIXED_CELL, FIRE_VARIABLE_CELL] {
            let mut well = Well {
                x: [1.0, -2.0, 0.5],
                v: [0.0; 3],
            };
            let run = minimise(&params, &mut well, 100_000).unwrap();
            assert!(run.converged, "{params:?}: {run:?}");
            assert!(run.iterations > 10);
        }
    }

    #[test]
    fn the_step_grows_after_n_delay_positive_steps_and_resets_on_negative_power() {
        let p = FIRE_FIXED_CELL;
        let mut s = FireState::new(&p);
        for _ in 0..p.n_delay {
            let step = s.next(&p, 1.0);
            assert_eq!((step.dt, step.alpha, step.reset), (0.02, 0.1, false));
        }
        let step = s.next(&p, 1.0);
        assert_eq!(step.dt, 0.02 * 1.1);
        assert_eq!(step.alpha, 0.1 * 0.99);
        let step = s.next(&p, 0.0);
        assert!(step.reset);
        assert_eq!(step.dt, 0.02 * 1.1 * 0.5);
        assert_eq!(step.back(), 0.5 * step.dt);
        assert_eq!(step.alpha, 0.1);
    }
}
