//! `anisobond validate yade`: run one bonded periodic packing in YADE 2023.02a and in
//! anisobond, and check that they compute the same thing.
//!
//! Both codes get the same inputs bit for bit: the packing and bond table are written to
//! `DIR/yade/` (shortest round-trip numbers) and anisobond's side is built from those files
//! read back, the time step is fixed by anisobond and passed to YADE (`--dt`), the masses
//! come from the same density (m = ρ(4/3)πR³, I = (2/5)mR², YADE's `utils.sphere`), and
//! the strain paths are the ones of `anisobond_yade.run_path`: the velocity gradient
//! strain/dt for one step (Truszkowska 2018 Eqs. 17–22, uniaxial e_aa or pure shear γ_ab,
//! extension positive), zero afterwards, with YADE's one-step-late `velGrad`.
//!
//! Three comparisons:
//! 1. **undamped** (λ = 0): the stress histories (symmetric Love stress, Pa) step by step;
//!    the difference, relative to the largest |stress| of the path's run, must stay below
//!    [`Tolerances::history`] (default 1e-6) — law (a) is YADE's law, so only rounding
//!    separates them;
//! 2. **damped quasi-static** (Cundall λ = 0.4, the strain in one step, all six paths):
//!    the 6×6 tensors C = S·E⁻¹ of the final stress and strain columns (as
//!    `anisobond_yade.element_tests` computes it) from YADE and from the reference
//!    integrator must agree within [`Tolerances::tensor`] (default 0.1 %);
//! 3. both within [`Tolerances::relaxed`] (default 0.1 %) of the exact quasi-static
//!    tensor of the relaxed solver with YADE's mid-gap contact point ([`LeverArm::MidGap`]).
//!
//! Tensor differences are max_ab |A − B| / max_ab |B| ([`relative_difference`]).

use super::engine::{Decks, Launch};
use super::specimen;
use crate::bonds::{table, BondSet, BondStiffness};
use crate::dem::element::to_voigt;
use crate::dem::{build_law, LawKind, Simulation};
use crate::export::yade::{
    self as export, files, read_yade_history, read_yade_tensor, run_yade_script, HistoryRow,
    YadeRunOptions, PATH_LABELS,
};
use crate::homogenize::network::LeverArm;
use crate::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use crate::model::Model;
use crate::packing::{self, Packing};
use crate::tensor::compare::relative_difference;
use crate::tensor::{Stiffness6, VOIGT_PAIRS};
use crate::validate::engine::{self, check_tolerances, Engine, Problem, Progress, TestKind};
use crate::validate::harness::{
    history_series, matrix_rows, named, reads_back_same, reference_simulation, side_by_side_csv,
    write_report_json, Check, DampedTensors, EngineDetails, HistoryComparison, HistoryPair, Report,
    Timing,
};
use crate::{Error, Mat3, Result};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Output files of a validation directory.
pub mod outputs {
    /// Plot of the undamped histories.
    pub const UNDAMPED_PNG: &str = "undamped-history.png";
    /// Plot of the damped histories.
    pub const DAMPED_PNG: &str = "damped-history.png";
    /// The YADE export (packing, bond table, model, module, run.py, YADE's own outputs).
    pub const YADE_DIR: &str = "yade";
    /// Undamped stress histories, YADE and anisobond side by side.
    pub const UNDAMPED_CSV: &str = "undamped-history.csv";
    /// Damped stress histories, YADE and anisobond side by side.
    pub const DAMPED_CSV: &str = "damped-history.csv";
    /// Summary: settings, tensors, differences, checks, timings.
    pub const SUMMARY_JSON: &str = "validation.json";
    /// YADE's undamped history (inside [`YADE_DIR`]).
    pub const YADE_UNDAMPED_HISTORY: &str = "undamped-yade-history.csv";
    /// YADE's undamped tensor report (inside [`YADE_DIR`]; `C` is null unless six paths).
    pub const YADE_UNDAMPED_TENSOR: &str = "undamped-yade-tensor.json";
    /// YADE's damped history (inside [`YADE_DIR`]).
    pub const YADE_DAMPED_HISTORY: &str = "damped-yade-history.csv";
    /// YADE's damped tensor report (inside [`YADE_DIR`]).
    pub const YADE_DAMPED_TENSOR: &str = "damped-yade-tensor.json";
}

pub use super::engine::Tolerances;

