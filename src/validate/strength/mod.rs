//! The strength test every engine runs (issue 32 item 5): quasi-static direct tension or
//! uniaxial compression ([`StrengthLoading`]) of a free bonded bar between held end layers —
//! the bottom layer held still, the top one moved along the axis at a constant velocity
//! (up in tension, down in compression), the free spheres started in the steady linear
//! velocity field (no wave at the start) —, the bonds breaking by the engine's own
//! criterion; the same motion in the reference integrator ([`crate::dem`]) with the same
//! bond law and the same per-bond limits. When the engine turns a broken bond into a
//! frictional contact, the integrator does too ([`Loading::contacts`]).
//!
//! The peak: in tension the largest tensile force of the run; in compression the first peak
//! ([`first_peak`]: the largest compressive force before the force first falls by
//! [`StrengthTest::peak_drop`] after bonds broke), so that broken pairs locking up as
//! contacts after the failure (re-hardening) do not count.
//!
//! An engine gives its strength deck in [`super::Engine::decks`]: it runs its code and returns a
//! [`StrengthRun`] per process count; [`reference()`] runs the integrator; [`compare`] makes
//! the [`Report`] with, per run, `peak-stress` (|σ_engine − σ_integrator| / σ_integrator,
//! default tolerance 2 %) and `first-breaks` (how many of the first ten broken bonds, in
//! breaking order, differ; 0 passes).

use super::harness::{Check, EngineDetails, Progress, Report, SharedDetails, Timing};
use crate::bonds::BondSet;
use crate::dem::{
    BondCriteria, BondLaw, ContactLaw, Contacts, DemOptions, PrescribedMotion, Simulation,
};
use crate::packing::Packing;
use crate::strength::BondStrengths;
use crate::{Error, Result, Vec3};
use serde::Serialize;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

pub mod lammps;
pub mod liggghts;
pub mod yade;

pub use super::harness::Launch;

/// What every engine's strength test starts from: `problem`'s model, its bonds' strengths
/// (`[strength]`, docs/strength.md) and the integrator's criteria for `law`. Refuses a problem
/// without a model, a model without a `[strength]` table and a bar without bonds, naming
/// `validate ENGINE --strength`.
pub fn strength_setup<'a>(
    engine: &str,
    problem: &super::Problem<'a>,
    law: crate::dem::LawKind,
) -> Result<(&'a crate::model::Model, BondStrengths, BondCriteria)> {
    let model = problem.model.ok_or_else(|| {
        Error::Invalid(format!(
            "validate {engine} --strength: the problem has no model"
        ))
    })?;
    let table = model.strength.as_ref().ok_or_else(|| {
        Error::Invalid(format!(
            "validate {engine} --strength: the model has no [strength] table (the bonds' \
             strengths; docs/strength.md)"
        ))
    })?;
    if problem.bonds.is_empty() {
        return Err(Error::Invalid(format!(
            "validate {engine} --strength: no bonds"
        )));
    }
    let spec = crate::strength::StrengthSpec::from_table(table)?;
    spec.refuse_cut_sections(&format!("validate {engine} --strength"))?;
    let (p, b, g) = (problem.packing, problem.bonds, model.grains.as_ref());
    let strengths = crate::grains::assign_strength_by_grain(p, b, &spec, g, None)?;
    let criteria = BondCriteria::for_law(
        law,
        &strengths,
        problem.packing,
        problem.bonds,
        &model.geometry,
    )?;
    Ok((model, strengths, criteria))
}

/// What every engine's strength run starts from ([`Start::of`]).
pub struct Start<'a> {
    /// The problem's model.
    pub model: &'a crate::model::Model,
    /// Its bonds' strengths ([`strength_setup`]).
    pub strengths: BondStrengths,
    /// The integrator's criteria for the engine's law.
    pub criteria: BondCriteria,
    /// The loading at the test's time step ([`Launch::step`]), with frictional contacts after breaking
    /// ([`contact_law`]) in compression.
    pub loading: Loading,
    /// The engine's directory (created).
    pub dir: PathBuf,
}

