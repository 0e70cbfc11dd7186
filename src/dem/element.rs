//! Element tests in the periodic cell: six strain paths (three uniaxial strains, three pure
//! shears; Truszkowska 2018 Eqs. 17–22 as a homogeneous velocity gradient), each applied in
//! one step and relaxed quasi-statically with Cundall damping, then the symmetric 21-component
//! solve of Truszkowska Eq. 27 for the 6×6 stiffness.

use super::equilibrium::{self, SteadyWindow, Unbalance, DEFAULT_UNBALANCED_TOLERANCE};
use super::sim::{DemOptions, Energies, Simulation, StabilityReport};
use crate::history::HistoryRow;
use crate::tensor::{fit_symmetric_eq27, Stiffness6, Voigt6, VOIGT_PAIRS};
use crate::{Error, Mat3, Result};

/// Settings of the strain-controlled element tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementTestOptions {
    /// Strain magnitude e per path: every path loads its Voigt component by −e (uniaxial
    /// compression as Eqs. 17–19; shears with the same sign, engineering γ = −e — with
    /// mixed signs the pairwise equations of Eq. 27 cancel between uniaxial and shear paths).
    pub strain: f64,
    /// Cundall local damping during the relaxation (YADE measurements use 0.4).
    pub local_damping: f64,
    /// A path is converged when, over the last `window` steps, the largest change of the
    /// stress (Voigt, Pa) relative to its norm stays below this, and the particles are in
    /// equilibrium (`unbalanced_tolerance`).
    pub tolerance: f64,
    /// Equilibrium: the unbalanced force and torque ([`Unbalance`]) must be at most this
    /// (a steady stress alone is met at once when the time step is tiny).
    pub unbalanced_tolerance: f64,
    /// Steps of the convergence window.
    pub window: usize,
    /// Step limit per path; reaching it is an error naming the residual change.
    pub max_steps: usize,
    /// Integrator settings (time step, masses, check interval); its damping is replaced by
    /// `local_damping`.
    pub dem: DemOptions,
    /// Record a history row every this many steps (0: none).
    pub history_every: usize,
}

impl Default for ElementTestOptions {
    fn default() -> Self {
        ElementTestOptions {
            strain: 1e-5,
            local_damping: 0.4,
            tolerance: 1e-7,
            unbalanced_tolerance: DEFAULT_UNBALANCED_TOLERANCE,
            window: 10,
            max_steps: 20_000,
            dem: DemOptions::default(),
            history_every: 0,
        }
    }
}

/// One recorded state of a path: the shared [`HistoryRow`] (reachable through `Deref`)
/// and what only the integrator measures.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementRecord {
    /// Path, step within the path, time, strain and stress.
    pub state: HistoryRow,
    /// Energies (J).
    pub energies: Energies,
    /// YADE's unbalanced-force ratio.
    pub unbalanced_force: f64,
}

impl std::ops::Deref for ElementRecord {
    type Target = HistoryRow;
    fn deref(&self) -> &HistoryRow {
        &self.state
    }
}

/// Result of one strain path.
#[derive(Clone, Debug, PartialEq)]
pub struct PathResult {
    /// Path number 0..6 (Voigt component loaded).
    pub path: usize,
    /// Final cell strain (Voigt, engineering shear).
    pub strain: Voigt6,
    /// Final relaxed stress (Voigt, Pa).
    pub stress: Voigt6,
    /// Steps used.
    pub steps: usize,
    /// Unbalanced force and torque reached.
    pub unbalance: Unbalance,
    /// Recorded history.
    pub history: Vec<ElementRecord>,
}

/// The dynamic stiffness tensor and how it was obtained.
#[derive(Clone, Debug)]
pub struct DynamicTensor {
    /// C from Truszkowska Eq. 27 (Pa).
    pub c: Stiffness6,
    /// The six paths.
    pub paths: Vec<PathResult>,
    /// Time step used (s).
    pub time_step: f64,
    /// Critical time step and weakly bonded particles.
    pub stability: StabilityReport,
}

/// Displacement gradient of path `k` with magnitude `e` (Truszkowska Eqs. 17–22): uniaxial
/// compression −e along axis k for k < 3, symmetric pure shear of engineering strain −e in
/// the plane of Voigt component k for k ≥ 3 (same sign as the uniaxial paths, see
/// [`ElementTestOptions::strain`]).
pub fn path_gradient(k: usize, e: f64) -> Mat3 {
    let (a, b) = VOIGT_PAIRS[k.min(5)];
    let mut g = Mat3::zeros();
    if a == b {
        g[(a, a)] = -e;
    } else {
        g[(a, b)] = -0.5 * e;
        g[(b, a)] = -0.5 * e;
    }
    g
}

/// Voigt vector of a symmetric tensor; `engineering` doubles the shear terms (strain).
pub fn to_voigt(m: &Mat3, engineering: bool) -> Voigt6 {
    let s = (m + m.transpose()) * 0.5;
    Voigt6::from_fn(|k, _| {
        let (a, b) = VOIGT_PAIRS[k];
        if a != b && engineering {
            2.0 * s[(a, b)]
        } else {
            s[(a, b)]
        }
    })
}

