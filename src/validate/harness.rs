//! The harness every engine's validation shares: the pass/fail [`Check`], the step-by-step
//! [`HistoryComparison`], the [`Timing`] list, the [`Report`] with its derived JSON, and the
//! checks as a text table or CSV. An engine (YADE, LIGGGHTS, …) adds only a runner that
//! runs its code, parses its outputs and fills a [`Report`] with its [`EngineDetails`].

use crate::assembly::Assembly;
use crate::bonds::{BondSet, BondStiffness};
use crate::dem::quat::Quat;
use crate::dem::state::deterministic_sum_mat3;
use crate::dem::{BondLaw, DemOptions, MassOptions, Simulation};
use crate::model::Model;
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::{Error, Mat3, Result, Vec3};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

// What every engine is given (the problem, the progress callback, the test kind): below the
// engines and the specimen test, which both take it (`engine.rs` re-exports it).

/// One line per finished stage of a run; called from the engine's threads (hence `Sync`).
pub type Progress<'a> = &'a (dyn Fn(&str) + Sync);

/// The test an engine runs on the problem.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TestKind {
    /// Element tests of a periodic bonded cell: undamped stress histories step by step
    /// against the reference integrator, and damped quasi-static 6×6 tensors against the
    /// integrator and the relaxed solver (every engine today).
    #[default]
    PeriodicElement,
}

impl TestKind {
    /// Name in messages.
    pub fn name(self) -> &'static str {
        match self {
            TestKind::PeriodicElement => "periodic element",
        }
    }
}

/// Refuse any tolerance of `named` (option name, value) for which `admissible` is false,
/// saying what is `expected`.
pub fn check_tolerances(
    engine: &str,
    named: &[(&str, f64)],
    expected: &str,
    admissible: fn(f64) -> bool,
) -> Result<()> {
    match named.iter().find(|(_, v)| !admissible(*v)) {
        Some((name, v)) => Err(Error::Invalid(format!(
            "validate {engine}: the {name} must be {expected}, got {v}"
        ))),
        None => Ok(()),
    }
}

/// How an engine launches its free-specimen decks: the settings of `validate ENGINE` they
/// take, given by [`super::Engine::decks`] (so a deck depends on no engine file).
#[derive(Clone, Debug, PartialEq)]
pub struct Launch {
    /// The program run (`lmp`, the LIGGGHTS driver; YADE is found on PATH).
    pub program: PathBuf,
    /// The process counts of the runs compared (1, then more with `-np`).
    pub processes: Vec<usize>,
    /// Particle density (kg/m³).
    pub density: f64,
    /// Time step (s); `None`: `safety` × the single-particle stable step.
    pub time_step: Option<f64>,
    /// Fraction of the stable step taken when `time_step` is `None` (the same in the engine
    /// and the integrator).
    pub safety: f64,
}

impl Launch {
    /// The decks' time step (s): `time_step`, else `safety` × the single-particle stable step
    /// of the bonded packing at `density` ([`crate::export::liggghts::stable_timestep`]).
    pub fn step(&self, packing: &Packing, bonds: &BondSet, springs: &BondStiffness) -> Result<f64> {
        match self.time_step {
            Some(dt) => Ok(dt),
            None => Ok(self.safety
                * crate::export::liggghts::stable_timestep(packing, bonds, springs, self.density)?),
        }
    }
}

/// What every engine is given: where to run, the bonded packing, its model, the test kind.
#[derive(Clone, Copy, Debug)]
pub struct Problem<'a> {
    /// Directory the engine writes its decks into and runs in (must exist).
    pub dir: &'a Path,
    /// The spheres and their cell.
    pub packing: &'a Packing,
    /// The bonds.
    pub bonds: &'a BondSet,
    /// Each bond's springs.
    pub springs: &'a BondStiffness,
    /// The model the springs came from (written beside an export that records it).
    pub model: Option<&'a Model>,
    /// The test to run.
    pub kind: TestKind,
}

