//! The specimen test every engine runs (issue 31 item 5): the finite bonded specimen of a
//! free packing, built by the engine from the packing and the bond table, its bottom end
//! layer held and its top one moved along the axis by the engine's own means, relaxed
//! quasi-statically to equilibrium; the engine's platen stiffness F/δ against the specimen
//! solve's ([`crate::specimen::solve`]) with the engine's contact-point convention.
//!
//! An engine gives its deck in [`super::Engine::decks`]: the deck runs its code and
//! returns an [`EngineMeasurement`]; [`compare`] makes the [`Report`] with the one check
//! `platen-stiffness` (|k_engine − k_solve| / k_solve, default tolerance 1e-3).

pub use super::harness::Launch;
use super::harness::{Check, EngineDetails, Report, SharedDetails, Timing};
use crate::assembly::Assembly;
use crate::homogenize::network::LeverArm;
use crate::specimen::{self, Platens, SpecimenOptions, SpecimenReport};
use crate::{Error, Result};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

pub mod lammps;
pub mod liggghts;
pub mod yade;

/// Files a specimen validation writes into its directory.
pub mod outputs {
    /// The report: settings, prediction, measurement, check, timings.
    pub const REPORT_JSON: &str = "specimen-validation.json";
    /// The check as CSV.
    pub const CHECKS_CSV: &str = "checks.csv";
}

/// The numbers every deck-driven engine's deck takes from the solve.
pub(super) struct DeckPlan {
    /// Shortening δ = strain × the gauge length (between the layers' mean centres), as the
    /// solve (m).
    pub delta: f64,
    /// Time step (s), [`Launch::step`].
    pub dt: f64,
    /// Damping rate √(K/M)/4 (1/s) of the specimen's slow modes, K the solve's platen
    /// stiffness, M the specimen's mass ([`specimen_mass`]); it changes the way to rest,
    /// not the rest state.
    pub damping_rate: f64,
}

/// A specimen test driven by an input deck (LAMMPS, LIGGGHTS): the engine's names, strain,
/// contact point, directory and deck file, how it writes the deck and how it runs the deck
/// once. [`ScriptDeck::run`] does the rest the same way for both.
pub(super) struct ScriptDeck {
    /// The engine's name in reports, stage names and errors (`lammps`).
    pub engine: &'static str,
    /// Its name in progress lines (`LAMMPS`).
    pub shown: &'static str,
    /// The default strain of its test.
    pub strain: f64,
    /// The contact point of its bonds, which the solve takes.
    pub lever_arm: LeverArm,
    /// Sub-directory of the validation directory the engine runs in.
    pub dir: &'static str,
    /// The deck's file name in that directory.
    pub deck_file: &'static str,
    /// Write the deck's data files into the start's directory; returns the deck.
    pub write: fn(&DeckStart, &Launch, &DeckPlan) -> Result<String>,
    /// Run the written deck once on `np` processes and read what it measured.
    pub run_once: fn(&DeckStart, &Launch, &DeckPlan, usize) -> Result<EngineMeasurement>,
}

impl ScriptDeck {
    /// The test of `problem`'s free specimen: [`deck_start`], the deck written with its
    /// [`DeckPlan`], one run per process count of `launch` (each timed as `ENGINE_npN` and
    /// reported in `progress`), compared with the solve.
    pub(super) fn run(
        &self,
        launch: &Launch,
        problem: &super::Problem,
        test: &SpecimenTest,
        progress: super::engine::Progress,
    ) -> Result<Report<SpecimenDetails>> {
        let mut start = deck_start(
            self.engine,
            problem,
            test,
            self.strain,
            self.lever_arm,
            self.dir,
            progress,
        )?;
        let (asm, predicted) = (&start.asm, &start.predicted);
        let mass = specimen_mass(&asm.packing, launch.density);
        let plan = DeckPlan {
            delta: start.test.strain() * predicted.length,
            dt: launch.step(&asm.packing, &asm.bonds, &asm.springs)?,
            damping_rate: (predicted.platen_stiffness / mass).sqrt() / 4.0,
        };
        let deck = (self.write)(&start, launch, &plan)?;
        crate::io::write_string_atomic(&start.dir.join(self.deck_file), &deck)?;
        let mut measured = Vec::new();
        for &np in &launch.processes {
            let m = (self.run_once)(&start, launch, &plan, np)?;
            start.timings.push(Timing {
                stage: format!("{}_np{np}", self.engine),
                seconds: m.seconds,
            });
            progress(&run_done_line(self.shown, &m));
            measured.push(m);
        }
        let DeckStart {
            test,
            asm,
            predicted,
            timings,
            ..
        } = start;
        compare(
            self.engine,
            &test,
            self.lever_arm,
            &asm,
            predicted,
            measured,
            timings,
        )
    }
}