impl<'a> Start<'a> {
    /// The start of `engine`'s run of `test` with `law` in the directory `sub` of the
    /// problem's: [`strength_setup`], [`Launch::step`], [`Loading::of`] (with contacts in
    /// compression), the directory created.
    pub fn of(
        engine: &str,
        law: crate::dem::LawKind,
        sub: &str,
        problem: &super::Problem<'a>,
        launch: &Launch,
        test: &StrengthTest,
    ) -> Result<Start<'a>> {
        let (model, strengths, criteria) = strength_setup(engine, problem, law)?;
        let dt = launch.step(problem.packing, problem.bonds, problem.springs)?;
        let mut loading = Loading::of(problem.packing, test, dt, engine)?;
        if test.loading == StrengthLoading::Compression {
            loading.contacts = Some(contact_law(problem.springs, &strengths)?);
        }
        let dir = problem.dir.join(sub);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        Ok(Start {
            model,
            strengths,
            criteria,
            loading,
            dir,
        })
    }
}

/// The engine's runs on each of `launch.processes` (`run(np)`), each recorded as the stage
/// `{stage}_np{np}` of `timings` and said on `progress` as `{who} on {np} process(es):`.
pub fn runs_per_process(
    launch: &Launch,
    stage: &str,
    who: &str,
    timings: &mut Vec<Timing>,
    progress: Progress,
    mut run: impl FnMut(usize) -> Result<StrengthRun>,
) -> Result<Vec<StrengthRun>> {
    let mut measured = Vec::with_capacity(launch.processes.len());
    for &np in &launch.processes {
        let m = run(np)?;
        m.record_stage(
            format!("{stage}_np{np}"),
            &format!("{who} on {np} process(es):"),
            timings,
            progress,
        );
        measured.push(m);
    }
    Ok(measured)
}

/// Files a strength validation writes into its directory.
pub mod outputs {
    /// The report: test, both runs' peaks and first breaks, checks, timings.
    pub const REPORT_JSON: &str = "strength-validation.json";
    /// The checks as CSV.
    pub const CHECKS_CSV: &str = "checks.csv";
}

/// How the bar is loaded: pulled apart (direct tension) or pushed together (uniaxial
/// compression, the UCS test).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StrengthLoading {
    /// Direct tension: the top layer moves up (+axis); the tensile force is measured.
    #[default]
    Tension,
    /// Uniaxial compression: the top layer moves down (−axis); the compressive force is
    /// measured.
    Compression,
}

impl StrengthLoading {
    /// `tension` or `compression`.
    pub fn as_str(self) -> &'static str {
        match self {
            StrengthLoading::Tension => "tension",
            StrengthLoading::Compression => "compression",
        }
    }

    /// The loading named `tension` or `compression`.
    pub fn from_name(name: &str) -> Option<StrengthLoading> {
        match name {
            "tension" => Some(StrengthLoading::Tension),
            "compression" => Some(StrengthLoading::Compression),
            _ => None,
        }
    }

    /// +1 in tension, −1 in compression: the sign of the top layer's velocity along the
    /// axis, and the factor that turns the tensile reaction −ΣF_top into the measured load.
    pub fn sign(self) -> f64 {
        match self {
            StrengthLoading::Tension => 1.0,
            StrengthLoading::Compression => -1.0,
        }
    }

    /// The test's name in reports (`direct tension`, `uniaxial compression`).
    pub fn describe(self) -> &'static str {
        match self {
            StrengthLoading::Tension => "direct tension",
            StrengthLoading::Compression => "uniaxial compression",
        }
    }
}

/// What the strength test is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StrengthTest {
    /// Tension or compression.
    pub loading: StrengthLoading,
    /// Loading axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Depth of each end layer (m): centres within it of the lowest / highest centre.
    pub end_layer: f64,
    /// Axial strain added per time step (the top layer's velocity is this × the gauge
    /// length / the time step): small, so the loading is quasi-static.
    pub strain_per_step: f64,
    /// Time steps run (the same in the engine and the integrator).
    pub steps: u64,
    /// Damping ratio of every bond's own dashpots (the law's damping, the same in both).
    pub damping_ratio: f64,
    /// Broken bonds compared in order.
    pub compared: usize,
    /// Largest admissible relative difference of the peak stress.
    pub tolerance: f64,
    /// Compression: the first peak ends where the force falls below (1 − `peak_drop`) × its
    /// running maximum after bonds broke ([`first_peak`]); unused in tension (the largest
    /// force of the run).
    pub peak_drop: f64,
}