/// Settings of a YADE validation.
#[derive(Clone, Debug, PartialEq)]
pub struct YadeValidationOptions {
    /// Strain of every path, applied in one step (engineering; extension positive).
    pub strain: f64,
    /// Particle density (kg/m³), the same in both codes.
    pub density: f64,
    /// Time step (s) of both codes; `None`: `safety` × anisobond's critical estimate.
    pub time_step: Option<f64>,
    /// Fraction of the critical time step used when `time_step` is `None`.
    pub safety: f64,
    /// Steps of the undamped runs (the strain step included).
    pub undamped_steps: usize,
    /// Paths of the undamped comparison (Voigt indices 0–5).
    pub undamped_paths: Vec<usize>,
    /// Steps of every damped path (the strain step included).
    pub damped_steps: usize,
    /// Cundall local damping λ of the damped runs.
    pub damping: f64,
    /// Relative CG residual of the relaxed solver (its tensor error is about the square).
    pub cg_tolerance: f64,
    /// Required agreement.
    pub tolerances: Tolerances,
}

impl Default for YadeValidationOptions {
    /// Strain 1e-5, density 2600 kg/m³, dt = 0.8 dt_c, 1,000 undamped steps on paths 11
    /// and 12, 200 damped steps with λ = 0.4 on all six paths, CG tolerance 1e-8.
    fn default() -> Self {
        YadeValidationOptions {
            strain: 1e-5,
            density: 2600.0,
            time_step: None,
            safety: 0.8,
            undamped_steps: 1000,
            undamped_paths: vec![0, 5],
            damped_steps: 200,
            damping: 0.4,
            cg_tolerance: 1e-8,
            // 1e-6 for the undamped histories, 0.1 % for the tensors; no MPI runs.
            tolerances: Tolerances {
                history: 1e-6,
                tensor: 1e-3,
                relaxed: 1e-3,
                processes: 0.0,
            },
        }
    }
}

impl YadeValidationOptions {
    /// Check every value; the error names the option and what is admissible.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("validate yade: {m}")));
        let run = YadeRunOptions {
            strain: self.strain,
            steps: self.undamped_steps.max(self.damped_steps),
            damping: self.damping,
            density: self.density,
            time_step: self.time_step,
            safety: self.safety,
            paths: self.undamped_paths.clone(),
            stress_volume: None,
        };
        run.validate()?;
        if self.undamped_steps < 2 || self.damped_steps < 2 {
            return bad(format!(
                "undamped and damped steps must be at least 2 (the strain shows in the stress \
                 from step 2 on), got {} and {}",
                self.undamped_steps, self.damped_steps
            ));
        }
        if self.damping == 0.0 {
            return bad("the damped comparison needs damping > 0".into());
        }
        if !(self.cg_tolerance.is_finite() && self.cg_tolerance > 0.0 && self.cg_tolerance < 1.0) {
            return bad(format!(
                "CG tolerance must be in (0, 1), got {}",
                self.cg_tolerance
            ));
        }
        let t = &self.tolerances;
        let named = [
            ("history tolerance", t.history),
            ("tensor tolerance", t.tensor),
            ("relaxed tolerance", t.relaxed),
        ];
        check_tolerances("yade", &named, "finite and ≥ 0", |v| {
            v.is_finite() && v >= 0.0
        })?;
        Ok(())
    }
}

/// What only the YADE validation measures; the rest is in the shared [`Report`].
#[derive(Clone, Debug)]
pub struct YadeDetails {
    /// Settings used.
    pub options: YadeValidationOptions,
    /// anisobond's critical time-step estimate (s).
    pub critical_time_step: f64,
    /// YADE's version string (from its report).
    pub yade_version: String,
    /// Undamped histories of YADE and of anisobond's reference integrator.
    pub undamped_runs: HistoryPair,
    /// One comparison per undamped path (labelled by the path's Voigt label).
    pub undamped: Vec<HistoryComparison>,
    /// Damped histories of YADE and of the reference integrator.
    pub damped_runs: HistoryPair,
    /// The damped tensors of YADE and of the integrator, the relaxed solver's (mid-gap
    /// lever arms) and the affine one.
    pub tensors: DampedTensors,
    /// The YADE export directory.
    pub yade_dir: PathBuf,
}

/// Everything a YADE validation measured. Checks in the order: undamped paths
/// (`history-11`, …), `tensor-yade-integrator`, `tensor-yade-relaxed`,
/// `tensor-integrator-relaxed`.
pub type YadeValidation = Report<YadeDetails>;