impl<'a> Problem<'a> {
    /// The periodic element tests of `a` in `dir`.
    pub fn of(dir: &'a Path, a: &'a Assembly) -> Problem<'a> {
        Problem {
            dir,
            packing: &a.packing,
            bonds: &a.bonds,
            springs: &a.springs,
            model: Some(&a.model),
            kind: TestKind::PeriodicElement,
        }
    }
}

/// One comparison: the measured relative difference and, for a pass/fail check, the
/// tolerance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Check {
    /// Short id (`history`, `tensor-driver-relaxed`, …).
    pub id: String,
    /// What is compared.
    pub description: String,
    /// Measured relative difference (dimensionless).
    pub value: f64,
    /// Largest admissible value; `None`: reported only.
    pub tolerance: Option<f64>,
    /// `value ≤ tolerance` (false for NaN); true when reported only.
    pub passed: bool,
    /// A run that had not settled: its estimated remaining relative change. The comparison
    /// is then reported as "not converged" and not judged (it neither passes nor fails the
    /// tolerance it would have had).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_converged: Option<f64>,
}

impl Check {
    /// A pass/fail check: passed when `value ≤ tolerance` (NaN fails).
    pub fn new(
        id: impl Into<String>,
        description: impl Into<String>,
        value: f64,
        tolerance: f64,
    ) -> Check {
        Check {
            id: id.into(),
            description: description.into(),
            value,
            tolerance: Some(tolerance),
            passed: value <= tolerance,
            not_converged: None,
        }
    }

    /// `new(id, description, value, tolerance)` when the compared run settled (estimated
    /// remaining relative change `remaining` ≤ `tolerance`); otherwise the comparison is
    /// reported as not converged, with `remaining`, and not judged: a slowly relaxing run
    /// (a network near a mechanism) is not a failed validation, and not a passed one. A
    /// non-finite `remaining` (nothing to tell by) leaves the check judged.
    pub fn unless_unsettled(
        id: impl Into<String>,
        description: impl Into<String>,
        value: f64,
        tolerance: f64,
        remaining: f64,
    ) -> Check {
        let mut c = Check::new(id, description, value, tolerance);
        if remaining.is_finite() && remaining > tolerance {
            c.tolerance = None;
            c.passed = true;
            c.not_converged = Some(remaining);
        }
        c
    }

    /// A difference reported without tolerance (a known convention difference).
    pub fn info(id: impl Into<String>, description: impl Into<String>, value: f64) -> Check {
        Check {
            id: id.into(),
            description: description.into(),
            value,
            tolerance: None,
            passed: true,
            not_converged: None,
        }
    }
}

/// Wall time of one stage of a validation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Timing {
    /// Stage.
    pub stage: String,
    /// Seconds.
    pub seconds: f64,
}

/// Run `f`, appending its wall time as `stage` to `timings`.
pub fn timed<T>(
    timings: &mut Vec<Timing>,
    stage: &str,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    let t0 = Instant::now();
    let r = f()?;
    timings.push(Timing {
        stage: stage.into(),
        seconds: t0.elapsed().as_secs_f64(),
    });
    Ok(r)
}

/// One regime's element-test histories of both codes (rows by path and step, step 0 first):
/// what an engine's side-by-side CSV and plot show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HistoryPair {
    /// The engine's.
    pub engine: Vec<HistoryRow>,
    /// The reference integrator's.
    pub integrator: Vec<HistoryRow>,
}

/// The damped element-test tensors of an engine and of anisobond, with the static
/// references (Pa).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DampedTensors {
    /// The engine's, C = S·E⁻¹ of the final stress/strain columns.
    pub engine: Stiffness6,
    /// The reference integrator's, same formula.
    pub integrator: Stiffness6,
    /// The relaxed solver's.
    pub relaxed: Stiffness6,
    /// The affine (Voigt) tensor of the same network, for scale.
    pub affine: Stiffness6,
}

/// Step-by-step comparison of two stress histories (Pa), relative to the largest |stress|
/// of the reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HistoryComparison {
    /// What was compared (a strain path's Voigt label, or a run's name).
    #[serde(rename = "path")]
    pub label: String,
    /// Steps compared.
    pub steps: usize,
    /// Largest |stress component| of the reference history (Pa).
    #[serde(rename = "max_stress_Pa")]
    pub max_stress: f64,
    /// Largest |σ_other − σ_reference| over steps and components (Pa).
    #[serde(rename = "max_difference_Pa")]
    pub max_difference: f64,
    /// `max_difference / max_stress` (NaN when the reference has no stress).
    pub relative: f64,
    /// Step where the largest difference occurs.
    pub worst_step: u64,
}