/// What the specimen test is asked for (the load test of `anisobond specimen`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpecimenTest {
    /// Loading axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Depth of each end layer (m): centres within it of the lowest / highest centre.
    pub end_layer: f64,
    /// How the platens hold the layers.
    pub platens: Platens,
    /// Axial compressive strain the engine applies (small: the response is linear); `None`:
    /// the engine's own default (YADE 1e-6; LAMMPS 1e-5, where bpm/rotational's angles from
    /// acos lose √ε of precision and 1e-6 measured 4.6e-4 off).
    pub strain: Option<f64>,
    /// Largest admissible |k_engine − k_solve| / k_solve.
    pub tolerance: f64,
    /// The engine's run is settled when its force's estimated remaining relative change
    /// is below this (and both layers carry the same force to it).
    pub settle: f64,
    /// Most steps the engine relaxes before giving up (the check is then not judged).
    pub max_steps: u64,
}

impl SpecimenTest {
    /// Along `axis` with end layers `end_layer` (m) deep held by `platens`: the engine's
    /// strain, tolerance 1e-3, settled at 1e-6, at most 400,000 steps.
    pub fn new(axis: usize, end_layer: f64, platens: Platens) -> SpecimenTest {
        SpecimenTest {
            axis,
            end_layer,
            platens,
            strain: None,
            tolerance: 1e-3,
            settle: 1e-6,
            max_steps: 400_000,
        }
    }

    /// Refuse values no run can satisfy, naming the option.
    pub fn check(&self, engine: &str) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("validate {engine} --specimen: {m}")));
        if self.axis > 2 {
            return bad(format!("axis {} is not x, y or z", self.axis));
        }
        if !(self.end_layer.is_finite() && self.end_layer >= 0.0) {
            return bad(format!(
                "--end-layer must be a finite depth ≥ 0 m, got {}",
                self.end_layer
            ));
        }
        if let Some(e) = self.strain {
            if !(e.is_finite() && e > 0.0 && e < 1e-2) {
                return bad(format!(
                    "the strain must be in (0, 0.01) (a small strain: the solve is linear), got {e}"
                ));
            }
        }
        for (name, v) in [("tolerance", self.tolerance), ("settle", self.settle)] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return bad(format!("the {name} must be in (0, 1), got {v}"));
            }
        }
        if self.max_steps < 1000 {
            return bad(format!(
                "at least 1000 relaxation steps are needed, got {}",
                self.max_steps
            ));
        }
        Ok(())
    }

    /// The test with the engine's `default` strain when none is given.
    pub fn resolved(&self, default: f64) -> SpecimenTest {
        SpecimenTest {
            strain: Some(self.strain.unwrap_or(default)),
            ..*self
        }
    }

    /// The strain (NaN when not resolved).
    pub fn strain(&self) -> f64 {
        self.strain.unwrap_or(f64::NAN)
    }

    /// The specimen solve's options with the engine's contact point.
    pub fn solve_options(&self, lever_arm: LeverArm) -> SpecimenOptions {
        let mut o = SpecimenOptions::new(self.axis, self.end_layer);
        o.platens = self.platens;
        o.load = specimen::Load::Strain(self.strain());
        o.lever_arm = lever_arm;
        o
    }
}