impl StrengthTest {
    /// Direct tension along `axis`, end layers `end_layer` (m) deep, `strain_per_step` for
    /// `steps` steps; bonds' damping ratio 0.3, the first ten breaks compared, peak stress
    /// within 2 % (set `loading` for compression; first-peak drop 5 %).
    pub fn new(axis: usize, end_layer: f64, strain_per_step: f64, steps: u64) -> StrengthTest {
        StrengthTest {
            loading: StrengthLoading::Tension,
            axis,
            end_layer,
            strain_per_step,
            steps,
            damping_ratio: 0.3,
            compared: 10,
            tolerance: 0.02,
            peak_drop: 0.05,
        }
    }

    /// The same test in compression.
    pub fn compression(self) -> StrengthTest {
        StrengthTest {
            loading: StrengthLoading::Compression,
            ..self
        }
    }

    /// Refuse values no run can satisfy, naming the option.
    pub fn check(&self, engine: &str) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("validate {engine} --strength: {m}")));
        if self.axis > 2 {
            return bad(format!("axis {} is not x, y or z", self.axis));
        }
        if !(self.end_layer.is_finite() && self.end_layer >= 0.0) {
            return bad(format!(
                "the end layer must be a finite depth ≥ 0 m, got {}",
                self.end_layer
            ));
        }
        if !(self.strain_per_step.is_finite()
            && self.strain_per_step > 0.0
            && self.strain_per_step < 1e-3)
        {
            return bad(format!(
                "the strain per step must be in (0, 1e-3) (quasi-static), got {}",
                self.strain_per_step
            ));
        }
        if self.steps == 0 {
            return bad("at least one step is needed".into());
        }
        if !(self.damping_ratio.is_finite() && self.damping_ratio >= 0.0) {
            return bad(format!(
                "the damping ratio must be finite and ≥ 0, got {}",
                self.damping_ratio
            ));
        }
        if self.compared == 0 {
            return bad("at least one broken bond must be compared".into());
        }
        let fractions = [("tolerance", self.tolerance), ("peak drop", self.peak_drop)];
        super::harness::check_tolerances(
            &format!("{engine} --strength"),
            &fractions,
            "in (0, 1)",
            |v| v.is_finite() && v > 0.0 && v < 1.0,
        )
    }
}

/// The first peak of a load curve `(step, load)` (the load in the test's sense) whose
/// bonds first broke at `first_break`: the largest load before the first step at or after
/// `first_break` where the load is below (1 − `drop`) × its running maximum; the global
/// maximum if it never drops. Re-hardening after the drop (broken pairs locking up as
/// frictional contacts) does not count. The same rule as the virtual laboratory's
/// (`study::strength_test`), on steps. `(load, step)`; None for an empty curve.
pub fn first_peak(curve: &[(u64, f64)], first_break: Option<u64>, drop: f64) -> Option<(f64, u64)> {
    // The lab's rule (`strength::peak::first_peak`) on (load, bonds broken yet) points.
    let series: Vec<(f64, usize)> = curve
        .iter()
        .map(|&(step, load)| (load, usize::from(first_break.is_some_and(|b| step >= b))))
        .collect();
    crate::strength::peak::first_peak(&series, drop).map(|p| (curve[p.first].1, curve[p.first].0))
}

/// The peak of a run's load curve for `test` (largest load in tension, [`first_peak`] in
/// compression) with its breaks in order.
pub fn peak_of(test: &StrengthTest, curve: &[(u64, f64)], breaks: &[Broken]) -> Option<(f64, u64)> {
    match test.loading {
        StrengthLoading::Tension => first_peak(curve, None, test.peak_drop),
        StrengthLoading::Compression => {
            first_peak(curve, breaks.first().map(|b| b.step), test.peak_drop)
        }
    }
}

/// The frictional contact a broken bond becomes in an engine with contacts after breaking
/// (LAMMPS route (a)'s `pair_style granular`, YADE's shear-broken CohFrictPhys): the median
/// k_n and k_s of the bonds, the mean friction coefficient of their strengths (as
/// `export lammps` writes it). The integrator gives a broken bond's pair the bond's own
/// springs ([`Contacts::set_pair_stiffness`]); these are the springs of new contacts.
pub fn contact_law(
    springs: &crate::bonds::BondStiffness,
    strengths: &BondStrengths,
) -> Result<ContactLaw> {
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let n = strengths.friction.len().max(1) as f64;
    let law = ContactLaw {
        normal_stiffness: median(&springs.kn),
        shear_stiffness: median(&springs.ks),
        friction: strengths.friction.iter().sum::<f64>() / n,
    };
    law.check()?;
    Ok(law)
}