impl HistoryComparison {
    /// Compare matched rows `(step, reference stress, other stress)`.
    pub fn of_rows<'a>(
        label: impl Into<String>,
        rows: impl IntoIterator<Item = (u64, &'a [f64], &'a [f64])>,
    ) -> HistoryComparison {
        let (mut max_stress, mut max_difference, mut worst_step, mut steps) =
            (0.0f64, 0.0f64, 0, 0);
        for (step, r, o) in rows {
            steps += 1;
            max_stress = r.iter().fold(max_stress, |m, v| m.max(v.abs()));
            let d = r.iter().zip(o).fold(0.0f64, |m, (a, b)| {
                let d = (b - a).abs();
                if d.is_nan() || m.is_nan() {
                    f64::NAN
                } else {
                    m.max(d)
                }
            });
            if d > max_difference || d.is_nan() {
                max_difference = d;
                worst_step = step;
            }
        }
        HistoryComparison {
            label: label.into(),
            steps,
            max_stress,
            max_difference,
            relative: if max_stress > 0.0 {
                max_difference / max_stress
            } else {
                f64::NAN
            },
            worst_step,
        }
    }
}

/// An engine's own results inside a [`Report`]: its name and the JSON it adds.
pub trait EngineDetails {
    /// The engine's key fields in the report JSON (flattened beside the shared ones).
    type Json<'a>: Serialize
    where
        Self: 'a;
    /// Name of the validation (`yade`, `liggghts`).
    const ENGINE: &'static str;
    /// The engine's part of the JSON.
    fn json(&self) -> Self::Json<'_>;
    /// The tensors compared, named (Pa), for the summary's table.
    fn tensors(&self) -> Vec<(String, Stiffness6)>;
    /// The engine's own lines of the summary, before the checks (none by default).
    fn summary(_report: &Report<Self>) -> String
    where
        Self: Sized,
    {
        String::new()
    }
}

/// Everything a validation measured: the shared part and the engine's `details`
/// (reachable directly through `Deref`).
#[derive(Clone, Debug)]
pub struct Report<D> {
    /// Particles of the packing.
    pub n_particles: usize,
    /// Bonds.
    pub n_bonds: usize,
    /// Time step of every run (s).
    pub time_step: f64,
    /// The comparisons, in order.
    pub checks: Vec<Check>,
    /// Wall time of the stages.
    pub timings: Vec<Timing>,
    /// The engine's own results.
    pub details: D,
}

impl<D> std::ops::Deref for Report<D> {
    type Target = D;
    fn deref(&self) -> &D {
        &self.details
    }
}

impl<D> Report<D> {
    /// True when every check passed.
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed)
    }

    /// The checks outside their tolerance.
    pub fn failures(&self) -> Vec<&Check> {
        self.checks.iter().filter(|c| !c.passed).collect()
    }
}

/// JSON form of a [`Report`]: the shared keys and the engine's, flattened.
#[derive(Serialize)]
struct ReportJson<'a, J: Serialize> {
    validation: &'static str,
    passed: bool,
    n_particles: usize,
    n_bonds: usize,
    time_step_s: f64,
    #[serde(flatten)]
    details: J,
    checks: &'a [Check],
    timings: &'a [Timing],
}

/// The report as pretty JSON (newline-terminated).
pub fn report_json<D: EngineDetails>(r: &Report<D>) -> Result<String> {
    let j = ReportJson {
        validation: D::ENGINE,
        passed: r.passed(),
        n_particles: r.n_particles,
        n_bonds: r.n_bonds,
        time_step_s: r.time_step,
        details: r.details.json(),
        checks: &r.checks,
        timings: &r.timings,
    };
    serde_json::to_string_pretty(&j)
        .map(|s| s + "\n")
        .map_err(|e| Error::Invalid(format!("validation report: cannot serialise: {e}")))
}