/// What the engine measured once its specimen had settled.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EngineMeasurement {
    /// The engine's version string.
    pub version: String,
    /// MPI processes of the run (1 for YADE).
    pub processes: usize,
    /// Particles (indices into the packing) the engine held as the bottom layer, ascending.
    pub bottom: Vec<usize>,
    /// Particles it moved as the top layer, ascending.
    pub top: Vec<usize>,
    /// Shortening δ it applied (m).
    #[serde(rename = "displacement_m")]
    pub displacement: f64,
    /// Axial force on the moved layer (N, compression positive).
    #[serde(rename = "force_top_N")]
    pub force_top: f64,
    /// Axial force on the held layer (N, compression positive).
    #[serde(rename = "force_bottom_N")]
    pub force_bottom: f64,
    /// Time step (s).
    #[serde(rename = "time_step_s")]
    pub time_step: f64,
    /// Steps run (loading and relaxation).
    pub steps: u64,
    /// Estimated remaining relative change of the force when it stopped (infinite: no
    /// estimate).
    #[serde(serialize_with = "finite_or_null")]
    pub remaining: f64,
    /// How it loaded and relaxed, in words.
    pub how: String,
    /// Wall time of the engine's process (s).
    #[serde(rename = "wall_s")]
    pub seconds: f64,
    /// Where the engine ran (its deck or script, its outputs).
    #[serde(skip)]
    pub dir: PathBuf,
}

fn finite_or_null<S: serde::Serializer>(v: &f64, s: S) -> std::result::Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else {
        s.serialize_none()
    }
}

impl EngineMeasurement {
    /// Platen stiffness F/δ (N/m) of the moved layer.
    pub fn stiffness(&self) -> f64 {
        self.force_top / self.displacement
    }
}

/// The specimen validation's own results inside the [`Report`].
#[derive(Clone, Debug)]
pub struct SpecimenDetails {
    /// The engine (`yade`, `lammps`, `liggghts`).
    pub engine: &'static str,
    /// The test run.
    pub test: SpecimenTest,
    /// The contact point of the engine's bond law, used by the solve.
    pub lever_arm: LeverArm,
    /// The specimen solve.
    pub predicted: SpecimenReport,
    /// What the engine measured: one run per number of MPI processes, the first on one.
    pub measured: Vec<EngineMeasurement>,
}

/// The specimen part of the report JSON.
#[derive(Serialize)]
pub struct SpecimenJson<'a> {
    engine: &'static str,
    test: &'a SpecimenTest,
    lever_arm: LeverArm,
    #[serde(rename = "platen_stiffness_engine_N_per_m")]
    engine_stiffness: f64,
    #[serde(rename = "platen_stiffness_solve_N_per_m")]
    solve_stiffness: f64,
    measured: &'a [EngineMeasurement],
    predicted: &'a SpecimenReport,
}

/// The summary ([`super::checks_summary`]): the engine's and the solve's lines, the checks
/// table, wall times; the files: [`outputs`].
impl SharedDetails for SpecimenDetails {
    const CHECKS_HEADING: &'static str = "relative differences (dimensionless):";
    const REPORT_JSON: &'static str = outputs::REPORT_JSON;
    const CHECKS_CSV: &'static str = outputs::CHECKS_CSV;
}

