//! Quasi-static compression of a clamped bar with the integrator (Kumar 2016 Sec. 5,
//! Figs. 7–9): the first end set held still, the second moved along the axis (translations
//! prescribed, rotations blocked), the axial stress from the reactions on the moved end, and
//! Kumar's normalised kinetic energy per particle Ẽ_kin = E_kin/(n·max(N·R)) (Eq. 16) along
//! the run. The end moves at constant velocity ([`Loading::ConstantRate`]) or at that
//! velocity only while Ẽ_kin is below a limit, holding still until the bar has relaxed below
//! it otherwise ([`Loading::KineticLimit`]: the recorded curve is quasi-static by Kumar's
//! criterion by construction).

use super::{build_law, DemOptions, LawKind, Simulation};
use crate::assembly::Assembly;
use crate::homogenize::buckling::RoundBar;
use crate::{Error, Result, Vec3};

/// How the moved end advances.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Loading {
    /// At constant velocity max_strain·l/(steps·dt) for `steps` steps.
    #[default]
    ConstantRate,
    /// At the same velocity while Ẽ_kin < `limit` (checked every `check_every` steps, the
    /// check being a loop over the bonds); otherwise the end holds still and the bar relaxes
    /// under its bond damping until Ẽ_kin < `limit` again. Points are recorded at states
    /// below the limit (and, flagged, where the end was stopped). At most `max_steps` steps
    /// in all (loading + holds): running out after the stress maximum ends the run (reported
    /// in [`CompressionResult::ran_out`]), before it is [`Error::NotConverged`].
    KineticLimit {
        /// Kumar's quasi-static bound on Ẽ_kin (he asks for 1e-8).
        limit: f64,
        /// Steps between checks of Ẽ_kin.
        check_every: usize,
        /// Cap on the total steps (≥ `steps`).
        max_steps: usize,
        /// Cundall local damping λ ∈ [0, 1) while the end holds still (the moving steps keep
        /// `dem.local_damping`). It damps every mode alike and leaves the static states as
        /// they are; 0 leaves the relaxation to the bond damping alone, which for a bar's
        /// axial and bending modes is weak (measured: one hold of l/r = 10 to 1e-7 takes
        /// tens of thousands of steps).
        hold_damping: f64,
    },
}

/// Settings of a compression run.
#[derive(Clone, Copy, Debug)]
pub struct CompressionOptions {
    /// Axial strain reached at the end of the run (shortening / l).
    pub max_strain: f64,
    /// Time steps of moving end to reach it (the loading rate: more steps, closer to
    /// quasi-static); with [`Loading::KineticLimit`] the holds come on top.
    pub steps: usize,
    /// Steps of moving end between recorded points.
    pub record_every: usize,
    /// Bond law of the integrator.
    pub law: LawKind,
    /// Time step, damping and masses.
    pub dem: DemOptions,
    /// How the end advances.
    pub loading: Loading,
}

impl Default for CompressionOptions {
    fn default() -> Self {
        CompressionOptions {
            max_strain: 0.01,
            steps: 100_000,
            record_every: 500,
            law: LawKind::Kumar,
            dem: DemOptions::default(),
            loading: Loading::ConstantRate,
        }
    }
}

/// One recorded state.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct CompressionPoint {
    /// Axial strain (shortening / l).
    pub strain: f64,
    /// Axial stress (Pa, compression positive): the moved end's reaction over πr².
    pub stress: f64,
    /// Ẽ_kin of Kumar 2016 Eq. 16.
    pub kinetic_ratio: f64,
    /// Ẽ_kin was below the limit of [`Loading::KineticLimit`] (a quasi-static point); false
    /// for the states where the end was stopped. Always true with [`Loading::ConstantRate`]
    /// (no limit).
    pub met_limit: bool,
    /// Time steps done so far (loading + holds).
    pub steps: usize,
}