/// Write the report JSON to `path` (atomically).
pub fn write_report_json<D: EngineDetails>(path: &Path, r: &Report<D>) -> Result<()> {
    crate::io::write_string_atomic(path, &report_json(r)?)
}

/// Write `report.json` ([`report_json`]) and `checks.csv` ([`checks_csv`]) into `dir`;
/// returns their paths.
pub fn write_report_and_checks<D: EngineDetails>(
    dir: &Path,
    r: &Report<D>,
) -> Result<Vec<PathBuf>> {
    let json = dir.join("report.json");
    write_report_json(&json, r)?;
    let csv = dir.join("checks.csv");
    crate::io::write_string_atomic(&csv, &checks_csv(&r.checks))?;
    Ok(vec![json, csv])
}

/// True when the packing, bonds and springs read back from an engine's files (`read`) are bit
/// for bit those written (`given`): positions, radii, cell lengths (or no cell), bond ends
/// and images, every spring. Else the two codes would not run the same problem.
pub(crate) fn reads_back_same(
    given: (&Packing, &BondSet, &BondStiffness),
    read: (&Packing, &BondSet, &BondStiffness),
) -> bool {
    let ((p, b, k), (p2, b2, k2)) = (given, read);
    p.positions == p2.positions
        && p.radii == p2.radii
        && p.cell.map(|c| c.lengths) == p2.cell.map(|c| c.lengths)
        && b.i == b2.i
        && b.j == b2.j
        && b.image == b2.image
        && k.kn == k2.kn
        && k.ks == k2.ks
        && k.kr == k2.kr
        && k.ktw == k2.ktw
}

pub use crate::tensor::compare::{matrix_rows, rows};

use crate::history::HistoryRow;

const PATH_LABELS: [&str; 6] = ["11", "22", "33", "23", "13", "12"];

/// Compare two codes' histories of strain path `path` (Voigt 0–5) step by step, rows
/// matched by step number; `reference` = (name, rows) is the one differences are relative
/// to. Errors (naming both codes) when either has no row of the path or the steps differ.
pub fn compare_history_rows(
    path: usize,
    reference: (&str, &[HistoryRow]),
    other: (&str, &[HistoryRow]),
) -> Result<HistoryComparison> {
    let label = PATH_LABELS[path.min(5)];
    let r: Vec<&HistoryRow> = reference.1.iter().filter(|x| x.path == path).collect();
    let o: Vec<&HistoryRow> = other.1.iter().filter(|x| x.path == path).collect();
    if r.is_empty() || o.is_empty() {
        return Err(Error::Invalid(format!(
            "history comparison of path {label}: {} {} rows and {} {} rows",
            r.len(),
            reference.0,
            o.len(),
            other.0
        )));
    }
    let pairs: Vec<(&HistoryRow, &HistoryRow)> = r
        .iter()
        .filter_map(|a| o.iter().find(|b| b.step == a.step).map(|b| (*a, *b)))
        .collect();
    if pairs.len() != r.len() || pairs.len() != o.len() {
        return Err(Error::Invalid(format!(
            "history comparison of path {label}: {} has {} rows, {} {}, {} steps in common",
            reference.0,
            r.len(),
            other.0,
            o.len(),
            pairs.len()
        )));
    }
    Ok(HistoryComparison::of_rows(
        label,
        pairs
            .iter()
            .map(|(a, b)| (a.step as u64, a.stress.as_slice(), b.stress.as_slice())),
    ))
}