impl EngineDetails for SpecimenDetails {
    type Json<'a> = SpecimenJson<'a>;
    const ENGINE: &'static str = "specimen";
    fn json(&self) -> SpecimenJson<'_> {
        SpecimenJson {
            engine: self.engine,
            test: &self.test,
            lever_arm: self.lever_arm,
            engine_stiffness: self.measured[0].stiffness(),
            solve_stiffness: self.predicted.platen_stiffness,
            measured: &self.measured,
            predicted: &self.predicted,
        }
    }
    fn tensors(&self) -> Vec<(String, crate::tensor::Stiffness6)> {
        Vec::new()
    }
    fn summary(r: &Report<Self>) -> String {
        let (m, p) = (&r.measured[0], &r.predicted);
        let mut s = format!(
            "{} {} vs the specimen solve: {} particles, {} bonds; {} platens along {}, end \
             layers {:e} m deep ({} held, {} moved), strain {:e}\n",
            r.engine,
            m.version,
            r.n_particles,
            r.n_bonds,
            platens_name(r.test.platens),
            p.axis,
            r.test.end_layer,
            m.bottom.len(),
            m.top.len(),
            r.test.strain()
        );
        let _ = writeln!(s, "  {}", m.how);
        let _ = writeln!(
            s,
            "  specimen solve: platen stiffness {:.7e} N/m ({} contact point)",
            p.platen_stiffness,
            lever_name(r.lever_arm)
        );
        for m in &r.measured {
            let _ = writeln!(
                s,
                "  {} on {} process(es): {:.7e} N/m after {} steps (remaining relative change \
                 {:.2e}; forces top {:.6e} N, bottom {:.6e} N; {:.1} s)",
                r.engine,
                m.processes,
                m.stiffness(),
                m.steps,
                m.remaining,
                m.force_top,
                m.force_bottom,
                m.seconds
            );
        }
        s.push('\n');
        s
    }
}

/// The name of `p` as the command line and the engines' scripts spell it.
pub(super) fn platens_name(p: Platens) -> &'static str {
    match p {
        Platens::Frictionless => "frictionless",
        Platens::Bonded => "bonded",
    }
}

fn lever_name(l: LeverArm) -> &'static str {
    match l {
        LeverArm::MidGap => "mid-gap",
        LeverArm::Proportional => "proportional",
        LeverArm::HalfLength => "half-length",
    }
}

/// The problem's bonded packing as an assembly for the solve, refused unless it is a free
/// cluster (a specimen has no periodic cell).
pub fn free_assembly(problem: &super::Problem, engine: &str) -> Result<Assembly> {
    if problem.packing.cell.is_some() {
        return Err(Error::Invalid(format!(
            "validate {engine} --specimen: the packing is periodic; the specimen test runs a \
             free cluster (read it with --free, or a file with a `# free` line)"
        )));
    }
    Ok(Assembly::of_parts(
        problem.packing.clone(),
        problem.model.cloned().ok_or_else(|| {
            Error::Invalid(format!(
                "validate {engine} --specimen: the problem has no model (the report records it)"
            ))
        })?,
        problem.bonds.clone(),
        problem.springs.clone(),
    ))
}

/// The specimen solve of `asm` for `test` with `lever_arm`, timed into `timings`.
pub fn predict(
    asm: &Assembly,
    test: &SpecimenTest,
    lever_arm: LeverArm,
    timings: &mut Vec<Timing>,
) -> Result<SpecimenReport> {
    super::harness::timed(timings, "specimen_solve", || {
        specimen::solve(asm, &test.solve_options(lever_arm))
    })
}

/// The end layers of the solve as ascending index lists (bottom, top).
pub fn layers(p: &SpecimenReport) -> (Vec<usize>, Vec<usize>) {
    let of = |w: u8| (0..p.layer.len()).filter(|&k| p.layer[k] == w).collect();
    (of(1), of(2))
}

/// The specimen solve of `asm` for `test` (timed into `timings`) and its progress line:
/// the platen stiffness every engine's is compared with.
pub(super) fn predict_reported(
    asm: &Assembly,
    test: &SpecimenTest,
    lever_arm: LeverArm,
    timings: &mut Vec<Timing>,
    progress: super::engine::Progress,
) -> Result<SpecimenReport> {
    let predicted = predict(asm, test, lever_arm, timings)?;
    progress(&format!(
        "anisobond: specimen solve done: platen stiffness {:.7e} N/m",
        predicted.platen_stiffness
    ));
    Ok(predicted)
}