/// The stress–strain curve and its maximum.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CompressionResult {
    /// Recorded states, in order.
    pub history: Vec<CompressionPoint>,
    /// Largest axial stress of the points that met the limit (Pa).
    pub max_stress: f64,
    /// Strain at the largest stress.
    pub strain_at_max: f64,
    /// Largest Ẽ_kin of the points that met the limit, up to the maximum (Kumar: below 1e-8
    /// for quasi-static; below the limit by construction with [`Loading::KineticLimit`]).
    pub max_kinetic_ratio_before_peak: f64,
    /// Time step used (s).
    pub time_step: f64,
    /// True when the maximum is the last point that met the limit: no stress drop by
    /// `max_strain` (not buckled, or buckled on a branch still rising, as quasi-static
    /// curves near the buckling load can be).
    pub peak_at_end: bool,
    /// Time steps done (loading + holds).
    pub total_steps: usize,
    /// The step cap of [`Loading::KineticLimit`] ended the run after the maximum, before the
    /// final strain.
    pub ran_out: bool,
}

/// Kumar 2016 Eq. 16: Ẽ_kin = E_kin/(n·max(N·R)), N the bonds' normal force at the last
/// evaluation, R the mean radius of the pair, n the number of particles (0 while no bond
/// carries a force).
pub fn kinetic_ratio(sim: &Simulation, a: &Assembly) -> f64 {
    let mut max_nr: f64 = 0.0;
    for b in 0..a.bonds.len() {
        let nrm = sim.branch(b).normalize();
        let normal = sim.loads.per_bond[b].force_i.dot(&nrm).abs();
        let (i, j) = (a.bonds.i[b] as usize, a.bonds.j[b] as usize);
        let r = 0.5 * (a.packing.radii[i] + a.packing.radii[j]);
        max_nr = max_nr.max(normal * r);
    }
    let kinetic = sim.energies().kinetic;
    if max_nr > 0.0 {
        kinetic / (a.packing.len() as f64 * max_nr)
    } else {
        0.0
    }
}

/// The clamped bar being compressed.
struct Run<'a> {
    bar: &'a RoundBar,
    sim: Simulation,
    axis: Vec3,
    speed: f64,
}

impl Run<'_> {
    /// Move the second end set at `speed` along −axis (0: hold it still).
    fn set_speed(&mut self, speed: f64) -> Result<()> {
        let first = &self.bar.boundary.first_end;
        let second = &self.bar.boundary.second_end;
        let particles: Vec<usize> = first.iter().chain(second).map(|&p| p as usize).collect();
        let velocity = first
            .iter()
            .map(|_| Vec3::zeros())
            .chain(second.iter().map(|_| -self.axis * speed))
            .collect();
        self.sim
            .set_prescribed_motion(Some(super::sim::PrescribedMotion {
                particles,
                velocity,
            }))
    }

    /// The state after `moved` steps of moving end and `steps` in all.
    fn point(&self, moved: usize, steps: usize) -> Result<CompressionPoint> {
        let stress = self
            .bar
            .boundary
            .second_end
            .iter()
            .map(|&p| self.sim.force[p as usize].dot(&self.axis))
            .sum::<f64>()
            / self.bar.area();
        let kinetic_ratio = kinetic_ratio(&self.sim, &self.bar.assembly);
        if !(stress.is_finite() && kinetic_ratio.is_finite()) {
            return Err(Error::Degenerate(format!(
                "compression: non-finite stress or kinetic energy at step {steps}"
            )));
        }
        Ok(CompressionPoint {
            strain: moved as f64 * self.speed * self.sim.time_step() / self.bar.length,
            stress,
            kinetic_ratio,
            met_limit: true,
            steps,
        })
    }
}

/// Index of the largest stress among the points that met the limit.
fn peak(history: &[CompressionPoint]) -> Option<usize> {
    history
        .iter()
        .enumerate()
        .filter(|(_, p)| p.met_limit)
        .max_by(|x, y| x.1.stress.total_cmp(&y.1.stress))
        .map(|(k, _)| k)
}