/// CSV of two codes' histories side by side: `path,step,time_s,e_path`, the first code's
/// six stress components, the second's, and the largest absolute difference (Pa). Rows in
/// the first code's order; `names` are the column prefixes.
pub fn side_by_side_csv(title: &str, a: (&str, &[HistoryRow]), b: (&str, &[HistoryRow])) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {title}");
    let _ = writeln!(
        s,
        "# units: time_s in s; stresses in Pa (Love stress, tension positive, \
         Voigt 11,22,33,23,13,12); e_path = engineering strain of the loaded component"
    );
    s.push_str("path,step,time_s,e_path");
    for who in [a.0, b.0] {
        for l in PATH_LABELS {
            let _ = write!(s, ",{who}_s{l}_Pa");
        }
    }
    s.push_str(",max_abs_diff_Pa\n");
    for r in a.1 {
        let o = b.1.iter().find(|o| o.path == r.path && o.step == r.step);
        let _ = write!(
            s,
            "{},{},{:e},{:e}",
            PATH_LABELS[r.path.min(5)],
            r.step,
            r.time,
            r.strain[r.path.min(5)]
        );
        for v in r.stress.iter() {
            let _ = write!(s, ",{v:e}");
        }
        match o {
            Some(o) => {
                for v in o.stress.iter() {
                    let _ = write!(s, ",{v:e}");
                }
                let _ = writeln!(s, ",{:e}", (o.stress - r.stress).amax());
            }
            None => s.push_str(",,,,,,,\n"),
        }
    }
    s
}

/// Plot curves of the loaded stress component (MPa) against step, per path, for two codes:
/// the first as lines, the second as dots.
pub fn history_series(
    a: (&str, &[HistoryRow]),
    b: (&str, &[HistoryRow]),
) -> Vec<crate::plot::Series> {
    let mut out = Vec::new();
    let mut paths: Vec<usize> = a.1.iter().map(|r| r.path).collect();
    paths.dedup();
    for p in paths {
        for ((who, rows), dashed) in [(a, false), (b, true)] {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.path == p)
                .map(|r| (r.step as f64, r.stress[p] / 1e6))
                .collect();
            if points.len() >= 2 {
                out.push(crate::plot::Series {
                    label: format!("{who}: path {}, σ{}", PATH_LABELS[p], PATH_LABELS[p]),
                    points,
                    dashed,
                    colour: Some(p),
                });
            }
        }
    }
    out
}

/// The reference integrator free of damping, as the engines run it: `law` on the packing,
/// masses ρ(4/3)πR³ and inertias (2/5)mR² from `density`, time step `dt` (`None`: `safety`
/// × the critical estimate).
pub fn reference_simulation(
    packing: &Packing,
    bonds: &BondSet,
    law: Box<dyn BondLaw>,
    density: f64,
    dt: Option<f64>,
    safety: f64,
) -> Result<Simulation> {
    Simulation::new(packing, bonds, law, &reference_options(density, dt, safety))
}

/// The options of [`reference_simulation`] (undamped, unscaled masses of `density`).
pub fn reference_options(density: f64, dt: Option<f64>, safety: f64) -> DemOptions {
    DemOptions {
        time_step: dt,
        safety,
        local_damping: 0.0,
        mass: MassOptions {
            density,
            scaling: 1.0,
        },
        ..DemOptions::default()
    }
}

/// How the reference integrator starts an undamped history, to match the engine's own
/// integrator.
#[derive(Clone, Copy, Debug)]
pub enum HistoryStart<'a> {
    /// LAMMPS (in.history): the box changed at once by the deformation gradient F (cell
    /// and positions, x ← F·x), particles at rest, the leapfrog started like velocity
    /// Verlet ([`start_like_velocity_verlet`]).
    Strained(Mat3),
    /// LIGGGHTS: particles moving with `velocities` (m/s) and `spins` (rad/s) from the
    /// stress-free packing, started after velocity Verlet's first drift (x₁ = x₀ + dt·v₀,
    /// orientations turned by ω₀·dt), so that the integrator's step n evaluates the forces
    /// at LIGGGHTS' x_n.
    Moving {
        /// Initial velocities (m/s), one per particle.
        velocities: &'a [Vec3],
        /// Initial spins (rad/s), one per particle.
        spins: &'a [Vec3],
    },
}