/// What the specimen test of an engine driven by a deck (LAMMPS, LIGGGHTS) starts from.
pub(super) struct DeckStart {
    /// The test with the engine's strain.
    pub test: SpecimenTest,
    /// The free bonded specimen.
    pub asm: Assembly,
    /// The specimen solve.
    pub predicted: SpecimenReport,
    /// Its end layers (bottom, top), which the engine must hold and move.
    pub layers: (Vec<usize>, Vec<usize>),
    /// Each atom's type and the held lateral axis of the far support ([`lammps::atom_types`]).
    pub types: (Vec<u8>, usize),
    /// The engine's directory (created).
    pub dir: PathBuf,
    /// Wall times so far (the solve).
    pub timings: Vec<Timing>,
}

/// The common start of a deck-driven engine's specimen test: `test` with the engine's
/// `strain`, the free assembly (refused without bonds), the solve with the engine's
/// `lever_arm`, the layers' atom types, and the directory `sub` of the problem's.
pub(super) fn deck_start(
    engine: &str,
    problem: &super::Problem,
    test: &SpecimenTest,
    strain: f64,
    lever_arm: LeverArm,
    sub: &str,
    progress: super::engine::Progress,
) -> Result<DeckStart> {
    let test = test.resolved(strain);
    let asm = free_assembly(problem, engine)?;
    if asm.bonds.is_empty() {
        return Err(Error::Invalid(format!(
            "validate {engine} --specimen: no bonds"
        )));
    }
    let mut timings = Vec::new();
    let predicted = predict_reported(&asm, &test, lever_arm, &mut timings, progress)?;
    let layers = layers(&predicted);
    let types = lammps::atom_types(&asm.packing, &predicted, test.axis);
    let dir = problem.dir.join(sub);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    Ok(DeckStart {
        test,
        asm,
        predicted,
        layers,
        types,
        dir,
        timings,
    })
}

/// Mass (kg) of a sphere of radius `r` (m) and `density` (kg/m³), as every engine takes it.
pub(super) fn sphere_mass(density: f64, r: f64) -> f64 {
    density * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
}

/// Mass (kg) of the specimen's spheres at `density` (kg/m³): M of the slow modes' damping
/// rate √(K/M)/4 of the LAMMPS and LIGGGHTS tests.
pub(super) fn specimen_mass(packing: &crate::packing::Packing, density: f64) -> f64 {
    packing.radii.iter().map(|&r| sphere_mass(density, r)).sum()
}

/// The estimated remaining relative change of a force read three times `f1`, `f2`, `f3`
/// at equal intervals: the geometric extrapolation |d₂| / (1 − |d₂/d₁|) / |f₃| of the
/// last two changes; infinite (no estimate) when they are not decaying. The decks stop on
/// the same rule ([`relax_in_chunks`]).
pub(super) fn remaining_change(f1: f64, f2: f64, f3: f64) -> f64 {
    let (d1, d2) = (f2 - f1, f3 - f2);
    let ratio = if d1 != 0.0 { (d2 / d1).abs() } else { 0.0 };
    if ratio < 1.0 {
        d2.abs() / (1.0 - ratio) / f3.abs()
    } else {
        f64::INFINITY
    }
}