/// A broken bond: its two particles (indices into the packing, i < j) and the step it broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Broken {
    /// Particles, ascending.
    pub pair: (usize, usize),
    /// The step it broke (the integrator's iteration, LAMMPS' timestep: the same count of
    /// loading steps).
    pub step: u64,
}

/// One run's result: the engine's (per process count) or the integrator's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrengthRun {
    /// Who ran it (`anisobond` or the engine with its version).
    pub program: String,
    /// MPI processes (1 for the integrator and YADE).
    pub processes: usize,
    /// Peak axial load on the moved layer (N; tensile in tension, compressive in
    /// compression; [`peak_of`]).
    #[serde(rename = "peak_force_N")]
    pub peak_force: f64,
    /// The step of the peak.
    pub peak_step: u64,
    /// Bonds broken, in breaking order (step, then bond index).
    pub breaks: Vec<Broken>,
    /// Wall time (s).
    #[serde(rename = "wall_s")]
    pub seconds: f64,
}

/// The strength validation's own results inside the [`Report`].
#[derive(Clone, Debug)]
pub struct StrengthDetails {
    /// The engine (`yade`, `lammps`, `liggghts`).
    pub engine: &'static str,
    /// The bond law both ran (`lammps-bpm`, `yade`).
    pub law: &'static str,
    /// The test run.
    pub test: StrengthTest,
    /// Cross-section the stresses are taken on (m²): the bar's lateral bounding box.
    pub area: f64,
    /// The integrator's run.
    pub reference: StrengthRun,
    /// The engine's runs, the first on one process.
    pub measured: Vec<StrengthRun>,
}

/// The strength part of the report JSON.
#[derive(Serialize)]
pub struct StrengthJson<'a> {
    engine: &'static str,
    law: &'static str,
    test: &'a StrengthTest,
    #[serde(rename = "area_m2")]
    area: f64,
    #[serde(rename = "peak_stress_integrator_Pa")]
    reference_peak: f64,
    #[serde(rename = "peak_stress_engine_Pa")]
    engine_peak: Vec<f64>,
    reference: &'a StrengthRun,
    measured: &'a [StrengthRun],
}

/// The summary ([`super::checks_summary`]): the runs' lines, the checks table, wall times;
/// the files: [`outputs`].
impl SharedDetails for StrengthDetails {
    const CHECKS_HEADING: &'static str = "checks:";
    const REPORT_JSON: &'static str = outputs::REPORT_JSON;
    const CHECKS_CSV: &'static str = outputs::CHECKS_CSV;
}

impl EngineDetails for StrengthDetails {
    type Json<'a> = StrengthJson<'a>;
    const ENGINE: &'static str = "strength";
    fn json(&self) -> StrengthJson<'_> {
        StrengthJson {
            engine: self.engine,
            law: self.law,
            test: &self.test,
            area: self.area,
            reference_peak: self.reference.peak_force / self.area,
            engine_peak: self
                .measured
                .iter()
                .map(|m| m.peak_force / self.area)
                .collect(),
            reference: &self.reference,
            measured: &self.measured,
        }
    }
    fn tensors(&self) -> Vec<(String, crate::tensor::Stiffness6)> {
        Vec::new()
    }
    fn summary(r: &Report<Self>) -> String {
        let t = &r.test;
        let mut s = format!(
            "{} vs the integrator, bond law {}: {} along {} of {} particles, {} \
             bonds; end layers {:e} m deep; strain {:e} per step for {} steps; bonds' damping \
             ratio {}; section {:.6e} m²\n",
            r.engine,
            r.law,
            t.loading.describe(),
            ["x", "y", "z"][t.axis],
            r.n_particles,
            r.n_bonds,
            t.end_layer,
            t.strain_per_step,
            t.steps,
            t.damping_ratio,
            r.area
        );
        for run in std::iter::once(&r.reference).chain(&r.measured) {
            let first: Vec<String> = run
                .breaks
                .iter()
                .take(t.compared)
                .map(|b| format!("{}-{}@{}", b.pair.0, b.pair.1, b.step))
                .collect();
            let _ = writeln!(
                s,
                "  {} on {} process(es): peak {:.7e} Pa at step {}, {} bonds broken ({:.1} s); \
                 first: {}",
                run.program,
                run.processes,
                run.peak_force / r.area,
                run.peak_step,
                run.breaks.len(),
                run.seconds,
                first.join(" ")
            );
        }
        s.push('\n');
        s
    }
}

