//! The damped Broyden iteration of the relaxed calibrations: solve f(x) = 0 for the
//! parameters x whose relaxed tensor matches the target, one relaxed solve per evaluation.
//!
//! Broyden (1965)'s method: the step solves J Δx = −f (minimum-norm for fewer equations than
//! unknowns), and after every evaluation J ← J + (Δf − J Δx) Δxᵀ/|Δx|². The step policy
//! decides from the residual only: a trial is accepted when |f| decreases (or it meets the
//! tolerance); otherwise, or when the residual function reports the trial point
//! [`Evaluation::Inadmissible`], the step is halved. When no trial of an iteration is
//! accepted, the Jacobian restarts from the caller's estimate. When the projected full step
//! does not move the point at all (every unknown it would move sits at its bound), no solve is
//! spent on it: the Jacobian restarts once, and a second such step ends the iteration
//! ([`End::Pinned`]) — a target outside the box's reach is then known at once instead of
//! after the whole budget of solves.

use crate::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// What the residual function returns for a trial point.
pub(crate) enum Evaluation<T> {
    /// The residual f(x) and what the caller keeps of the evaluation.
    Admissible(DVector<f64>, T),
    /// x lies outside the admissible domain (e.g. a bond stiffness would be negative): no
    /// relaxed solve was made.
    Inadmissible,
}

/// Options of [`solve`].
#[derive(Clone, Debug)]
pub(crate) struct BroydenOptions {
    /// Converged when max_i |f_i|/scale_i ≤ this.
    pub tolerance: f64,
    /// Per-component scale of the residual for the tolerance.
    pub scale: DVector<f64>,
    /// Admissible evaluations allowed, the starting point's included.
    pub max_evaluations: usize,
    /// Largest |Δx_i| of a full step (longer steps are scaled down); ∞ for none.
    pub max_step: f64,
    /// Trials per iteration (the full step, then halved ones).
    pub max_trials: usize,
}

/// A point of the iteration with its residual.
#[derive(Clone, Debug)]
pub(crate) struct Point<T> {
    /// The unknowns.
    pub x: DVector<f64>,
    /// The residual f(x).
    pub f: DVector<f64>,
    /// The caller's data of the evaluation.
    pub data: T,
}

/// How [`solve`] ended.
#[derive(Clone, Debug)]
pub(crate) enum End {
    /// max_i |f_i|/scale_i ≤ tolerance at the returned point.
    Converged,
    /// `max_evaluations` reached.
    Budget,
    /// Every trial of an iteration was inadmissible; the last trial point.
    Inadmissible(DVector<f64>),
    /// The projected Newton step left the point where it was, with the caller's Jacobian
    /// as well: the residual decreases only outside the box.
    Pinned,
}

/// Result of [`solve`].
#[derive(Clone, Debug)]
pub(crate) struct BroydenResult<T> {
    /// The last accepted point (the start if none was).
    pub point: Point<T>,
    /// The smallest scaled error of all admissible evaluations.
    pub best_error: f64,
    /// Admissible evaluations made, the starting point's included.
    pub evaluations: usize,
    /// Why the iteration stopped.
    pub end: End,
}

/// Broyden's iteration (see the module doc) from `start` (already evaluated) with the initial
/// Jacobian `jacobian`. `project` maps a trial into the caller's box (the step used for the
/// update is the projected one); `restart` gives the Jacobian at x when an iteration accepts
/// no trial. Errors of `residual` are returned as they are.
pub(crate) fn solve<T: Clone>(
    start: Point<T>,
    jacobian: DMatrix<f64>,
    mut residual: impl FnMut(&DVector<f64>) -> Result<Evaluation<T>>,
    project: impl Fn(&mut DVector<f64>),
    restart: impl Fn(&DVector<f64>) -> DMatrix<f64>,
    opts: &BroydenOptions,
) -> Result<BroydenResult<T>> {
    let error = scaled_error(&start.f, opts);
    let mut it = Iteration {
        jac: jacobian,
        current: start,
        error,
        best_error: error,
        evaluations: 1,
    };
    // Whether the Jacobian was restarted because the last step was pinned.
    let mut restarted_pinned = false;
    loop {
        if let Some(end) = error_end(it.error, it.evaluations, opts) {
            return Ok(it.finish(end));
        }
        let mut step = newton_step(&it.jac, &it.current.f)?;
        let biggest = step.amax();
        if biggest > opts.max_step {
            step *= opts.max_step / biggest;
        }
        match it.search(step, &mut residual, &project, opts)? {
            Search::Accepted => restarted_pinned = false,
            Search::Pinned if restarted_pinned => return Ok(it.finish(End::Pinned)),
            Search::Pinned => {
                it.jac = restart(&it.current.x);
                restarted_pinned = true;
            }
            Search::Rejected => it.jac = restart(&it.current.x),
            Search::Inadmissible(last_trial) => {
                return Ok(it.finish(End::Inadmissible(last_trial)));
            }
        }
    }
}