/// Settings as written to the summary JSON.
#[derive(Serialize)]
struct JsonSettings {
    strain: f64,
    density_kg_m3: f64,
    undamped_steps: usize,
    undamped_paths: Vec<&'static str>,
    damped_steps: usize,
    damping: f64,
    cg_tolerance: f64,
    law: &'static str,
    lever_arm: &'static str,
    tensor_formula: &'static str,
    difference: &'static str,
}

/// The YADE part of the summary JSON: settings, tolerances, per-path histories, tensors (Pa).
#[derive(Serialize)]
pub struct YadeJson<'a> {
    yade_version: &'a str,
    critical_time_step_s: f64,
    settings: JsonSettings,
    tolerances: Tolerances,
    undamped: &'a [HistoryComparison],
    units: &'static str,
    #[serde(rename = "C_yade", serialize_with = "matrix_rows")]
    c_yade: &'a Stiffness6,
    #[serde(rename = "C_anisobond", serialize_with = "matrix_rows")]
    c_anisobond: &'a Stiffness6,
    #[serde(rename = "C_relaxed", serialize_with = "matrix_rows")]
    c_relaxed: &'a Stiffness6,
    #[serde(rename = "C_affine", serialize_with = "matrix_rows")]
    c_affine: &'a Stiffness6,
}

impl EngineDetails for YadeDetails {
    type Json<'a> = YadeJson<'a>;
    const ENGINE: &'static str = "yade";
    fn json(&self) -> YadeJson<'_> {
        let o = &self.options;
        YadeJson {
            yade_version: &self.yade_version,
            critical_time_step_s: self.critical_time_step,
            settings: JsonSettings {
                strain: o.strain,
                density_kg_m3: o.density,
                undamped_steps: o.undamped_steps,
                undamped_paths: o.undamped_paths.iter().map(|&p| PATH_LABELS[p]).collect(),
                damped_steps: o.damped_steps,
                damping: o.damping,
                cg_tolerance: o.cg_tolerance,
                law: "yade (Law2_ScGeom6D_CohFrictPhys_CohesionMoment)",
                lever_arm: "mid-gap",
                tensor_formula: "C = S E^-1 of the final stress/strain columns",
                difference: "max_ab |A - B| / max_ab |B|",
            },
            tolerances: o.tolerances,
            undamped: &self.undamped,
            units: "Pa",
            c_yade: &self.tensors.engine,
            c_anisobond: &self.tensors.integrator,
            c_relaxed: &self.tensors.relaxed,
            c_affine: &self.tensors.affine,
        }
    }
    fn tensors(&self) -> Vec<(String, Stiffness6)> {
        named(&[
            ("YADE", self.tensors.engine),
            ("anisobond", self.tensors.integrator),
            ("relaxed", self.tensors.relaxed),
        ])
    }
    fn summary(v: &YadeValidation) -> String {
        let o = &v.options;
        let mut s = format!(
            "YADE {} vs anisobond: {} particles, {} bonds, dt {:.4e} s (critical estimate \
             {:.4e} s), density {} kg/m³, strain {:e} in one step\n\n",
            v.yade_version,
            v.n_particles,
            v.n_bonds,
            v.time_step,
            v.critical_time_step,
            o.density,
            o.strain
        );
        let _ = writeln!(
            s,
            "undamped stress histories ({} steps, damping 0):\n  {:<6} {:>14} {:>16} {:>12} {:>11}",
            o.undamped_steps, "path", "max |σ| (Pa)", "max |Δσ| (Pa)", "relative", "worst step"
        );
        for h in &v.undamped {
            let _ = writeln!(
                s,
                "  {:<6} {:>14.4e} {:>16.4e} {:>12.3e} {:>11}",
                h.label, h.max_stress, h.max_difference, h.relative, h.worst_step
            );
        }
        let _ = writeln!(
            s,
            "\ndamped element tests: Cundall {}, {} steps per path, C = S·E⁻¹ of the final columns",
            o.damping, o.damped_steps
        );
        s
    }
}

/// Velocity-gradient increment of path `path` (Voigt 0–5) carrying `strain` in one step,
/// as `anisobond_yade.velocity_gradient` × dt: uniaxial e_aa = strain, or the symmetric
/// pure shear with engineering γ_ab = strain (Truszkowska 2018 Eqs. 17–22, extension
/// positive). Dividing by dt gives the velocity gradient.
pub fn yade_path_increment(path: usize, strain: f64) -> Mat3 {
    let (a, b) = VOIGT_PAIRS[path.min(5)];
    let mut g = Mat3::zeros();
    if a == b {
        g[(a, a)] = strain;
    } else {
        g[(a, b)] = 0.5 * strain;
        g[(b, a)] = 0.5 * strain;
    }
    g
}