/// The end layers of `packing` along `axis`: centres within `depth` of the lowest and of
/// the highest centre (bottom, top; ascending indices), and the gauge length between the
/// layers' mean centres.
pub fn layers(packing: &Packing, axis: usize, depth: f64) -> (Vec<usize>, Vec<usize>, f64) {
    let c = |p: usize| packing.positions[p][axis];
    let n = packing.len();
    let lo = (0..n).map(c).fold(f64::INFINITY, f64::min);
    let hi = (0..n).map(c).fold(f64::NEG_INFINITY, f64::max);
    let bottom: Vec<usize> = (0..n).filter(|&p| c(p) <= lo + depth).collect();
    let top: Vec<usize> = (0..n).filter(|&p| c(p) >= hi - depth).collect();
    let mean = |v: &[usize]| v.iter().map(|&p| c(p)).sum::<f64>() / v.len().max(1) as f64;
    let gauge = mean(&top) - mean(&bottom);
    (bottom, top, gauge)
}

/// The bar's cross-section normal to `axis`: its lateral bounding box, spheres included (m²).
pub fn section_area(packing: &Packing, axis: usize) -> f64 {
    let mut area = 1.0;
    for a in [(axis + 1) % 3, (axis + 2) % 3] {
        let lo = (0..packing.len())
            .map(|p| packing.positions[p][a] - packing.radii[p])
            .fold(f64::INFINITY, f64::min);
        let hi = (0..packing.len())
            .map(|p| packing.positions[p][a] + packing.radii[p])
            .fold(f64::NEG_INFINITY, f64::max);
        area *= hi - lo;
    }
    area
}

/// What the engine and the integrator share: the free bar, its layers, the top's velocity.
#[derive(Clone, Debug)]
pub struct Loading {
    /// Held bottom layer and moved top layer (ascending indices).
    pub bottom: Vec<usize>,
    /// See `bottom`.
    pub top: Vec<usize>,
    /// Lowest centre along the axis (m): the free spheres' initial velocity is
    /// v·(x − lowest)/gauge.
    pub lowest: f64,
    /// Gauge length between the layers' mean centres (m).
    pub gauge: f64,
    /// Top layer's velocity along the axis (m/s): positive in tension, negative in
    /// compression.
    pub velocity: f64,
    /// Time step (s).
    pub time_step: f64,
    /// +1 in tension, −1 in compression ([`StrengthLoading::sign`]): the load read is
    /// `sign` × (−ΣF_top along the axis).
    pub sign: f64,
    /// The frictional contacts broken bonds become (and spheres that come into touch), when
    /// the engine has them after breaking: the integrator then runs [`Contacts`] with this
    /// law for new pairs and each broken bond's springs for its pair. None (as [`Loading::of`]
    /// sets): no contacts, in the engine and in the integrator.
    pub contacts: Option<ContactLaw>,
}

impl Loading {
    /// The loading of `packing` for `test` with time step `dt`; refused when the layers are
    /// empty or overlap (the bar is not longer than two end layers).
    pub fn of(packing: &Packing, test: &StrengthTest, dt: f64, engine: &str) -> Result<Loading> {
        if packing.cell.is_some() {
            return Err(Error::Invalid(format!(
                "validate {engine} --strength: the packing is periodic; the strength test pulls a \
                 free bar (read it with --free, or a file with a `# free` line)"
            )));
        }
        let (bottom, top, gauge) = layers(packing, test.axis, test.end_layer);
        if bottom.is_empty() || top.is_empty() || bottom.iter().any(|p| top.contains(p)) {
            return Err(Error::Invalid(format!(
                "validate {engine} --strength: end layers {:e} m deep leave no bar between them",
                test.end_layer
            )));
        }
        let lowest = (0..packing.len())
            .map(|p| packing.positions[p][test.axis])
            .fold(f64::INFINITY, f64::min);
        Ok(Loading {
            bottom,
            top,
            lowest,
            gauge,
            velocity: test.loading.sign() * test.strain_per_step * gauge / dt,
            time_step: dt,
            sign: test.loading.sign(),
            contacts: None,
        })
    }

