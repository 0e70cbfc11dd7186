//! The engine interface: what every validation engine (YADE, LIGGGHTS, LAMMPS) is given — a
//! [`Problem`] and its own options —, what it returns — a [`Report`] with its
//! [`EngineDetails`] —, how it reports progress — one [`Progress`] callback —, and the
//! [`TestKind`]s it runs. A client runs any engine through [`validate`]; a new test kind is
//! a [`TestKind`] variant every engine's [`Engine::run`] answers (docs/architecture.md).

pub use super::harness::{check_tolerances, Launch, Problem, Progress, TestKind};
use super::harness::{EngineDetails, Report};
use super::specimen::{SpecimenDetails, SpecimenTest};
use super::strength::{StrengthDetails, StrengthTest};
use crate::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Agreement required by the comparisons every engine makes (relative differences); an
/// engine that makes no comparison of a kind ignores its tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerances {
    /// Undamped stress histories: max |Δσ| / max |σ| of the reference run.
    pub history: f64,
    /// Damped tensors, the engine against the reference integrator.
    pub tensor: f64,
    /// Damped tensors against the relaxed solver.
    pub relaxed: f64,
    /// The engine on N MPI processes against one.
    #[serde(skip)]
    pub processes: f64,
}

/// A validation engine: runs a [`Problem`] in another code and in anisobond, and compares.
///
/// The three runners, each built from its programs and options (they run only where YADE,
/// LIGGGHTS with the `anisobond-liggghts` driver, or LAMMPS are installed):
/// ```no_run
/// # fn main() -> anisobond::Result<()> {
/// use anisobond::prelude::*;
/// use anisobond::validate::lammps::LammpsValidateOptions;
/// use anisobond::validate::liggghts::{Programs, ValidateOptions};
/// use anisobond::validate::yade::YadeValidationOptions;
/// use std::path::{Path, PathBuf};
/// let assembly = Assembly::new(read_packing(Path::new("packing.txt"))?, Model::truszkowska_mrv())?;
/// let problem = Problem::of(Path::new("run"), &assembly);
/// let progress = |stage: &str| eprintln!("{stage}");
/// let yade = validate(&Yade(YadeValidationOptions::default()), &problem, &progress)?;
/// let lammps = Lammps(LammpsValidateOptions::new(PathBuf::from("lmp")));
/// let lammps = validate(&lammps, &problem, &progress)?;
/// let liggghts = Liggghts {
///     programs: Programs {
///         driver: PathBuf::from("cpp/build/anisobond-liggghts"),
///         liggghts: PathBuf::from("liggghts"),
///     },
///     options: ValidateOptions::default(),
/// };
/// let liggghts = validate(&liggghts, &problem, &progress)?;
/// println!("{} {} {}", yade.passed(), lammps.passed(), liggghts.passed());
/// # Ok(())
/// # }
/// ```
pub trait Engine: Sync {
    /// The engine's own results inside the [`Report`].
    type Details: EngineDetails;
    /// Refuse options no run can satisfy, before anything is written or run.
    fn check(&self) -> Result<()>;
    /// The test kinds the engine runs.
    fn kinds(&self) -> &'static [TestKind] {
        &[TestKind::PeriodicElement]
    }
    /// Run `problem` (options checked, kind among [`Engine::kinds`]). A comparison outside
    /// tolerance is a failed check of the report, not an error; errors: the engine's program
    /// failed ([`Error::EngineFailed`]), did not settle ([`Error::NotConverged`]), or the
    /// input cannot be run.
    fn run(&self, problem: &Problem, progress: Progress) -> Result<Report<Self::Details>>;
    /// Write the report files into `dir` (atomically each); returns the paths written.
    fn write_files(&self, dir: &Path, report: &Report<Self::Details>) -> Result<Vec<PathBuf>>;
    /// The engine's free-specimen decks — the specimen test ([`super::specimen`]: the
    /// engine builds the bonded specimen of a free packing, loads it between platens by its
    /// own means, and its platen stiffness is compared with the specimen solve's) and the
    /// strength test ([`super::strength`]: direct tension or compression to failure in the
    /// engine and in the integrator with the same bond law and limits, peak stress and first
    /// broken bonds compared) — with the one [`Launch`] both take. Their reports are the same
    /// for every engine, so they are decks rather than [`TestKind`]s. Default: none (both
    /// tests are refused); an error when the engine's program cannot be found.
    fn decks(&self) -> Result<Option<Decks<'_>>> {
        Ok(None)
    }
}

/// Runs an engine's specimen deck with its [`Launch`]: writes, runs and reads the deck, and
/// compares with the specimen solve.
pub type SpecimenRunner =
    fn(&Launch, &Problem, &SpecimenTest, Progress) -> Result<Report<SpecimenDetails>>;

/// Runs an engine's strength deck with its [`Launch`], against the integrator with the same
/// law (it may hold engine options the launch does not carry, as LAMMPS' bond style).
pub type StrengthRunner<'a> =
    Box<dyn Fn(&Launch, &Problem, &StrengthTest, Progress) -> Result<Report<StrengthDetails>> + 'a>;

/// An engine's free-specimen decks as [`Engine::decks`] gives them.
pub struct Decks<'a> {
    /// The settings both decks take.
    pub launch: Launch,
    /// The specimen test's runner.
    pub specimen: SpecimenRunner,
    /// The strength test's runner.
    pub strength: StrengthRunner<'a>,
}