/// The relaxation loop of the LAMMPS and LIGGGHTS decks, appended to `s`: two readings of
/// the platen force `ft` a chunk apart, then chunks of `${chunk_steps}` (at most
/// `${max_chunks}`) until the estimated remaining relative change ([`remaining_change`],
/// multiplied out) and |F_top − F_bottom| / F_top are below `${settle}`; ends at `label
/// settled` with the last readings in `f1 f2 f3 b3`. `ft` and `fb` are how the deck
/// reads the top and (sign-corrected) bottom force now (LAMMPS `$(v_ft:%.17g)`, LIGGGHTS
/// `${ft}`).
pub(super) fn relax_in_chunks(s: &mut String, ft: &str, fb: &str) {
    let _ = write!(
        s,
        "thermo_style custom step v_ft v_fb\nthermo ${{chunk_steps}}\n\
         run ${{chunk_steps}}\nvariable f1 equal {ft}\n\
         run ${{chunk_steps}}\nvariable f2 equal {ft}\n\
         variable chunk loop ${{max_chunks}}\n\
         label relax\n\
         run ${{chunk_steps}}\n\
         variable f3 equal {ft}\nvariable b3 equal {fb}\n\
         variable done equal \"abs(v_f3-v_f2)*abs(v_f2-v_f1) <= v_settle*abs(v_f3)*(abs(v_f2-v_f1)-abs(v_f3-v_f2)) && abs(v_f3-v_b3) <= v_settle*abs(v_f3)\"\n\
         if \"${{done}} == 1\" then \"jump SELF settled\"\n\
         variable f1 equal ${{f2}}\nvariable f2 equal ${{f3}}\n\
         next chunk\njump SELF relax\n\
         label settled\n"
    );
}

/// The progress line of a finished run of `engine` (its name as it prints it).
pub(super) fn run_done_line(engine: &str, m: &EngineMeasurement) -> String {
    format!(
        "{engine} on {} process(es): done in {:.1} s ({} steps): platen stiffness {:.7e} N/m",
        m.processes,
        m.seconds,
        m.steps,
        m.stiffness()
    )
}

impl SpecimenTest {
    /// Chunks of `chunk_steps` the relaxation loop may run after its first two readings,
    /// so that all of them stay within [`SpecimenTest::max_steps`] (at least one).
    pub(super) fn relax_chunks(&self, chunk_steps: u64) -> u64 {
        self.max_steps.div_ceil(chunk_steps).max(3) - 2
    }
}

/// The report: each run's stiffness against the solve's (one check per run:
/// `platen-stiffness`, `platen-stiffness-np2`, …), after making sure there is a run and
/// every run held and moved the solve's layers (else [`Error::EngineFailed`]: nothing was
/// measured, or they did not load the same specimen).
pub fn compare(
    engine: &'static str,
    test: &SpecimenTest,
    lever_arm: LeverArm,
    asm: &Assembly,
    predicted: SpecimenReport,
    measured: Vec<EngineMeasurement>,
    timings: Vec<Timing>,
) -> Result<Report<SpecimenDetails>> {
    if measured.is_empty() {
        return Err(Error::engine(
            engine,
            "no run measured the platen force: the engine returned no measurement to compare \
             with the specimen solve",
        ));
    }
    let (bottom, top) = layers(&predicted);
    let mut checks = Vec::new();
    for m in &measured {
        if bottom != m.bottom || top != m.top {
            return Err(Error::engine(
                engine,
                format!(
                    "the engine's end layers ({} held, {} moved) are not the specimen solve's \
                     ({} and {}): the two did not load the same specimen",
                    m.bottom.len(),
                    m.top.len(),
                    bottom.len(),
                    top.len()
                ),
            ));
        }
        let rel = ((m.stiffness() - predicted.platen_stiffness) / predicted.platen_stiffness).abs();
        let suffix = if m.processes == 1 {
            String::new()
        } else {
            format!("-np{}", m.processes)
        };
        checks.push(Check::unless_unsettled(
            format!("platen-stiffness{suffix}"),
            format!(
                "platen stiffness F/δ, {engine} on {} process(es) vs the specimen solve ({} \
                 contact point)",
                m.processes,
                lever_name(lever_arm)
            ),
            if rel.is_finite() { rel } else { f64::NAN },
            test.tolerance,
            m.remaining,
        ));
        checks.push(Check::info(
            format!("force-balance{suffix}"),
            format!("|F_top − F_bottom| / F_top in {engine}"),
            ((m.force_top - m.force_bottom) / m.force_top).abs(),
        ));
    }
    let time_step = measured.first().map_or(f64::NAN, |m| m.time_step);
    Ok(Report {
        n_particles: asm.packing.len(),
        n_bonds: asm.bonds.len(),
        time_step,
        checks,
        timings,
        details: SpecimenDetails {
            engine,
            test: *test,
            lever_arm,
            predicted,
            measured,
        },
    })
}

