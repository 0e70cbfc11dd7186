//! Stress (servo) control of the periodic cell: each of the six symmetric velocity-gradient
//! components is either prescribed (a strain rate or a target strain) or driven toward a
//! target stress, as YADE's `PeriTriaxController` / Woo's `WeirdTriaxControl` do for the
//! unconfined element tests of Šmilauer ("Evaluating the stiffness tensor":
//! lateral strains adjusted until |T_lateral| < t_r·|T_axial|).
//!
//! The controller is deterministic and stateless: before every step it reads the Love
//! stress, predicts the stress once the strain increment already requested (but not yet
//! seen by the stress, see [`crate::dem::state::DeformingCell`]) has acted, through the
//! affine stiffness of the bond network C_aff (the instantaneous response of the assembly
//! to a homogeneous strain increment), and solves C_aff,SS·Δε_S = g·(σ*_S − σ_S,pred) −
//! C_aff,SP·Δε_P for the controlled components S, given the prescribed increments Δε_P.
//! With g = 1 an affine response would be met in one step; the relaxation of the particles
//! then makes the stress drift and the controller follows it until both are steady.

use super::element::to_voigt;
use super::equilibrium::{self, SteadyWindow, Unbalance, DEFAULT_UNBALANCED_TOLERANCE};
use super::sim::Simulation;
use crate::tensor::{strain_tensor, Stiffness6, Voigt6, VOIGT_PAIRS};
use crate::{Error, Result};

/// How one symmetric component (Voigt order xx, yy, zz, yz, xz, xy; engineering shear
/// strain) of the cell's deformation is driven.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ComponentControl {
    /// Prescribed strain rate (1/s; engineering rate for shears).
    StrainRate(f64),
    /// Prescribed cell strain (small strain ½(F + Fᵀ) − I, engineering shear), reached in
    /// one step (or as fast as [`ServoOptions::max_strain_increment`] allows) and then held.
    Strain(f64),
    /// Target stress component (Pa, tension positive): the strain is servo-controlled.
    Stress(f64),
}

/// Settings of the servo controller and of its convergence test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoOptions {
    /// Gain g ∈ (0, 1] on the predicted stress error (1: meet it in one affine step).
    pub gain: f64,
    /// Šmilauer's relative stress tolerance t_r: every stress-controlled component must end
    /// within t_r·σ_ref of its target, σ_ref the largest |σ| of the prescribed components
    /// (or the largest |target| if every component is stress-controlled).
    pub stress_tolerance: f64,
    /// The state is steady when, over the last `window` steps, the largest change of the
    /// stress (Voigt, Pa) relative to its norm stays below this.
    pub steady_tolerance: f64,
    /// Equilibrium: the unbalanced force and torque ([`Unbalance`]) must be at most this (a
    /// steady stress alone is met at once when the time step is tiny).
    pub unbalanced_tolerance: f64,
    /// Steps of the steadiness window.
    pub window: usize,
    /// Step limit of [`servo_until_converged`]; reaching it is an error naming the residuals.
    pub max_steps: usize,
    /// Largest strain increment of any component in one step; a larger request is scaled
    /// down as a whole (keeps its direction). `f64::INFINITY`: no limit.
    pub max_strain_increment: f64,
}

impl Default for ServoOptions {
    fn default() -> Self {
        ServoOptions {
            gain: 0.5,
            stress_tolerance: 1e-3,
            steady_tolerance: 1e-7,
            unbalanced_tolerance: DEFAULT_UNBALANCED_TOLERANCE,
            window: 10,
            max_steps: 50_000,
            max_strain_increment: f64::INFINITY,
        }
    }
}