/// One path as `anisobond_yade.run_path` runs it, on a copy of `initial`: velocity
/// gradient strain/dt before the first step (YADE's `velGrad`, acting one step late on the
/// cell), zero after it, `steps` steps with Cundall damping `damping`. Rows after every
/// step, step 0 (the state before any step) first: cell strain (Voigt, engineering) and
/// the symmetric Love stress (Pa, tension positive, `utils.getStress()`).
pub fn run_path_like_yade(
    initial: &Simulation,
    path: usize,
    strain: f64,
    steps: usize,
    damping: f64,
) -> Result<Vec<HistoryRow>> {
    if path > 5 {
        return Err(Error::Invalid(format!(
            "strain path {path}: expected a Voigt index 0–5"
        )));
    }
    let mut sim = initial.clone();
    sim.set_local_damping(damping)?;
    let dt = sim.time_step();
    let row = |sim: &Simulation, step: usize| HistoryRow {
        path,
        step,
        time: sim.time(),
        strain: to_voigt(&sim.strain(), true),
        stress: to_voigt(&sim.stress(), false),
    };
    let mut rows = Vec::with_capacity(steps + 1);
    rows.push(row(&sim, 0));
    // Divide entry by entry as Python does (strain/dt, 0.5*strain/dt), for the same bits.
    let g = yade_path_increment(path, strain).map(|x| x / dt);
    sim.set_velocity_gradient(g)?;
    for k in 1..=steps {
        sim.step()?;
        if k == 1 {
            sim.set_velocity_gradient(Mat3::zeros())?;
        }
        rows.push(row(&sim, k));
    }
    Ok(rows)
}

/// C = S·E⁻¹ from the final minus initial stress and strain of each of the six paths (the
/// formula of `anisobond_yade.element_tests`). `rows` must hold paths 0–5.
pub fn tensor_from_columns(rows: &[HistoryRow], what: &str) -> Result<Stiffness6> {
    let mut e = Stiffness6::zeros();
    let mut s = Stiffness6::zeros();
    for (p, label) in PATH_LABELS.iter().enumerate() {
        let mine: Vec<&HistoryRow> = rows.iter().filter(|r| r.path == p).collect();
        let first = mine.iter().min_by_key(|r| r.step);
        let last = mine.iter().max_by_key(|r| r.step);
        let (Some(first), Some(last)) = (first, last) else {
            return Err(Error::Invalid(format!(
                "{what}: no history rows for path {label} (all six paths are needed for C)"
            )));
        };
        e.set_column(p, &(last.strain - first.strain));
        s.set_column(p, &(last.stress - first.stress));
    }
    let inv = e.try_inverse().ok_or_else(|| {
        Error::Invalid(format!(
            "{what}: the six final strain columns are singular: {e}"
        ))
    })?;
    Ok(s * inv)
}

/// Compare two histories of the same path step by step (rows matched by step number).
pub fn compare_histories(
    path: usize,
    yade: &[HistoryRow],
    anisobond: &[HistoryRow],
) -> Result<HistoryComparison> {
    crate::validate::harness::compare_history_rows(path, ("YADE", yade), ("anisobond", anisobond))
}

fn run_options(o: &YadeValidationOptions, dt: f64, undamped: bool) -> YadeRunOptions {
    YadeRunOptions {
        strain: o.strain,
        steps: if undamped {
            o.undamped_steps
        } else {
            o.damped_steps
        },
        damping: if undamped { 0.0 } else { o.damping },
        density: o.density,
        time_step: Some(dt),
        safety: o.safety,
        paths: if undamped {
            o.undamped_paths.clone()
        } else {
            (0..6).collect()
        },
        stress_volume: None,
    }
}

fn simulation(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    o: &YadeValidationOptions,
    dt: Option<f64>,
) -> Result<Simulation> {
    let law = build_law(LawKind::Yade, packing, bonds, k)?;
    reference_simulation(packing, bonds, law, o.density, dt, o.safety)
}

/// What the YADE thread returns: histories, damped tensor report, wall times.
struct YadeRuns {
    undamped: Vec<HistoryRow>,
    damped: Vec<HistoryRow>,
    tensor: export::YadeTensor,
    undamped_seconds: f64,
    damped_seconds: f64,
}