/// A number as the LAMMPS and LIGGGHTS specimen decks write it (shortest round-trip, `e`).
pub(super) fn num(x: f64) -> String {
    format!("{x:e}")
}

/// The box lines `lo hi xlo xhi`, … of a data file for a free specimen: the spheres'
/// bounding box widened by `margin` (m) on every side.
pub(super) fn box_lines(packing: &crate::packing::Packing, margin: f64) -> String {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (x, r) in packing.positions.iter().zip(&packing.radii) {
        for a in 0..3 {
            lo[a] = lo[a].min(x[a] - r);
            hi[a] = hi[a].max(x[a] + r);
        }
    }
    let mut s = String::new();
    for (a, name) in ["x", "y", "z"].iter().enumerate() {
        let _ = writeln!(
            s,
            "{} {} {name}lo {name}hi",
            num(lo[a] - margin),
            num(hi[a] + margin)
        );
    }
    s
}

/// The atom lines `id [mol] type diameter density x y z` (ids from 1; `molecule` writes the
/// molecule id 1 of LAMMPS' `bpm/sphere` style), `types[p]` each atom's type.
pub(super) fn atom_lines(
    packing: &crate::packing::Packing,
    types: &[u8],
    density: f64,
    molecule: bool,
) -> String {
    let mut s = String::new();
    for (p, (x, r)) in packing.positions.iter().zip(&packing.radii).enumerate() {
        let _ = writeln!(
            s,
            "{}{} {} {} {} {} {} {}",
            p + 1,
            if molecule { " 1" } else { "" },
            types[p],
            num(2.0 * r),
            num(density),
            num(x.x),
            num(x.y),
            num(x.z)
        );
    }
    s
}