/// max_i |f_i|/scale_i.
fn scaled_error(f: &DVector<f64>, opts: &BroydenOptions) -> f64 {
    f.component_div(&opts.scale).amax()
}

/// Converged at this error, or out of evaluations; `None` to go on.
fn error_end(error: f64, evaluations: usize, opts: &BroydenOptions) -> Option<End> {
    if error <= opts.tolerance {
        Some(End::Converged)
    } else if evaluations >= opts.max_evaluations {
        Some(End::Budget)
    } else {
        None
    }
}

/// The state of [`solve`] between iterations.
struct Iteration<T> {
    /// The Jacobian estimate.
    jac: DMatrix<f64>,
    /// The last accepted point.
    current: Point<T>,
    /// Its scaled error.
    error: f64,
    /// The smallest scaled error of all admissible evaluations.
    best_error: f64,
    /// Admissible evaluations made.
    evaluations: usize,
}

/// How the trials of one iteration ended.
enum Search {
    /// A trial decreased |f| (or met the tolerance) and is the new point.
    Accepted,
    /// Admissible trials, none accepted.
    Rejected,
    /// Every trial inadmissible; the last one.
    Inadmissible(DVector<f64>),
    /// The projected full step is the current point: nothing evaluated.
    Pinned,
}

impl<T: Clone> Iteration<T> {
    /// The trials of one iteration: the full `step`, then halved ones, each admissible
    /// evaluation updating the Jacobian by Broyden's rank-one formula; the first trial that
    /// decreases |f| (or meets the tolerance) is accepted.
    fn search(
        &mut self,
        mut step: DVector<f64>,
        residual: &mut impl FnMut(&DVector<f64>) -> Result<Evaluation<T>>,
        project: &impl Fn(&mut DVector<f64>),
        opts: &BroydenOptions,
    ) -> Result<Search> {
        let mut admissible = false;
        let mut last_trial = self.current.x.clone();
        for attempt in 0..opts.max_trials {
            let mut trial = &self.current.x + &step;
            project(&mut trial);
            if attempt == 0 && trial == self.current.x {
                // A box projection maps every shorter step along this one to the same
                // point: no trial can move.
                return Ok(Search::Pinned);
            }
            last_trial.clone_from(&trial);
            let (f_new, data) = match residual(&trial)? {
                Evaluation::Admissible(f, data) => (f, data),
                Evaluation::Inadmissible => {
                    step *= 0.5;
                    continue;
                }
            };
            admissible = true;
            self.evaluations += 1;
            let actual = &trial - &self.current.x;
            let denominator = actual.norm_squared();
            if denominator > 0.0 {
                // Broyden's update: J ← J + (Δf − JΔx)Δxᵀ/|Δx|².
                let correction = (&f_new - &self.current.f - &self.jac * &actual)
                    * actual.transpose()
                    / denominator;
                self.jac += correction;
            }
            let new_error = scaled_error(&f_new, opts);
            self.best_error = self.best_error.min(new_error);
            if f_new.norm() < self.current.f.norm() || new_error <= opts.tolerance {
                self.current = Point {
                    x: trial,
                    f: f_new,
                    data,
                };
                self.error = new_error;
                return Ok(Search::Accepted);
            }
            if self.evaluations >= opts.max_evaluations {
                break;
            }
            step *= 0.5;
        }
        Ok(if admissible {
            Search::Rejected
        } else {
            Search::Inadmissible(last_trial)
        })
    }

    /// The result, ended by `end`.
    fn finish(self, end: End) -> BroydenResult<T> {
        BroydenResult {
            point: self.current,
            best_error: self.best_error,
            evaluations: self.evaluations,
            end,
        }
    }
}