/// The affine stiffness of the bonds of `sim` in their current configuration (Pa, Voigt,
/// engineering shear): dσ = (1/V) Σ_b [k_n n(n·Δε·l) + k_s(Δε·l − n(n·Δε·l))] ⊗ l for a
/// homogeneous strain increment Δε (the Love stress, Kumar 2016 Eq. 9, of affinely moved
/// springs; rotational springs take no load under a symmetric strain). Summed in bond order.
pub fn affine_stiffness(sim: &Simulation) -> Stiffness6 {
    let law = sim.law();
    let mut c = Stiffness6::zeros();
    for b in 0..sim.topology.len() {
        let l = sim.branch(b);
        let len = l.norm();
        if len == 0.0 {
            continue;
        }
        let n = l / len;
        let (kn, ks, _, _) = law.springs(b);
        for (q, &(a, bb)) in VOIGT_PAIRS.iter().enumerate() {
            // Unit engineering strain q: ε_ab = ε_ba = ½ for a shear, ε_aa = 1 for a normal.
            let mut u = crate::Vec3::zeros();
            if a == bb {
                u[a] = l[a];
            } else {
                u[a] = 0.5 * l[bb];
                u[bb] = 0.5 * l[a];
            }
            let un = n.dot(&u);
            let f = n * (kn * un) + (u - n * un) * ks;
            for (p, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
                c[(p, q)] += 0.5 * (f[i] * l[j] + f[j] * l[i]);
            }
        }
    }
    c / sim.volume()
}

/// A stress-controlled periodic cell: the six component controls and the stiffness used to
/// turn a stress error into a strain increment.
#[derive(Clone, Debug)]
pub struct StressServo {
    controls: [ComponentControl; 6],
    gain: f64,
    max_increment: f64,
    /// C_aff of the assembly at construction (Pa).
    stiffness: Stiffness6,
    /// Indices of the stress-controlled components.
    controlled: Vec<usize>,
    /// Inverse of C_aff restricted to the controlled components.
    controlled_inverse: nalgebra::DMatrix<f64>,
}