/// Compress `bar` (clamped ends) with the integrator and record σ, ε, Ẽ_kin. Refuses a
/// strain that is not finite and in (0, 0.5), zero steps or recording interval, and for
/// [`Loading::KineticLimit`] a limit that is not finite and > 0, a zero check interval or a
/// step cap below `steps`; and a run longer than [`super::MAX_PARTICLE_STEPS`] (particles ×
/// `steps`, or × the step cap).
pub fn compress_clamped_bar(
    bar: &RoundBar,
    opts: &CompressionOptions,
) -> Result<CompressionResult> {
    compress_clamped_bar_with_progress(bar, opts, &|_| {})
}

/// Refuse the compression settings [`compress_clamped_bar`] lists.
fn check_compression_options(opts: &CompressionOptions) -> Result<()> {
    if !(opts.max_strain.is_finite() && opts.max_strain > 0.0 && opts.max_strain < 0.5) {
        return Err(Error::Invalid(format!(
            "compression: the final strain must be in (0, 0.5), got {}",
            opts.max_strain
        )));
    }
    if opts.steps == 0 || opts.record_every == 0 {
        return Err(Error::Invalid(
            "compression: steps and recording interval must be > 0".into(),
        ));
    }
    if let Loading::KineticLimit {
        limit,
        check_every,
        max_steps,
        hold_damping,
    } = opts.loading
    {
        if !(hold_damping.is_finite() && (0.0..1.0).contains(&hold_damping)) {
            return Err(Error::Invalid(format!(
                "compression: the hold damping must be in [0, 1), got {hold_damping}"
            )));
        }
        if !(limit.is_finite() && limit > 0.0) {
            return Err(Error::Invalid(format!(
                "compression: the kinetic-energy limit must be finite and > 0, got {limit}"
            )));
        }
        if check_every == 0 || max_steps < opts.steps {
            return Err(Error::Invalid(format!(
                "compression: the check interval must be > 0 and the step cap ≥ the {} \
                 loading steps, got {check_every} and {max_steps}",
                opts.steps
            )));
        }
    }
    Ok(())
}

impl Run<'_> {
    /// [`Loading::ConstantRate`]: `steps` steps of moving end, a point every `record_every`
    /// and at the last; returns the steps run.
    fn load_at_constant_rate(
        &mut self,
        opts: &CompressionOptions,
        progress: &(dyn Fn(f64) + Sync),
        history: &mut Vec<CompressionPoint>,
    ) -> Result<usize> {
        let every = (opts.steps / 100).max(1);
        for s in 1..=opts.steps {
            self.sim.step()?;
            if s % opts.record_every == 0 || s == opts.steps {
                history.push(self.point(s, s)?);
            }
            if s % every == 0 {
                progress(s as f64 / opts.steps as f64);
            }
        }
        Ok(opts.steps)
    }

    /// Hold the moved end still under Cundall damping `hold_damping` (`still`), or move it
    /// again at the loading speed under `moving_damping`.
    fn hold(&mut self, still: bool, hold_damping: f64, moving_damping: f64) -> Result<()> {
        self.set_speed(if still { 0.0 } else { self.speed })?;
        self.sim
            .set_local_damping(if still { hold_damping } else { moving_damping })
    }

    /// [`Loading::KineticLimit`]: move the end while Ẽ_kin < `limit` (Kumar Eq. 16), hold it
    /// still otherwise; returns the steps run and whether the step cap ended the run after
    /// the stress maximum.
    fn load_below_kinetic_limit(
        &mut self,
        opts: &CompressionOptions,
        progress: &(dyn Fn(f64) + Sync),
        history: &mut Vec<CompressionPoint>,
    ) -> Result<(usize, bool)> {
        let Loading::KineticLimit {
            limit,
            check_every,
            max_steps,
            hold_damping,
        } = opts.loading
        else {
            unreachable!("called for the kinetic-limit loading only")
        };
        let moving_damping = opts.dem.local_damping;
        // `moved`: steps with the end moving; `due`: of them since the last point.
        let (mut moved, mut due, mut total, mut moving) = (0, 0, 0, true);
        loop {
            if total == max_steps {
                self.refuse_before_peak(opts, history, moved, total)?;
                return Ok((total, true));
            }
            self.sim.step()?;
            total += 1;
            if moving {
                moved += 1;
                due += 1;
                if moved == opts.steps {
                    self.hold(true, hold_damping, moving_damping)?;
                    moving = false;
                }
            }
            if total % check_every != 0 {
                continue;
            }
            let mut p = self.point(moved, total)?;
            if p.kinetic_ratio < limit {
                if due >= opts.record_every || moved == opts.steps {
                    history.push(p);
                    due = 0;
                }
                if moved == opts.steps {
                    break;
                }
                if !moving {
                    self.hold(false, hold_damping, moving_damping)?;
                    moving = true;
                }
            } else if moving {
                self.hold(true, hold_damping, moving_damping)?;
                moving = false;
                if due >= opts.record_every {
                    p.met_limit = false;
                    history.push(p);
                }
            }
            progress(moved as f64 / opts.steps as f64);
        }
        Ok((total, false))
    }

    /// At the step cap of [`Loading::KineticLimit`]: fine after the stress maximum (a later
    /// quasi-static point lower), else [`Error::NotConverged`] with the state reached.
    fn refuse_before_peak(
        &self,
        opts: &CompressionOptions,
        history: &[CompressionPoint],
        moved: usize,
        total: usize,
    ) -> Result<()> {
        let Loading::KineticLimit {
            limit, max_steps, ..
        } = opts.loading
        else {
            unreachable!("called for the kinetic-limit loading only")
        };
        let k = peak(history);
        let last = history.iter().rposition(|p| p.met_limit);
        if matches!((k, last), (Some(k), Some(last)) if k < last) {
            return Ok(());
        }
        let now = self.point(moved, total)?;
        Err(Error::NotConverged(format!(
            "compression: Ẽ_kin limit {limit:e} not met within {max_steps} steps \
             before the stress maximum: strain {:.4e} of {:.4e} reached ({moved} \
             loading steps of {}), Ẽ_kin now {:.3e}, stress {:.4e} Pa, largest \
             quasi-static stress {:.4e} Pa",
            now.strain,
            opts.max_strain,
            opts.steps,
            now.kinetic_ratio,
            now.stress,
            k.map_or(0.0, |k| history[k].stress)
        )))
    }
}