/// The step Δx with J Δx = −f: J⁻¹ for a square invertible J (LU), else the minimum-norm
/// least-squares step of the pseudo-inverse.
fn newton_step(jac: &DMatrix<f64>, f: &DVector<f64>) -> Result<DVector<f64>> {
    if jac.is_square() {
        if let Some(inv) = jac.clone().try_inverse() {
            return Ok(-(inv * f));
        }
    }
    let pinv = jac
        .clone()
        .pseudo_inverse(1e-12)
        .map_err(|e| Error::Invalid(format!("relaxed calibration: Jacobian: {e}")))?;
    Ok(-(pinv * f))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(n: usize) -> BroydenOptions {
        BroydenOptions {
            tolerance: 1e-10,
            scale: DVector::from_element(n, 1.0),
            max_evaluations: 50,
            max_step: f64::INFINITY,
            max_trials: 8,
        }
    }

    /// [`solve`] from `x0` (residual `f0` there) with a constant Jacobian `jac` (also the
    /// restart Jacobian), no projection, and [`opts`].
    fn solve_from(
        x0: DVector<f64>,
        f0: DVector<f64>,
        jac: DMatrix<f64>,
        residual: impl FnMut(&DVector<f64>) -> Result<Evaluation<()>>,
    ) -> BroydenResult<()> {
        let n = x0.len();
        let start = Point {
            f: f0,
            x: x0,
            data: (),
        };
        solve(
            start,
            jac.clone(),
            residual,
            |_| {},
            |_| jac.clone(),
            &opts(n),
        )
        .unwrap()
    }

    /// The root of x − 3 outside the box [0, 1], from x = 1: the first step projects onto
    /// x = 1 itself, so the iteration ends [`End::Pinned`] after the Jacobian restart,
    /// having evaluated nothing beyond the start; the root of x − 0.5 inside the box is
    /// still found from the same start.
    #[test]
    fn ends_when_the_box_pins_the_step() {
        let run = |root: f64, evaluated: &mut usize| {
            let start = Point {
                f: DVector::from_vec(vec![1.0 - root]),
                x: DVector::from_vec(vec![1.0]),
                data: (),
            };
            let jac = DMatrix::from_element(1, 1, 1.0);
            solve(
                start,
                jac.clone(),
                |x: &DVector<f64>| {
                    *evaluated += 1;
                    Ok(Evaluation::Admissible(x.add_scalar(-root), ()))
                },
                |x: &mut DVector<f64>| x[0] = x[0].clamp(0.0, 1.0),
                |_: &DVector<f64>| jac.clone(),
                &opts(1),
            )
            .unwrap()
        };
        let mut evaluated = 0;
        let out = run(3.0, &mut evaluated);
        assert!(matches!(out.end, End::Pinned), "{out:?}");
        assert_eq!((evaluated, out.evaluations), (0, 1));
        let mut evaluated = 0;
        let out = run(0.5, &mut evaluated);
        assert!(matches!(out.end, End::Converged), "{out:?}");
        assert!((out.point.x[0] - 0.5).abs() < 1e-12 && evaluated >= 1);
    }

    /// x² = 2, y³ = 3 from a poor Jacobian.
    #[test]
    fn solves_a_square_system() {
        let r = |x: &DVector<f64>| DVector::from_vec(vec![x[0] * x[0] - 2.0, x[1].powi(3) - 3.0]);
        let x0 = DVector::from_vec(vec![1.0, 1.0]);
        let jac = DMatrix::from_diagonal(&DVector::from_vec(vec![2.0, 3.0]));
        let out = solve_from(x0.clone(), r(&x0), jac, |x| {
            Ok(Evaluation::Admissible(r(x), ()))
        });
        assert!(matches!(out.end, End::Converged), "{out:?}");
        assert!((out.point.x[0] - 2f64.sqrt()).abs() < 1e-9);
        assert!((out.point.x[1] - 3f64.cbrt()).abs() < 1e-9);
    }

    /// An inadmissible region x < 0.5 on the way to the root of x − 0.6 from x = 2 with a
    /// Jacobian that overshoots: the step is halved until the trial is admissible.
    #[test]
    fn halves_steps_into_inadmissible_points() {
        let jac = DMatrix::from_element(1, 1, 0.5);
        let mut inadmissible = 0;
        let out = solve_from(
            DVector::from_vec(vec![2.0]),
            DVector::from_vec(vec![1.4]),
            jac,
            |x| {
                if x[0] < 0.5 {
                    inadmissible += 1;
                    Ok(Evaluation::Inadmissible)
                } else {
                    Ok(Evaluation::Admissible(x.add_scalar(-0.6), ()))
                }
            },
        );
        assert!(matches!(out.end, End::Converged), "{out:?}");
        assert!(inadmissible > 0);
        assert!((out.point.x[0] - 0.6).abs() < 1e-10);
    }

    /// Every trial inadmissible: the iteration stops and says where.
    #[test]
    fn reports_an_inadmissible_neighbourhood() {
        let out = solve_from(
            DVector::from_vec(vec![1.0]),
            DVector::from_vec(vec![1.0]),
            DMatrix::from_element(1, 1, 1.0),
            |_| Ok(Evaluation::Inadmissible),
        );
        assert!(matches!(out.end, End::Inadmissible(_)), "{out:?}");
        assert_eq!(out.evaluations, 1);
    }
}