    /// The atom type of every particle of a packing of `n`, as the decks number them: 2 the
    /// bottom layer, 3 the top one, 1 free.
    pub fn atom_types(&self, n: usize) -> Vec<u8> {
        let mut types = vec![1u8; n];
        for &p in &self.bottom {
            types[p] = 2;
        }
        for &p in &self.top {
            types[p] = 3;
        }
        types
    }

    /// Start `sim` (of spheres at `positions`) on this loading along `axis`: the free
    /// spheres in the linear velocity field v·(x − lowest)/gauge, the bottom layer held and
    /// the top one moved at v (prescribed motion), as the engines' decks start them.
    pub fn start(&self, sim: &mut Simulation, positions: &[Vec3], axis: usize) -> Result<()> {
        let along = |v: f64| {
            let mut u = Vec3::zeros();
            u[axis] = v;
            u
        };
        for (v, x) in sim.particles.velocity.iter_mut().zip(positions) {
            *v = along(self.velocity * (x[axis] - self.lowest) / self.gauge);
        }
        let mut held = Vec::new();
        let mut velocity = Vec::new();
        for (layer, v) in [(&self.bottom, 0.0), (&self.top, self.velocity)] {
            for &p in layer {
                held.push(p);
                velocity.push(along(v));
                sim.particles.velocity[p] = along(v);
            }
        }
        sim.set_prescribed_motion(Some(PrescribedMotion {
            particles: held,
            velocity,
        }))
    }
}

/// The pair of bond `b`, ascending.
fn pair(bonds: &BondSet, b: usize) -> (usize, usize) {
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    (i.min(j), i.max(j))
}

/// The bond index of every pair (ascending), for reading an engine's broken pairs.
pub fn pair_index(bonds: &BondSet) -> HashMap<(usize, usize), usize> {
    (0..bonds.len()).map(|b| (pair(bonds, b), b)).collect()
}

/// An engine's broken pairs `(i, j, step)` (particle indices, any order, a bond possibly
/// reported by two processes) as [`Broken`]s in breaking order: by step, then bond index;
/// each bond once (its first report). Refused ([`Error::EngineFailed`]) for a pair that is
/// no bond.
pub fn order_breaks(
    engine: &str,
    bonds: &BondSet,
    raw: &[(usize, usize, u64)],
) -> Result<Vec<Broken>> {
    let index = pair_index(bonds);
    let mut seen: HashMap<usize, u64> = HashMap::new();
    for &(i, j, step) in raw {
        let p = (i.min(j), i.max(j));
        let b = *index.get(&p).ok_or_else(|| {
            Error::engine(
                engine,
                format!(
                    "reported a broken bond between particles {} and {}, which no bond joins",
                    p.0, p.1
                ),
            )
        })?;
        let e = seen.entry(b).or_insert(step);
        *e = (*e).min(step);
    }
    let mut v: Vec<(u64, usize)> = seen.into_iter().map(|(b, s)| (s, b)).collect();
    v.sort_unstable();
    Ok(v.into_iter()
        .map(|(step, b)| Broken {
            pair: pair(bonds, b),
            step,
        })
        .collect())
}

impl StrengthRun {
    /// Record the integrator's run as the `integrator` stage of `timings` and say what it
    /// found (peak force, bonds broken) on `progress`: what every engine's test does with
    /// [`reference()`]'s result.
    pub fn record(&self, timings: &mut Vec<Timing>, progress: Progress) {
        self.record_stage(
            "integrator".into(),
            "anisobond: integrator",
            timings,
            progress,
        );
    }

    /// Record this run's wall time as `stage` of `timings` and say on `progress` what `who`
    /// found (`{who} done in … s: peak … N, … bonds broken`).
    pub fn record_stage(
        &self,
        stage: String,
        who: &str,
        timings: &mut Vec<Timing>,
        progress: Progress,
    ) {
        timings.push(Timing {
            stage,
            seconds: self.seconds,
        });
        progress(&format!(
            "{who} done in {:.1} s: peak {:.7e} N, {} bonds broken",
            self.seconds,
            self.peak_force,
            self.breaks.len()
        ));
    }
}