/// Start the leapfrog as LAMMPS's velocity Verlet starts from rest: VV's first half kick
/// gives v(dt/2) = (dt/2)·a(0), the leapfrog's v(dt/2) = v(−dt/2) + dt·a(0), so the
/// particles at rest at t = 0 get v(−dt/2) = −(dt/2)·F(0)/m and ω(−dt/2) = −(dt/2)·T(0)/I
/// (from the forces at the current positions; a copy of the simulation takes one step to
/// evaluate them). From then on both give the same positions in exact arithmetic.
pub fn start_like_velocity_verlet(sim: &mut Simulation) -> Result<()> {
    let mut probe = sim.clone();
    probe.step()?;
    let dt = sim.time_step();
    let p = &mut sim.particles;
    for k in 0..p.len() {
        p.velocity[k] = probe.force[k] * (-0.5 * dt / p.mass[k]);
        p.angular_velocity[k] = probe.torque[k] * (-0.5 * dt / p.inertia[k]);
    }
    Ok(())
}

/// The reference integrator's run of the engine's undamped history: `sim` started as
/// `start`, stepped free, and at each iteration of `record` (ascending) the engines'
/// virial stress of that step's force evaluation, σ_ab = Σ l_a f_b / V (branch vectors l
/// from the bond's i to j end at the positions of the evaluation, f the force on i; Pa,
/// tension positive), Voigt 11 22 33 23 13 12 from the upper triangle (σ_23 = Σ l_y f_z /
/// V, …, as LAMMPS' and LIGGGHTS' virials; f includes the many-body term's g_b when the
/// simulation carries the term). Errors name `what` when the start does not fit
/// the packing or a stress is not finite.
pub fn integrator_history(
    mut sim: Simulation,
    start: HistoryStart,
    record: &[u64],
    what: &str,
) -> Result<Vec<[f64; 6]>> {
    match start {
        HistoryStart::Strained(f) => {
            let cell = sim
                .cell
                .as_mut()
                .ok_or_else(|| Error::Invalid(format!("{what}: the packing is not periodic")))?;
            cell.h = f * cell.h;
            cell.prev_h = cell.h;
            cell.trsf = f;
            for x in sim.particles.position.iter_mut() {
                *x = f * *x;
            }
            start_like_velocity_verlet(&mut sim)?;
        }
        HistoryStart::Moving { velocities, spins } => {
            let (dt, p) = (sim.time_step(), &mut sim.particles);
            if velocities.len() != p.len() || spins.len() != p.len() {
                return Err(Error::Invalid(format!(
                    "{what}: {} velocities and {} spins for {} particles",
                    velocities.len(),
                    spins.len(),
                    p.len()
                )));
            }
            for k in 0..p.len() {
                p.position[k] += velocities[k] * dt;
                p.velocity[k] = velocities[k];
                p.angular_velocity[k] = spins[k];
                let w = spins[k].norm();
                if w > 0.0 {
                    let dq = Quat::from_angle_axis(w * dt, &(spins[k] / w));
                    p.orientation[k] = dq.mul(&p.orientation[k]);
                    p.orientation[k].normalize();
                }
            }
        }
    }
    let mut out = Vec::with_capacity(record.len());
    for &n in record {
        while sim.iteration() < n {
            sim.step()?;
        }
        let branches: Vec<Vec3> = (0..sim.topology.len()).map(|b| sim.branch(b)).collect();
        let volume = sim.volume();
        // Forces at the positions of this step, then the move to the next.
        sim.step()?;
        // With the many-body term, its pair of forces ±g_b on the bond joins the bond's
        // (the engines tally its virial the same way).
        let m = deterministic_sum_mat3(branches.len(), |b| {
            let f = sim.loads.force_i(b) + sim.manybody_bond_force(b).unwrap_or_else(Vec3::zeros);
            branches[b] * f.transpose()
        }) / volume;
        let s = [
            m[(0, 0)],
            m[(1, 1)],
            m[(2, 2)],
            m[(1, 2)],
            m[(0, 2)],
            m[(0, 1)],
        ];
        if s.iter().any(|v| !v.is_finite()) {
            return Err(Error::Degenerate(format!(
                "{what}: non-finite stress at step {n}"
            )));
        }
        out.push(s);
    }
    Ok(out)
}