fn run_yade(
    script: &Path,
    dir: &Path,
    o: &YadeValidationOptions,
    dt: f64,
    progress: Progress,
) -> Result<YadeRuns> {
    // One YADE run: the undamped or the damped paths, into their history and tensor files.
    let run = |undamped: bool, history: &str, tensor: &str, what: &str| {
        let mut args = run_options(o, dt, undamped).to_args();
        args.extend([
            "--history".into(),
            history.into(),
            "--tensor".into(),
            tensor.into(),
        ]);
        let out = run_yade_script(script, &args)?;
        progress(&format!("YADE: {what} done in {:.1} s", out.wall_seconds));
        Ok::<_, Error>(out)
    };
    let undamped_out = run(
        true,
        outputs::YADE_UNDAMPED_HISTORY,
        outputs::YADE_UNDAMPED_TENSOR,
        "undamped runs",
    )?;
    let damped_out = run(
        false,
        outputs::YADE_DAMPED_HISTORY,
        outputs::YADE_DAMPED_TENSOR,
        "damped element tests",
    )?;
    Ok(YadeRuns {
        undamped: read_yade_history(&dir.join(outputs::YADE_UNDAMPED_HISTORY))?,
        damped: read_yade_history(&dir.join(outputs::YADE_DAMPED_HISTORY))?,
        tensor: read_yade_tensor(&dir.join(outputs::YADE_DAMPED_TENSOR))?,
        undamped_seconds: undamped_out.wall_seconds,
        damped_seconds: damped_out.wall_seconds,
    })
}

/// Check that the files YADE reads give back exactly the data anisobond was given.
fn check_round_trip(
    p: &Packing,
    b: &BondSet,
    k: &BondStiffness,
    p2: &Packing,
    b2: &BondSet,
    k2: &BondStiffness,
) -> Result<()> {
    if reads_back_same((p, b, k), (p2, b2, k2)) {
        Ok(())
    } else {
        Err(Error::Invalid(
            "validate yade: the exported packing or bond table does not read back bit for bit \
             (positions outside the cell [0, L)?); the two codes would not run the same problem"
                .into(),
        ))
    }
}

/// YADE 2023.02a (`yade` on PATH) as a validation [`Engine`], with its settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Yade(pub YadeValidationOptions);

impl Engine for Yade {
    type Details = YadeDetails;
    fn check(&self) -> Result<()> {
        self.0.validate()
    }
    fn run(&self, p: &Problem, progress: Progress) -> Result<YadeValidation> {
        match p.kind {
            TestKind::PeriodicElement => element_tests(p, &self.0, progress),
        }
    }
    fn write_files(&self, dir: &Path, r: &YadeValidation) -> Result<Vec<PathBuf>> {
        write_validation_files(dir, r)
    }
    fn decks(&self) -> Result<Option<Decks<'_>>> {
        let launch = Launch {
            program: "yade".into(),
            processes: vec![1],
            density: self.0.density,
            time_step: self.0.time_step,
            safety: self.0.safety,
        };
        Ok(Some(Decks {
            launch,
            specimen: specimen::yade::run,
            strength: Box::new(super::strength::yade::run),
        }))
    }
}

/// [`engine::validate`] with [`Yade`]: the periodic element tests of the packing `bonds`
/// and `springs` (of `model`) in `dir`.
pub fn validate_yade(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    model: Option<&Model>,
    opts: &YadeValidationOptions,
    progress: Progress,
) -> Result<YadeValidation> {
    let problem = Problem {
        dir,
        packing,
        bonds,
        springs,
        model,
        kind: TestKind::PeriodicElement,
    };
    engine::validate(&Yade(opts.clone()), &problem, progress)
}