impl StressServo {
    /// A servo for `sim` (periodic) with the given controls; the gain matrix is the affine
    /// stiffness of `sim`'s bonds now (`affine_stiffness`). Errors on a free assembly, a
    /// non-finite control, a gain outside (0, 1], a non-positive increment limit, or an
    /// assembly whose affine stiffness is singular on the controlled components.
    pub fn new(
        sim: &Simulation,
        controls: [ComponentControl; 6],
        opts: &ServoOptions,
    ) -> Result<Self> {
        if sim.cell.is_none() {
            return Err(Error::Invalid(
                "stress control needs a periodic packing (a `# periodic Lx Ly Lz` header)".into(),
            ));
        }
        for (name, value) in [
            ("relative stress tolerance t_r", opts.stress_tolerance),
            ("steadiness tolerance", opts.steady_tolerance),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::Invalid(format!(
                    "servo {name} must be finite and > 0, got {value}"
                )));
            }
        }
        if !(opts.gain.is_finite() && opts.gain > 0.0 && opts.gain <= 1.0) {
            return Err(Error::Invalid(format!(
                "servo gain must be in (0, 1], got {}",
                opts.gain
            )));
        }
        if opts.max_strain_increment.is_nan() || opts.max_strain_increment <= 0.0 {
            return Err(Error::Invalid(format!(
                "servo strain-increment limit must be > 0, got {}",
                opts.max_strain_increment
            )));
        }
        for (k, c) in controls.iter().enumerate() {
            let v = match c {
                ComponentControl::StrainRate(v)
                | ComponentControl::Strain(v)
                | ComponentControl::Stress(v) => *v,
            };
            if !v.is_finite() {
                return Err(Error::Invalid(format!(
                    "servo control of Voigt component {k} is not finite: {c:?}"
                )));
            }
        }
        let stiffness = affine_stiffness(sim);
        let controlled: Vec<usize> = (0..6)
            .filter(|&k| matches!(controls[k], ComponentControl::Stress(_)))
            .collect();
        let m = controlled.len();
        let block =
            nalgebra::DMatrix::from_fn(m, m, |a, b| stiffness[(controlled[a], controlled[b])]);
        let controlled_inverse = if m == 0 {
            block
        } else {
            let scale = block.amax();
            match block.clone().cholesky() {
                Some(ch) if scale > 0.0 && ch.l().diagonal().min() > 1e-8 * scale.sqrt() => {
                    ch.inverse()
                }
                _ => {
                    return Err(Error::Invalid(format!(
                        "stress control of Voigt components {controlled:?}: the affine stiffness \
                         of the bonds is singular on them (the assembly offers no resistance to \
                         these strains; largest entry {scale:.3e} Pa)"
                    )));
                }
            }
        };
        Ok(StressServo {
            controls,
            gain: opts.gain,
            max_increment: opts.max_strain_increment,
            stiffness,
            controlled,
            controlled_inverse,
        })
    }

    /// The component controls.
    pub fn controls(&self) -> &[ComponentControl; 6] {
        &self.controls
    }

    /// The affine stiffness the controller uses (Pa).
    pub fn stiffness(&self) -> &Stiffness6 {
        &self.stiffness
    }

    /// The strain increment (Voigt, engineering shear) requested from the cell but not yet
    /// seen by the stress: the velocity gradient the integrator took up last step, times dt.
    fn pending_increment(sim: &Simulation) -> Voigt6 {
        match &sim.cell {
            Some(c) => to_voigt(&c.vel_grad, true) * sim.time_step(),
            None => Voigt6::zeros(),
        }
    }

    /// Compute this step's velocity gradient from the current stress and strain and hand
    /// it to the cell ([`Simulation::set_velocity_gradient`]); returns the strain increment
    /// requested (Voigt, engineering shear). Call before every [`Simulation::step`].
    pub fn apply(&self, sim: &mut Simulation) -> Result<Voigt6> {
        let dt = sim.time_step();
        let pending = Self::pending_increment(sim);
        let stress_pred = to_voigt(&sim.stress(), false) + self.stiffness * pending;
        let strain_pred = to_voigt(&sim.strain(), true) + pending;
        let mut inc = Voigt6::zeros();
        for (k, c) in self.controls.iter().enumerate() {
            match *c {
                ComponentControl::StrainRate(r) => inc[k] = r * dt,
                ComponentControl::Strain(target) => inc[k] = target - strain_pred[k],
                ComponentControl::Stress(_) => {}
            }
        }
        if !self.controlled.is_empty() {
            let m = self.controlled.len();
            let rhs = nalgebra::DVector::from_fn(m, |a, _| {
                let k = self.controlled[a];
                let target = match self.controls[k] {
                    ComponentControl::Stress(s) => s,
                    _ => 0.0,
                };
                // Coupling of the prescribed increments into this component.
                let coupled: f64 = (0..6)
                    .filter(|q| !self.controlled.contains(q))
                    .map(|q| self.stiffness[(k, q)] * inc[q])
                    .sum();
                self.gain * (target - stress_pred[k]) - coupled
            });
            let sol = &self.controlled_inverse * rhs;
            for (a, &k) in self.controlled.iter().enumerate() {
                inc[k] = sol[a];
            }
        }
        let largest = inc.amax();
        if largest > self.max_increment {
            inc *= self.max_increment / largest;
        }
        if inc.iter().any(|x| !x.is_finite()) {
            return Err(Error::Invalid(format!(
                "stress control at step {}: the requested strain increment is not finite \
                 (stress {:?} Pa)",
                sim.iteration(),
                stress_pred.as_slice()
            )));
        }
        sim.set_velocity_gradient(strain_tensor(&inc) / dt)?;
        Ok(inc)
    }

    /// Largest |σ_k − σ*_k| over the stress-controlled components divided by σ_ref (see
    /// [`ServoOptions::stress_tolerance`]); 0 when nothing is stress-controlled, and 0 when
    /// σ_ref = 0 and every error is 0.
    pub fn relative_stress_error(&self, stress: &Voigt6) -> f64 {
        let mut err: f64 = 0.0;
        let mut reference: f64 = 0.0;
        let mut target_ref: f64 = 0.0;
        for (k, c) in self.controls.iter().enumerate() {
            match *c {
                ComponentControl::Stress(s) => {
                    err = err.max((stress[k] - s).abs());
                    target_ref = target_ref.max(s.abs());
                }
                _ => reference = reference.max(stress[k].abs()),
            }
        }
        if self.controlled.len() == 6 {
            reference = target_ref;
        }
        if err == 0.0 {
            0.0
        } else if reference > 0.0 {
            err / reference
        } else {
            f64::INFINITY
        }
    }

    /// Largest |ε_k − target| over the strain-controlled components.
    pub fn strain_error(&self, strain: &Voigt6) -> f64 {
        self.controls
            .iter()
            .enumerate()
            .filter_map(|(k, c)| match *c {
                ComponentControl::Strain(t) => Some((strain[k] - t).abs()),
                _ => None,
            })
            .fold(0.0, f64::max)
    }
}