/// The checks as a text table (relative differences, dimensionless).
pub fn checks_table<D>(r: &Report<D>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<26} {:>12} {:>10}  {:<6} what",
        "check", "rel. diff", "tolerance", "result"
    );
    for c in &r.checks {
        let _ = writeln!(
            s,
            "{:<26} {:>12.3e} {:>10}  {:<6} {}",
            c.id,
            c.value,
            c.tolerance.map_or("—".into(), |t| format!("{t:.1e}")),
            match (c.tolerance, c.passed, c.not_converged) {
                (_, _, Some(_)) => "UNSETTLED",
                (None, _, _) => "info",
                (_, true, _) => "pass",
                _ => "FAILED",
            },
            c.description
        );
        if let Some(rest) = c.not_converged {
            let _ = writeln!(
                s,
                "{:<26} not converged: the run was still changing (estimated remaining relative \
                 change {rest:.2e}); not judged — relax longer to test it",
                ""
            );
        }
    }
    s
}

/// Tensors with their names, as [`EngineDetails::tensors`] returns them.
pub fn named(tensors: &[(&str, Stiffness6)]) -> Vec<(String, Stiffness6)> {
    tensors.iter().map(|(n, c)| (n.to_string(), *c)).collect()
}

/// The report as text: the engine's own lines, the time step, the checks table, the
/// compared tensors' C11 C22 C33 C12 C44 C55 C66 (GPa) and the wall times.
pub fn summary<D: EngineDetails>(r: &Report<D>) -> String {
    let mut s = D::summary(r);
    let _ = writeln!(s, "time step {:.4e} s\n", r.time_step);
    let _ = writeln!(
        s,
        "relative differences (dimensionless; stresses and tensors in Pa):"
    );
    s += &checks_table(r);
    let _ = writeln!(s, "\nC11 C22 C33 C12 C44 C55 C66 (GPa):");
    for (name, c) in r.details.tensors() {
        let _ = write!(s, "  {name:<14}");
        for (i, j) in [(0, 0), (1, 1), (2, 2), (0, 1), (3, 3), (4, 4), (5, 5)] {
            let _ = write!(s, " {:9.4}", c[(i, j)] / 1e9);
        }
        s.push('\n');
    }
    let _ = writeln!(s, "\nwall time:");
    for t in &r.timings {
        let _ = writeln!(s, "  {:<40} {:8.2} s", t.stage, t.seconds);
    }
    s
}

/// The details of a test with one report for every engine (the specimen, the strength
/// test): the line over its checks table and the names of its report files.
pub trait SharedDetails: EngineDetails + Sized {
    /// The line over the checks table of the summary.
    const CHECKS_HEADING: &'static str;
    /// The report JSON's file name.
    const REPORT_JSON: &'static str;
    /// The checks CSV's file name.
    const CHECKS_CSV: &'static str;
}

/// The report of a test with one report for every engine as text: the details' own lines,
/// the heading over the checks table, the wall times.
pub fn checks_summary<D: SharedDetails>(r: &Report<D>) -> String {
    let mut s = D::summary(r);
    let _ = writeln!(s, "{}", D::CHECKS_HEADING);
    s += &checks_table(r);
    let _ = writeln!(s, "\nwall time:");
    for t in &r.timings {
        let _ = writeln!(s, "  {:<40} {:8.2} s", t.stage, t.seconds);
    }
    s
}

/// Write the report JSON and the checks CSV of a test with one report for every engine into
/// `dir` (atomically each); returns the paths written.
pub fn write_report_files<D: SharedDetails>(dir: &Path, r: &Report<D>) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let json = dir.join(D::REPORT_JSON);
    write_report_json(&json, r)?;
    let csv = dir.join(D::CHECKS_CSV);
    crate::io::write_string_atomic(&csv, &checks_csv(&r.checks))?;
    Ok(vec![json, csv])
}

/// The checks reported as not converged, one line each: `id: remaining … (description)`.
pub fn unsettled_lines<D>(r: &Report<D>) -> Vec<String> {
    r.checks
        .iter()
        .filter_map(|c| {
            c.not_converged.map(|rest| {
                format!(
                    "{}: not converged (estimated remaining relative change {rest:.2e}; \
                     difference so far {:.2e}): {}",
                    c.id, c.value, c.description
                )
            })
        })
        .collect()
}