/// The element tests: export to `dir/yade/`, run YADE there (in a second thread) and
/// anisobond's reference integrator and relaxed solver here, and compare. `progress`
/// receives one line per finished part. Errors when YADE is missing or fails, or the
/// inputs are not a periodic bonded packing; a comparison outside tolerance is not an
/// error but a failed [`Check`] (see [`YadeValidation::passed`]).
fn element_tests(
    p: &Problem,
    opts: &YadeValidationOptions,
    progress: Progress,
) -> Result<YadeValidation> {
    let s = prepare(p, opts)?;
    let (yade, ours) = std::thread::scope(|scope| {
        let yade = scope.spawn(|| run_yade(&s.run_script, &s.yade_dir, opts, s.dt, progress));
        let ours = our_runs(&s, opts, progress);
        let yade = yade.join().unwrap_or_else(|_| {
            Err(Error::Invalid(
                "validate yade: the thread running YADE panicked".into(),
            ))
        });
        (yade, ours)
    });
    let yade = yade?;
    let ours = ours?;
    let undamped = opts
        .undamped_paths
        .iter()
        .map(|&p| compare_histories(p, &yade.undamped, &ours.undamped))
        .collect::<Result<Vec<_>>>()?;
    let c_yade = tensor_from_columns(&yade.damped, "YADE damped history")?;
    let c_anisobond = tensor_from_columns(&ours.damped, "anisobond damped history")?;
    let checks = yade_checks(&undamped, &c_yade, &c_anisobond, &ours.relaxed.c, opts);
    let yade_version = yade.tensor.json["yade"]["version"]
        .as_str()
        .unwrap_or("unknown")
        .to_string();
    let timings = yade_timings(&yade, ours.seconds);
    Ok(Report {
        n_particles: s.packing.len(),
        n_bonds: s.bonds.len(),
        time_step: s.dt,
        checks,
        timings,
        details: YadeDetails {
            options: opts.clone(),
            critical_time_step: s.critical_time_step,
            yade_version,
            undamped_runs: HistoryPair {
                engine: yade.undamped,
                integrator: ours.undamped,
            },
            undamped,
            damped_runs: HistoryPair {
                engine: yade.damped,
                integrator: ours.damped,
            },
            tensors: DampedTensors {
                engine: c_yade,
                integrator: c_anisobond,
                relaxed: ours.relaxed.c,
                affine: ours.relaxed.c_affine,
            },
            yade_dir: s.yade_dir,
        },
    })
}

/// Both codes' common start: the packing, bonds and springs as YADE reads them back from
/// the export (bit for bit those given), the time step (anisobond's, imposed on YADE) and
/// the integrator's initial state.
struct Prepared {
    yade_dir: PathBuf,
    run_script: PathBuf,
    packing: Packing,
    bonds: BondSet,
    springs: BondStiffness,
    dt: f64,
    critical_time_step: f64,
    initial: Simulation,
}

/// Export the problem to `dir/yade/` (refused unless exportable and `yade` is on PATH),
/// read it back, check the round trip, and build the integrator's initial state from what
/// YADE reads.
fn prepare(p: &Problem, opts: &YadeValidationOptions) -> Result<Prepared> {
    let (dir, packing, bonds, springs) = (p.dir, p.packing, p.bonds, p.springs);
    export::check_yade_runnable(p.model)?;
    export::check_exportable(packing, bonds, springs)?;
    if export::find_yade().is_none() {
        return Err(Error::Invalid(
            "validate yade: `yade` is not on PATH (install YADE 2023.02a, e.g. apt install yade)"
                .into(),
        ));
    }
    // The time step is anisobond's, imposed on YADE.
    let dt = simulation(packing, bonds, springs, opts, opts.time_step)?.time_step();
    let yade_dir = dir.join(outputs::YADE_DIR);
    let exp = export::write_yade_export(
        &yade_dir,
        packing,
        bonds,
        springs,
        p.model,
        &run_options(opts, dt, false),
    )?;
    // anisobond runs what YADE reads.
    let p2 = packing::io::read_packing(&yade_dir.join(files::PACKING))?;
    let (b2, k2) = table::read_bond_table(&yade_dir.join(files::BONDS))?;
    check_round_trip(packing, bonds, springs, &p2, &b2, &k2)?;
    let initial = simulation(&p2, &b2, &k2, opts, Some(dt))?;
    let critical_time_step = initial.stability().critical_time_step;
    Ok(Prepared {
        yade_dir,
        run_script: exp.run_script,
        packing: p2,
        bonds: b2,
        springs: k2,
        dt,
        critical_time_step,
        initial,
    })
}

/// What anisobond's side measured, with the wall times of its three parts.
struct OurRuns {
    undamped: Vec<HistoryRow>,
    damped: Vec<HistoryRow>,
    relaxed: crate::homogenize::relaxed::RelaxedResult,
    /// Undamped, damped, relaxed (s).
    seconds: [f64; 3],
}