/// The integrator's run of the test on `problem`'s packing and bonds: `law` (the engine's,
/// with its damping) and `criteria` (the same limits), the masses of `density`, Cundall `local_damping` (YADE's; 0 for
/// LAMMPS), the bottom layer held, the top moved at the loading's velocity, the free
/// spheres started in the linear velocity field, frictional contacts after breaking when
/// [`Loading::contacts`] says so (Verlet skin a fifth of the mean radius); the top layer's
/// load read every step, its peak by [`peak_of`].
pub fn reference(
    problem: &super::Problem,
    law: Box<dyn BondLaw>,
    criteria: BondCriteria,
    density: f64,
    local_damping: f64,
    loading: &Loading,
    test: &StrengthTest,
) -> Result<StrengthRun> {
    let (packing, bonds) = (problem.packing, problem.bonds);
    crate::dem::check_run_size("validate --strength", packing.len(), test.steps as f64)?;
    let t0 = std::time::Instant::now();
    let opts = DemOptions {
        time_step: Some(loading.time_step),
        mass: crate::dem::MassOptions {
            density,
            scaling: 1.0,
        },
        check_interval: 0,
        local_damping,
        ..Default::default()
    };
    let mut sim = Simulation::new(packing, bonds, law, &opts)?;
    sim.set_breakage(Some(criteria))?;
    if let Some(law) = loading.contacts {
        let mean = packing.radii.iter().sum::<f64>() / packing.len().max(1) as f64;
        sim.set_contacts(Some(Contacts::new(law, 0.2 * mean)?))?;
    }
    let ax = test.axis;
    loading.start(&mut sim, &packing.positions, ax)?;
    let mut curve = Vec::with_capacity(test.steps as usize + 1);
    for _ in 0..=test.steps {
        let step = sim.iteration();
        sim.step()?;
        let f = -loading.top.iter().map(|&p| sim.force[p][ax]).sum::<f64>();
        curve.push((step, loading.sign * f));
    }
    let mut events: Vec<(u64, usize)> = sim
        .break_events()
        .iter()
        .map(|e| (e.step, e.bond))
        .collect();
    events.sort_unstable();
    let breaks: Vec<Broken> = events
        .into_iter()
        .map(|(step, b)| Broken {
            pair: pair(bonds, b),
            step,
        })
        .collect();
    let (peak_force, peak_step) = peak_of(test, &curve, &breaks).unwrap_or((f64::NAN, 0));
    Ok(StrengthRun {
        program: format!("anisobond {}", env!("CARGO_PKG_VERSION")),
        processes: 1,
        peak_force,
        peak_step,
        breaks,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// How many of the first `n` broken bonds of `a` and `b` differ, position by position (a
/// missing one differs).
pub fn differing(a: &[Broken], b: &[Broken], n: usize) -> usize {
    (0..n)
        .filter(|&k| a.get(k).map(|x| x.pair) != b.get(k).map(|x| x.pair) || a.get(k).is_none())
        .count()
}

/// The report: per engine run, its peak stress against the integrator's
/// (`peak-stress[-npN]`) and its first `test.compared` broken bonds against the
/// integrator's, in order (`first-breaks[-npN]`: the count that differ, 0 passes).
#[allow(clippy::too_many_arguments)]
pub fn compare(
    engine: &'static str,
    law: &'static str,
    test: &StrengthTest,
    problem: &super::Problem,
    reference: StrengthRun,
    measured: Vec<StrengthRun>,
    time_step: f64,
    timings: Vec<Timing>,
) -> Result<Report<StrengthDetails>> {
    if measured.is_empty() {
        return Err(Error::engine(
            engine,
            "no run measured a peak: the engine returned nothing to compare with the integrator",
        ));
    }
    let packing = problem.packing;
    let area = section_area(packing, test.axis);
    let mut checks = Vec::new();
    for m in &measured {
        let suffix = if m.processes == 1 {
            String::new()
        } else {
            format!("-np{}", m.processes)
        };
        let rel = ((m.peak_force - reference.peak_force) / reference.peak_force).abs();
        checks.push(Check::new(
            format!("peak-stress{suffix}"),
            format!(
                "peak {} stress, {engine} on {} process(es) vs the integrator (law {law})",
                match test.loading {
                    StrengthLoading::Tension => "tensile",
                    StrengthLoading::Compression => "compressive (first peak)",
                },
                m.processes
            ),
            if rel.is_finite() { rel } else { f64::NAN },
            test.tolerance,
        ));
        checks.push(Check::new(
            format!("first-breaks{suffix}"),
            format!(
                "of the first {} broken bonds (in order), how many differ from the integrator's",
                test.compared
            ),
            differing(&reference.breaks, &m.breaks, test.compared) as f64,
            0.0,
        ));
    }
    Ok(Report {
        n_particles: packing.len(),
        n_bonds: problem.bonds.len(),
        time_step,
        checks,
        timings,
        details: StrengthDetails {
            engine,
            law,
            test: *test,
            area,
            reference,
            measured,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn broken(pairs: &[(usize, usize)]) -> Vec<Broken> {
        pairs
            .iter()
            .enumerate()
            .map(|(k, &pair)| Broken {
                pair,
                step: k as u64,
            })
            .collect()
    }

    #[test]
    fn breaks_are_ordered_by_step_then_bond_and_counted_once() {
        let bonds = BondSet {
            i: vec![0, 1, 2],
            j: vec![1, 2, 3],
            ..Default::default()
        };
        // Bond 2 (2-3) and bond 0 (1-0, reversed) at step 5, bond 0 reported again by the
        // other process; bond 1 at step 4.
        let raw = [(3, 2, 5), (1, 0, 5), (0, 1, 5), (1, 2, 4)];
        let v = order_breaks("lammps", &bonds, &raw).unwrap();
        let pairs: Vec<_> = v.iter().map(|b| (b.pair, b.step)).collect();
        assert_eq!(pairs, [((1, 2), 4), ((0, 1), 5), ((2, 3), 5)]);
        let e = order_breaks("lammps", &bonds, &[(0, 3, 1)]).unwrap_err();
        assert!(matches!(e, Error::EngineFailed { .. }), "{e}");
    }

    #[test]
    fn first_peak_ignores_re_hardening_after_the_drop_and_noise_before_the_first_break() {
        // Rises to 10 at step 2, dips 40 % before any bond broke (not a failure), peaks at
        // 12 (step 5), falls to 11 (−8 %) after the first break at step 5, re-hardens to 20.
        let c: Vec<(u64, f64)> = [0.0, 5.0, 10.0, 6.0, 11.0, 12.0, 11.0, 15.0, 20.0]
            .iter()
            .enumerate()
            .map(|(k, &f)| (k as u64, f))
            .collect();
        assert_eq!(first_peak(&c, Some(5), 0.05), Some((12.0, 5)));
        // A 10 % drop is not reached at 11/12: the global maximum.
        assert_eq!(first_peak(&c, Some(5), 0.1), Some((20.0, 8)));
        // No break: never a failure, the global maximum (the tension rule).
        assert_eq!(first_peak(&c, None, 0.05), Some((20.0, 8)));
        assert_eq!(first_peak(&[], Some(0), 0.05), None);
        let mut t = StrengthTest::new(2, 0.0, 1e-6, 10).compression();
        let b = [Broken {
            pair: (0, 1),
            step: 5,
        }];
        assert_eq!(peak_of(&t, &c, &b), Some((12.0, 5)));
        t.loading = StrengthLoading::Tension;
        assert_eq!(peak_of(&t, &c, &b), Some((20.0, 8)));
        t.peak_drop = 1.0;
        assert!(matches!(t.check("yade"), Err(Error::Invalid(_))));
    }

    #[test]
    fn differing_counts_positions_and_missing_breaks() {
        let a = broken(&[(0, 1), (1, 2), (2, 3)]);
        assert_eq!(differing(&a, &a, 3), 0);
        assert_eq!(differing(&a, &broken(&[(1, 2), (0, 1), (2, 3)]), 3), 2);
        assert_eq!(differing(&a, &a[..2], 3), 1);
        assert_eq!(differing(&a[..2], &a[..2], 3), 1);
    }
}