/// The checks as CSV: `check,relative_difference,tolerance,passed,description`.
pub fn checks_csv(checks: &[Check]) -> String {
    let mut c = String::from("check,relative_difference,tolerance,passed,description\n");
    for k in checks {
        let _ = writeln!(
            c,
            "{},{:e},{},{},\"{}\"",
            k.id,
            k.value,
            k.tolerance.map_or(String::new(), |t| format!("{t:e}")),
            k.passed,
            k.description.replace('"', "'")
        );
    }
    c
}

/// How a finished validation of engine `name` ends, for every client: the checks outside
/// their tolerance are [`Error::OutOfTolerance`]; else a compared run that had not settled
/// (its checks not judged: neither a pass nor a failure, so not a success either) is
/// [`Error::NotConverged`]; else success.
pub fn outcome<D>(name: &str, report: &Report<D>) -> Result<()> {
    let failures = failure_lines(report);
    if !failures.is_empty() {
        return Err(Error::OutOfTolerance {
            failed: failures.len(),
            checks: report.checks.len(),
            message: format!(
                "validate {name} FAILED ({} of {} checks outside tolerance):\n  {}",
                failures.len(),
                report.checks.len(),
                failures.join("\n  ")
            ),
        });
    }
    let unsettled = unsettled_lines(report);
    if !unsettled.is_empty() {
        return Err(Error::NotConverged(format!(
            "validate {name}: {} of {} checks not judged, the compared run had not settled \
             (relax longer: more steps or a looser settling tolerance):\n  {}",
            unsettled.len(),
            report.checks.len(),
            unsettled.join("\n  ")
        )));
    }
    Ok(())
}

/// The failing checks, one line each: `id: value > tolerance (description)`.
pub fn failure_lines<D>(r: &Report<D>) -> Vec<String> {
    r.failures()
        .iter()
        .map(|c| {
            format!(
                "{}: {:.3e} > tolerance {:.1e} ({})",
                c.id,
                c.value,
                c.tolerance.unwrap_or(f64::NAN),
                c.description
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_fail_on_nan_and_excess() {
        assert!(Check::new("x", "x", 1e-7, 1e-6).passed);
        assert!(!Check::new("x", "x", 2e-6, 1e-6).passed);
        assert!(!Check::new("x", "x", f64::NAN, 1e-6).passed);
        assert!(Check::info("x", "x", f64::NAN).passed);
    }

    #[test]
    fn an_unsettled_run_is_reported_not_judged() {
        // Settled: an ordinary check, judged on its value.
        let settled = Check::unless_unsettled("x", "x", 2e-6, 1e-6, 1e-7);
        assert!(!settled.passed && settled.not_converged.is_none());
        assert_eq!(settled, Check::new("x", "x", 2e-6, 1e-6));
        // Still changing by more than the tolerance: reported, not judged.
        let c = Check::unless_unsettled("x", "x", 7e-3, 1e-6, 2e-6);
        assert!(c.passed && c.tolerance.is_none() && c.not_converged == Some(2e-6));
        // Nothing to tell by: judged as before.
        for remaining in [f64::INFINITY, f64::NAN] {
            let c = Check::unless_unsettled("x", "x", 7e-3, 1e-6, remaining);
            assert_eq!(c, Check::new("x", "x", 7e-3, 1e-6));
        }
    }

    #[test]
    fn history_difference_is_relative_to_the_largest_reference_stress() {
        let r = [[0.0; 6], [100.0, -400.0, 0.0, 0.0, 0.0, 0.0]];
        let o = [[0.0; 6], [100.0, -398.0, 0.0, 0.0, 0.0, 1.0]];
        let h = HistoryComparison::of_rows("11", (0..2).map(|k| (k as u64, &r[k][..], &o[k][..])));
        assert_eq!((h.steps, h.max_stress, h.max_difference), (2, 400.0, 2.0));
        assert_eq!((h.relative, h.worst_step), (2.0 / 400.0, 1));
        let n = [[0.0; 6], [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]];
        let h = HistoryComparison::of_rows("x", (0..2).map(|k| (k as u64, &r[k][..], &n[k][..])));
        assert!(h.relative.is_nan());
    }
}