/// anisobond's side: the undamped and the six damped paths as YADE runs them, and the
/// relaxed solve with YADE's mid-gap contact point; a progress line after each.
fn our_runs(s: &Prepared, opts: &YadeValidationOptions, progress: Progress) -> Result<OurRuns> {
    let t = Instant::now();
    let mut undamped = Vec::new();
    for &p in &opts.undamped_paths {
        undamped.extend(run_path_like_yade(
            &s.initial,
            p,
            opts.strain,
            opts.undamped_steps,
            0.0,
        )?);
    }
    let t_undamped = t.elapsed().as_secs_f64();
    progress(&format!(
        "anisobond: undamped runs done in {t_undamped:.1} s"
    ));
    let t = Instant::now();
    let mut damped = Vec::new();
    for p in 0..6 {
        damped.extend(run_path_like_yade(
            &s.initial,
            p,
            opts.strain,
            opts.damped_steps,
            opts.damping,
        )?);
    }
    let t_damped = t.elapsed().as_secs_f64();
    progress(&format!(
        "anisobond: damped element tests done in {t_damped:.1} s"
    ));
    let t = Instant::now();
    let relaxed = relaxed_tensor(
        &s.packing,
        &s.bonds,
        &s.springs,
        &RelaxedOptions {
            lever_arm: LeverArm::MidGap,
            tolerance: opts.cg_tolerance,
            ..Default::default()
        },
    )?;
    let t_relaxed = t.elapsed().as_secs_f64();
    progress(&format!(
        "anisobond: relaxed solve done in {t_relaxed:.1} s ({} CG iterations)",
        relaxed.iterations
    ));
    Ok(OurRuns {
        undamped,
        damped,
        relaxed,
        seconds: [t_undamped, t_damped, t_relaxed],
    })
}

/// The checks: each undamped path's history, then the damped tensors pairwise (YADE,
/// the integrator, the relaxed solver).
fn yade_checks(
    undamped: &[HistoryComparison],
    c_yade: &Stiffness6,
    c_anisobond: &Stiffness6,
    c_relaxed: &Stiffness6,
    opts: &YadeValidationOptions,
) -> Vec<Check> {
    let tol = opts.tolerances;
    let mut checks: Vec<Check> = undamped
        .iter()
        .map(|h| {
            Check::new(
                format!("history-{}", h.label),
                format!(
                    "undamped stress history, path {} ({} steps): max |Δσ| / max |σ|",
                    h.label, opts.undamped_steps
                ),
                h.relative,
                tol.history,
            )
        })
        .collect();
    checks.push(Check::new(
        "tensor-yade-integrator",
        "damped tensor, YADE vs anisobond integrator",
        relative_difference(c_anisobond, c_yade),
        tol.tensor,
    ));
    checks.push(Check::new(
        "tensor-yade-relaxed",
        "damped tensor, YADE vs relaxed",
        relative_difference(c_yade, c_relaxed),
        tol.relaxed,
    ));
    checks.push(Check::new(
        "tensor-integrator-relaxed",
        "damped tensor, anisobond integrator vs relaxed",
        relative_difference(c_anisobond, c_relaxed),
        tol.relaxed,
    ));
    checks
}

/// The wall times: YADE's two processes and its own stepping time, anisobond's three parts.
fn yade_timings(yade: &YadeRuns, ours: [f64; 3]) -> Vec<Timing> {
    let stepping: f64 = yade.tensor.path_seconds.iter().map(|p| p.2).sum();
    [
        ("yade_undamped_process", yade.undamped_seconds),
        ("yade_damped_process", yade.damped_seconds),
        ("yade_damped_stepping", stepping),
        ("anisobond_undamped", ours[0]),
        ("anisobond_damped", ours[1]),
        ("relaxed", ours[2]),
    ]
    .map(|(stage, seconds)| Timing {
        stage: stage.into(),
        seconds,
    })
    .to_vec()
}