/// The converged state of a servo-controlled run.
#[derive(Clone, Debug, PartialEq)]
pub struct ServoOutcome {
    /// Final cell strain (Voigt, engineering shear).
    pub strain: Voigt6,
    /// Final Love stress, symmetric part (Voigt, Pa).
    pub stress: Voigt6,
    /// Steps used.
    pub steps: usize,
    /// Final relative stress error ([`StressServo::relative_stress_error`]).
    pub relative_stress_error: f64,
    /// Final relative stress change over the window.
    pub stress_change: f64,
    /// Unbalanced force and torque reached.
    pub unbalance: Unbalance,
}

/// Servo-control `sim` until every stress-controlled component is within t_r·σ_ref of its
/// target, every target strain is reached (to 1e-9 of its size, at least 1e-15), the
/// stress is steady over the window and the particles are in equilibrium
/// ([`ServoOptions::unbalanced_tolerance`]). `progress` receives the step count. Errors if a
/// strain rate is prescribed (a steady state needs fixed strains) or at the step limit.
pub fn servo_until_converged(
    sim: &mut Simulation,
    servo: &StressServo,
    opts: &ServoOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<ServoOutcome> {
    if let Some(k) = servo
        .controls
        .iter()
        .position(|c| matches!(c, ComponentControl::StrainRate(r) if *r != 0.0))
    {
        return Err(Error::Invalid(format!(
            "servo_until_converged: Voigt component {k} has a non-zero strain rate, so no \
             steady state exists; prescribe a target strain instead"
        )));
    }
    let strain_scale = servo
        .controls
        .iter()
        .filter_map(|c| match *c {
            ComponentControl::Strain(t) => Some(t.abs()),
            _ => None,
        })
        .fold(0.0, f64::max);
    let strain_tolerance = (1e-9 * strain_scale).max(1e-15);
    equilibrium::check_tolerance(opts.unbalanced_tolerance)?;
    let mut steady = SteadyWindow::new(opts.window);
    let window = steady.steps();
    let mut steps = 0;
    loop {
        servo.apply(sim)?;
        sim.step()?;
        steps += 1;
        let stress = to_voigt(&sim.stress(), false);
        // A window of equal values is steady even when they are zero.
        let change = match steady.push(stress) {
            Some(spread) if spread.change == 0.0 => 0.0,
            Some(spread) => spread.relative(),
            None => f64::INFINITY,
        };
        let stress_error = servo.relative_stress_error(&stress);
        let strain = to_voigt(&sim.strain(), true);
        let strain_error = servo.strain_error(&strain);
        // Equilibrium is measured only once everything else is met (it costs a pass).
        if change < opts.steady_tolerance
            && stress_error <= opts.stress_tolerance
            && strain_error <= strain_tolerance
        {
            let unbalance = Unbalance::of(sim);
            if unbalance.within(opts.unbalanced_tolerance) {
                return Ok(ServoOutcome {
                    strain,
                    stress,
                    steps,
                    relative_stress_error: stress_error,
                    stress_change: change,
                    unbalance,
                });
            }
        }
        if steps >= opts.max_steps {
            return Err(Error::NotConverged(format!(
                "stress control did not converge in {steps} steps: {}, relative stress error \
                 {stress_error:.3e} (tolerance t_r = {:.1e}), relative stress change {change:.3e} \
                 over {window} steps (tolerance {:.1e}), strain error {strain_error:.3e}; {}, or \
                 loosen the tolerances",
                Unbalance::of(sim).describe(opts.unbalanced_tolerance),
                opts.stress_tolerance,
                opts.steady_tolerance,
                equilibrium::budget_advice(sim)
            )));
        }
        progress(steps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voigt_round_trip() {
        let v = Voigt6::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let m = strain_tensor(&v);
        assert_eq!(to_voigt(&m, true), v);
        assert_eq!(m, m.transpose());
    }
}