/// [`compress_clamped_bar`], reporting the fraction of the loading done (moved-end steps
/// over `steps`) to `progress`.
pub fn compress_clamped_bar_with_progress(
    bar: &RoundBar,
    opts: &CompressionOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<CompressionResult> {
    check_compression_options(opts)?;
    let a = &bar.assembly;
    a.refuse_manybody("the bar compression")?;
    let cap = match opts.loading {
        Loading::ConstantRate => opts.steps,
        Loading::KineticLimit { max_steps, .. } => max_steps,
    };
    super::check_run_size("compression", a.packing.len(), cap as f64)?;
    let law = build_law(opts.law, &a.packing, &a.bonds, &a.springs)?;
    let sim = Simulation::new(&a.packing, &a.bonds, law, &opts.dem)?;
    let dt = sim.time_step();
    let mut run = Run {
        bar,
        sim,
        axis: bar.region.axis(),
        speed: opts.max_strain * bar.length / (opts.steps as f64 * dt),
    };
    run.set_speed(run.speed)?;
    let mut history = Vec::new();
    let (total_steps, ran_out) = match opts.loading {
        Loading::ConstantRate => (
            run.load_at_constant_rate(opts, progress, &mut history)?,
            false,
        ),
        Loading::KineticLimit { .. } => {
            run.load_below_kinetic_limit(opts, progress, &mut history)?
        }
    };
    let k = peak(&history).ok_or_else(|| Error::Invalid("compression: nothing recorded".into()))?;
    let peak = history[k];
    let max_kinetic_ratio_before_peak = history[..=k]
        .iter()
        .filter(|p| p.met_limit)
        .map(|p| p.kinetic_ratio)
        .fold(0.0, f64::max);
    Ok(CompressionResult {
        peak_at_end: history[k + 1..].iter().all(|p| !p.met_limit),
        history,
        max_stress: peak.stress,
        strain_at_max: peak.strain,
        max_kinetic_ratio_before_peak,
        time_step: dt,
        total_steps,
        ran_out,
    })
}