/// Apply the displacement gradient `g` to the cell in one step (velocity gradient g/dt for
/// one integrator pass) and relax with damping until the stress is steady and the particles
/// are in equilibrium ([`ElementTestOptions::unbalanced_tolerance`]). Reaching the step
/// limit first is an error naming the residuals reached and what to change.
pub fn relax_path(
    sim: &mut Simulation,
    path: usize,
    g: &Mat3,
    opts: &ElementTestOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<PathResult> {
    equilibrium::check_tolerance(opts.unbalanced_tolerance)?;
    if opts.max_steps < 2 {
        return Err(Error::Invalid(format!(
            "element test step limit must be at least 2, got {}",
            opts.max_steps
        )));
    }
    sim.set_local_damping(opts.local_damping)?;
    let dt = sim.time_step();
    sim.set_velocity_gradient(g / dt)?;
    sim.step()?;
    sim.set_velocity_gradient(Mat3::zeros())?;
    let mut history = Vec::new();
    let mut steady = SteadyWindow::new(opts.window);
    let window = steady.steps();
    let mut steps = 1;
    let mut last_change = f64::INFINITY;
    let unbalance = loop {
        sim.step()?;
        steps += 1;
        let stress = to_voigt(&sim.stress(), false);
        if opts.history_every > 0 && steps % opts.history_every == 0 {
            history.push(ElementRecord {
                state: HistoryRow {
                    path,
                    step: steps,
                    time: sim.time(),
                    strain: to_voigt(&sim.strain(), true),
                    stress,
                },
                energies: sim.energies(),
                unbalanced_force: sim.unbalanced_force(),
            });
        }
        if let Some(spread) = steady.push(stress) {
            last_change = spread.relative();
            // Equilibrium is measured only once the stress is steady (it costs a pass).
            if last_change < opts.tolerance {
                let u = Unbalance::of(sim);
                if u.within(opts.unbalanced_tolerance) {
                    break u;
                }
            }
        }
        if steps >= opts.max_steps {
            return Err(Error::NotConverged(format!(
                "element test path {path}: not relaxed after {steps} steps: {}, relative \
                 stress change {last_change:.3e} over {window} steps (tolerance {:.1e}); {}",
                Unbalance::of(sim).describe(opts.unbalanced_tolerance),
                opts.tolerance,
                equilibrium::budget_advice(sim)
            )));
        }
        progress(steps);
    };
    Ok(PathResult {
        path,
        strain: to_voigt(&sim.strain(), true),
        stress: to_voigt(&sim.stress(), false),
        steps,
        unbalance,
        history,
    })
}

/// Refuse a strain magnitude per path outside (0, 0.1) (`what` names the tests): the
/// element tests are linear, and a path of 10 % strain or more is not.
pub(crate) fn check_path_strain(strain: f64, what: &str) -> Result<()> {
    if !(strain.is_finite() && strain > 0.0 && strain < 0.1) {
        return Err(Error::Invalid(format!(
            "{what} strain must be in (0, 0.1), got {strain}"
        )));
    }
    Ok(())
}

/// Run the six strain paths (Voigt 0–5) in order with `run(path, step_progress)`, reporting
/// to `progress` the fraction done with the paths counted equally (a path's steps over
/// `max_steps`), and 1 at the end.
pub(crate) fn run_six_paths<P>(
    max_steps: usize,
    progress: &(dyn Fn(f64) + Sync),
    mut run: impl FnMut(usize, &mut dyn FnMut(usize)) -> Result<P>,
) -> Result<Vec<P>> {
    let max = max_steps.max(1) as f64;
    let mut paths = Vec::with_capacity(6);
    for k in 0..6 {
        paths.push(run(k, &mut |s| {
            progress((k as f64 + (s as f64 / max).min(1.0)) / 6.0)
        })?);
    }
    progress(1.0);
    Ok(paths)
}

/// Run the six paths from the same initial state and fit C (Truszkowska Eq. 27).
/// `progress` receives the fraction done (paths counted equally).
pub fn dynamic_tensor(
    initial: &Simulation,
    opts: &ElementTestOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<DynamicTensor> {
    check_path_strain(opts.strain, "element-test")?;
    if initial.cell.is_none() {
        return Err(Error::Invalid(
            "strain-controlled element tests need a periodic packing (a `# periodic Lx Ly Lz` header)".into(),
        ));
    }
    let paths = run_six_paths(opts.max_steps, progress, |k, path_progress| {
        let mut sim = initial.clone();
        let g = path_gradient(k, opts.strain);
        relax_path(&mut sim, k, &g, opts, path_progress)
    })?;
    let strains: Vec<Voigt6> = paths.iter().map(|p| p.strain).collect();
    let stresses: Vec<Voigt6> = paths.iter().map(|p| p.stress).collect();
    let c = fit_symmetric_eq27(&strains, &stresses)?;
    Ok(DynamicTensor {
        c,
        paths,
        time_step: initial.time_step(),
        stability: initial.stability().clone(),
    })
}