/// The `Bonds` section's lines of a data file with one bond type per bond: bond b (from 0)
/// is `b+1 b+1 i+1 j+1` (bond id, its own type, atom ids from 1).
pub fn bond_lines_one_type_each(bonds: &crate::bonds::BondSet) -> String {
    let mut s = String::new();
    for b in 0..bonds.len() {
        let _ = writeln!(
            s,
            "{} {} {} {}",
            b + 1,
            b + 1,
            bonds.i[b] + 1,
            bonds.j[b] + 1
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::Packing;
    use crate::Vec3;

    /// A 3 × 3 × 9 simple-cubic column of touching spheres, k_n = 2e6 N/m, k_s = 7e5 N/m:
    /// platen stiffness 9 k_n / 8 = 2.25e6 N/m (closed form, any platens).
    fn column() -> Assembly {
        let r = 1e-3;
        let mut pos = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..9 {
                    pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * r);
                }
            }
        }
        let n = pos.len();
        let model = crate::model::Model::from_toml_str(
            "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
             normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n",
            "<test>",
        )
        .unwrap();
        Assembly::new(Packing::new(pos, vec![r; n], None).unwrap(), model).unwrap()
    }

    fn measured(p: &SpecimenReport, force: f64, remaining: f64) -> EngineMeasurement {
        let (bottom, top) = layers(p);
        EngineMeasurement {
            version: "test".into(),
            processes: 1,
            bottom,
            top,
            displacement: 1e-9,
            force_top: force,
            force_bottom: force,
            time_step: 1e-7,
            steps: 1000,
            remaining,
            how: String::new(),
            seconds: 0.0,
            dir: PathBuf::new(),
        }
    }

    #[test]
    fn the_engine_stiffness_is_checked_against_the_solve() {
        let asm = column();
        let test = SpecimenTest::new(2, 0.5e-3, Platens::Bonded).resolved(1e-6);
        let mut t = Vec::new();
        let p = predict(&asm, &test, LeverArm::MidGap, &mut t).unwrap();
        assert!((p.platen_stiffness / 2.25e6 - 1.0).abs() < 1e-10);
        let run = |force: f64, remaining: f64| {
            compare(
                "yade",
                &test,
                LeverArm::MidGap,
                &asm,
                p.clone(),
                vec![measured(&p, force, remaining)],
                Vec::new(),
            )
            .unwrap()
        };
        // 2.25e6 N/m × 1e-9 m = 2.25e-3 N: passes; 0.2 % more fails; unsettled is not judged.
        assert!(run(2.25e-3, 1e-8).passed());
        let off = run(2.2545e-3, 1e-8);
        assert!(!off.passed() && (off.checks[0].value - 2e-3).abs() < 1e-9);
        let unsettled = run(2.2545e-3, 1e-2);
        assert!(unsettled.passed() && unsettled.checks[0].not_converged == Some(1e-2));
        // Other end layers: not the same specimen.
        let mut m = measured(&p, 2.25e-3, 1e-8);
        m.top.pop();
        let e = compare(
            "yade",
            &test,
            LeverArm::MidGap,
            &asm,
            p,
            vec![m],
            Vec::new(),
        )
        .unwrap_err();
        assert!(matches!(e, Error::EngineFailed { .. }), "{e}");
    }

    #[test]
    fn a_run_that_measured_nothing_is_an_engine_failure_not_a_pass() {
        let asm = column();
        let test = SpecimenTest::new(2, 0.5e-3, Platens::Bonded).resolved(1e-6);
        let p = predict(&asm, &test, LeverArm::MidGap, &mut Vec::new()).unwrap();
        let e = compare(
            "lammps",
            &test,
            LeverArm::MidGap,
            &asm,
            p,
            Vec::new(),
            Vec::new(),
        )
        .unwrap_err();
        assert!(
            matches!(&e, Error::EngineFailed { engine, .. } if engine == "lammps"),
            "{e}"
        );
        assert!(e.to_string().contains("no run measured"), "{e}");
    }

    #[test]
    fn the_remaining_change_is_the_geometric_extrapolation() {
        // Changes 8, 4 (ratio 1/2): 4 + 2 + 1 + … = 4 / (1 − 1/2) = 8 remaining, of 112.
        assert_eq!(remaining_change(100.0, 108.0, 112.0), 8.0 / 112.0);
        // Not decaying (ratio ≥ 1): no estimate.
        assert_eq!(remaining_change(100.0, 104.0, 112.0), f64::INFINITY);
        // Constant: nothing remains.
        assert_eq!(remaining_change(5.0, 5.0, 5.0), 0.0);
    }

    #[test]
    fn bad_tests_and_periodic_packings_are_refused() {
        let ok = SpecimenTest::new(2, 1e-3, Platens::Frictionless);
        assert!(ok.check("yade").is_ok());
        for bad in [
            SpecimenTest { axis: 3, ..ok },
            SpecimenTest {
                end_layer: f64::NAN,
                ..ok
            },
            SpecimenTest {
                strain: Some(0.0),
                ..ok
            },
            SpecimenTest {
                tolerance: 0.0,
                ..ok
            },
            SpecimenTest { settle: 1.0, ..ok },
            SpecimenTest {
                max_steps: 10,
                ..ok
            },
        ] {
            assert!(
                matches!(bad.check("yade"), Err(Error::Invalid(_))),
                "{bad:?}"
            );
        }
        let mut asm = column();
        asm.packing = Packing::new(
            asm.packing.positions.clone(),
            asm.packing.radii.clone(),
            Some(crate::packing::PeriodicCell::new(Vec3::new(6e-3, 6e-3, 1.8e-2)).unwrap()),
        )
        .unwrap();
        let dir = std::env::temp_dir();
        let e = free_assembly(&super::super::Problem::of(&dir, &asm), "yade").unwrap_err();
        assert!(e.to_string().contains("--free"), "{e}");
    }
}