/// Write the side-by-side CSVs and the summary JSON into `dir` (atomically). Returns the
/// paths written.
pub fn write_validation_files(dir: &Path, v: &YadeValidation) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // Both regimes: CSV name, plot name, what, the CSV's title line, both codes' rows.
    let o = &v.options;
    let regimes = [
        (
            outputs::UNDAMPED_CSV,
            outputs::UNDAMPED_PNG,
            "undamped",
            "undamped (damping 0)".to_string(),
            &v.undamped_runs,
        ),
        (
            outputs::DAMPED_CSV,
            outputs::DAMPED_PNG,
            "damped",
            format!("damped (Cundall {})", o.damping),
            &v.damped_runs,
        ),
    ];
    let mut written = Vec::new();
    for (csv, _, _, regime, runs) in &regimes {
        let path = dir.join(csv);
        let title = format!(
            "{regime}, strain {:e} in one step, dt {:e} s, {} particles, {} bonds",
            o.strain, v.time_step, v.n_particles, v.n_bonds
        );
        let csv = side_by_side_csv(
            &title,
            ("yade", &runs.engine),
            ("anisobond", &runs.integrator),
        );
        crate::io::write_string_atomic(&path, &csv)?;
        written.push(path);
    }
    let summary = dir.join(outputs::SUMMARY_JSON);
    write_report_json(&summary, v)?;
    written.push(summary);
    for (_, png_name, what, _, runs) in &regimes {
        let series = history_series(("YADE", &runs.engine), ("anisobond", &runs.integrator));
        if !series.is_empty() {
            let png = dir.join(png_name);
            crate::plot::plot_series(
                &png,
                &series,
                &format!("{what} stress histories: YADE (lines) and anisobond (dots)"),
                "step",
                "stress in the loaded direction (MPa)",
            )?;
            written.push(png);
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensor::Voigt6;

    fn row(path: usize, step: usize, strain: f64, stress: [f64; 6]) -> HistoryRow {
        let mut e = Voigt6::zeros();
        e[path] = strain;
        HistoryRow {
            path,
            step,
            time: step as f64,
            strain: e,
            stress: Voigt6::from_row_slice(&stress),
        }
    }

    #[test]
    fn path_increments_are_yade_s() {
        let g = yade_path_increment(0, 2e-5);
        assert_eq!(g[(0, 0)], 2e-5);
        assert_eq!(g.abs().sum(), 2e-5);
        let g = yade_path_increment(4, 2e-5); // 13
        assert_eq!((g[(0, 2)], g[(2, 0)]), (1e-5, 1e-5));
        assert_eq!(to_voigt(&g, true)[4], 2e-5);
        assert_eq!(g.abs().sum(), 2e-5);
    }

    #[test]
    fn columns_give_a_known_tensor() {
        // Isotropic-like C with λ = 1, μ = 2 (Pa): columns are C·e_p·ε.
        let mut c = Stiffness6::zeros();
        for a in 0..3 {
            for b in 0..3 {
                c[(a, b)] = if a == b { 5.0 } else { 1.0 };
            }
            c[(a + 3, a + 3)] = 2.0;
        }
        let eps = 1e-5;
        let mut rows = Vec::new();
        for p in 0..6 {
            rows.push(row(p, 0, 0.0, [0.0; 6]));
            let s: Vec<f64> = (0..6).map(|a| c[(a, p)] * eps).collect();
            rows.push(row(p, 7, eps, s.try_into().unwrap()));
        }
        let got = tensor_from_columns(&rows, "test").unwrap();
        assert!(relative_difference(&got, &c) < 1e-12, "{got}");
        rows.retain(|r| r.path != 3);
        assert!(tensor_from_columns(&rows, "test")
            .unwrap_err()
            .to_string()
            .contains("path 23"));
    }

    #[test]
    fn history_difference_is_relative_to_the_largest_stress() {
        let y = vec![
            row(0, 0, 0.0, [0.0; 6]),
            row(0, 1, 1.0, [100.0, -400.0, 0.0, 0.0, 0.0, 0.0]),
        ];
        let a = vec![
            row(0, 0, 0.0, [0.0; 6]),
            row(0, 1, 1.0, [100.0, -398.0, 0.0, 0.0, 0.0, 1.0]),
        ];
        let h = compare_histories(0, &y, &a).unwrap();
        assert_eq!(h.max_stress, 400.0);
        assert_eq!(h.max_difference, 2.0);
        assert_eq!(h.relative, 2.0 / 400.0);
        assert_eq!(h.worst_step, 1);
        assert!(compare_histories(0, &y, &a[..1]).is_err());
        assert!(compare_histories(3, &y, &a).is_err());
    }

    #[test]
    fn options_are_validated() {
        assert!(YadeValidationOptions::default().validate().is_ok());
        for o in [
            YadeValidationOptions {
                damping: 0.0,
                ..Default::default()
            },
            YadeValidationOptions {
                undamped_steps: 1,
                ..Default::default()
            },
            YadeValidationOptions {
                undamped_paths: vec![7],
                ..Default::default()
            },
            YadeValidationOptions {
                tolerances: Tolerances {
                    history: f64::NAN,
                    ..YadeValidationOptions::default().tolerances
                },
                ..Default::default()
            },
            YadeValidationOptions {
                cg_tolerance: 0.0,
                ..Default::default()
            },
        ] {
            assert!(o.validate().is_err(), "{o:?} accepted");
        }
    }
}