/// The decks of `engine`, or the refusal of `test` by an engine that has none.
fn decks_of<'a, E: Engine>(engine: &'a E, test: &str) -> Result<Decks<'a>> {
    engine.decks()?.ok_or_else(|| {
        Error::Invalid(format!(
            "validate {}: the engine does not run the {test}",
            E::Details::ENGINE
        ))
    })
}

/// Run the strength test `test` of `engine` on `problem`: the engine's and the test's
/// options checked, then the engine's strength deck ([`Engine::decks`]) run.
pub fn validate_strength<E: Engine>(
    engine: &E,
    problem: &Problem,
    test: &StrengthTest,
    progress: Progress,
) -> Result<Report<StrengthDetails>> {
    engine.check()?;
    test.check(E::Details::ENGINE)?;
    refuse_many_body(E::Details::ENGINE, problem, "strength test")?;
    let decks = decks_of(engine, "strength test")?;
    (decks.strength)(&decks.launch, problem, test, progress)
}

/// Refuse a model with a `[manybody]` term for a free-specimen test: no engine's specimen
/// or strength deck carries it, and the integrator refuses it there too (its default
/// volumes share a periodic cell; a broken bond would have to leave the fits;
/// docs/manybody.md). Without this the engines would validate the springs alone.
fn refuse_many_body(engine: &str, problem: &Problem, test: &str) -> Result<()> {
    if problem.model.is_some_and(|m| m.manybody.is_some()) {
        return Err(Error::Invalid(format!(
            "validate {engine}: the model has a [manybody] term, which the {test} does not \
             carry (free specimens and breaking bonds are not run with the term; \
             docs/manybody.md): validate the periodic element tests, or remove [manybody] to \
             validate the springs"
        )));
    }
    Ok(())
}

/// Run the specimen test `test` of `engine` on `problem`: the engine's and the test's
/// options checked, then the engine's specimen deck ([`Engine::decks`]) run.
///
/// The platen stiffness of a free packing's specimen in YADE against the specimen solve
/// (z axis, end layers of one mean radius, frictionless platens):
/// ```no_run
/// # fn main() -> anisobond::Result<()> {
/// use anisobond::prelude::*;
/// use anisobond::specimen::Platens;
/// use anisobond::validate::specimen::SpecimenTest;
/// use anisobond::validate::yade::YadeValidationOptions;
/// use std::path::Path;
/// let assembly = Assembly::new(read_packing(Path::new("free.txt"))?, Model::truszkowska_mrv())?;
/// let test = SpecimenTest::new(2, 1e-3, Platens::Frictionless);
/// let engine = Yade(YadeValidationOptions::default());
/// let report = validate_specimen(&engine, &Problem::of(Path::new("run"), &assembly), &test, &|s| eprintln!("{s}"))?;
/// println!("passed: {}", report.passed());
/// # Ok(())
/// # }
/// ```
pub fn validate_specimen<E: Engine>(
    engine: &E,
    problem: &Problem,
    test: &SpecimenTest,
    progress: Progress,
) -> Result<Report<SpecimenDetails>> {
    engine.check()?;
    test.check(E::Details::ENGINE)?;
    refuse_many_body(E::Details::ENGINE, problem, "specimen test")?;
    let decks = decks_of(engine, "specimen test")?;
    (decks.specimen)(&decks.launch, problem, test, progress)
}

/// Run `engine` on `problem`: its options checked, the test kind refused unless the engine
/// runs it, then [`Engine::run`].
///
/// Every engine runs the same way (here YADE, which must be installed to run it):
/// ```no_run
/// # fn main() -> anisobond::Result<()> {
/// use anisobond::assembly::Assembly;
/// use anisobond::model::Model;
/// use anisobond::validate::{validate, Problem};
/// use anisobond::validate::write_report_json;
/// use anisobond::validate::yade::{Yade, YadeValidationOptions};
/// use std::path::Path;
/// let packing = anisobond::packing::read_packing(Path::new("packing.txt"))?;
/// let assembly = Assembly::new(packing, Model::from_path(Path::new("model.toml"))?)?;
/// let dir = Path::new("yade-run");
/// std::fs::create_dir_all(dir).map_err(|e| anisobond::Error::io(dir, e))?;
/// let engine = Yade(YadeValidationOptions::default());
/// let report = validate(&engine, &Problem::of(dir, &assembly), &|stage| eprintln!("{stage}"))?;
/// write_report_json(&dir.join("validation.json"), &report)?;
/// println!("passed: {}", report.passed());
/// # Ok(())
/// # }
/// ```
pub fn validate<E: Engine>(
    engine: &E,
    problem: &Problem,
    progress: Progress,
) -> Result<Report<E::Details>> {
    engine.check()?;
    if !engine.kinds().contains(&problem.kind) {
        return Err(Error::Invalid(format!(
            "validate {}: the engine does not run the {} test",
            E::Details::ENGINE,
            problem.kind.name()
        )));
    }
    engine.run(problem, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tolerance_outside_its_range_is_refused_by_name() {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let named = [("history tolerance", 1e-6), ("MPI tolerance", f64::NAN)];
        let e = check_tolerances("x", &named, "finite and > 0", positive).unwrap_err();
        assert!(matches!(e, Error::Invalid(_)));
        let e = e.to_string();
        assert!(
            e.contains("validate x: the MPI tolerance must be finite and > 0"),
            "{e}"
        );
        assert!(check_tolerances("x", &named[..1], "finite and > 0", positive).is_ok());
    }
}
