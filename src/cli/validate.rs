//! `anisobond validate yade|liggghts|lammps PACKING --model MODEL [-o DIR]`: the same problem
//! in another DEM code and in anisobond through the engine's [`Engine`] implementation, the
//! differences as a table with units, files in DIR, and a non-zero exit status when any
//! agreement is outside its tolerance ([`run_engine`], the one path every engine takes).

use super::cell::BondedInput;
use super::validate_specimen::SpecimenFlags;
use anisobond::export::yade::parse_paths;
use anisobond::io::OutputSet;
use anisobond::validate::specimen;
use anisobond::validate::yade::{Yade, YadeValidationOptions};
use anisobond::validate::{failure_lines, summary, unsettled_lines, EngineDetails};
use anisobond::validate::{validate, validate_specimen, Engine, Problem, Tolerances};
use anisobond::{Error, Result};
use clap::Subcommand;
use std::path::{Path, PathBuf};

/// Validate anisobond against another DEM code.
#[derive(clap::Args)]
pub struct ValidateArgs {
    #[command(subcommand)]
    pub target: ValidateTarget,
}

/// The codes to validate against.
#[derive(Subcommand)]
pub enum ValidateTarget {
    /// YADE 2023.02a (`yade` on PATH): undamped stress histories step by step, damped
    /// six-path tensors, and both against the relaxed solver. Writes DIR/yade/ (the export
    /// YADE ran), DIR/undamped-history.csv and DIR/damped-history.csv (both codes' stress
    /// side by side, Pa) and DIR/validation.json; exits non-zero when a comparison is out
    /// of tolerance.
    Yade(YadeValidateArgs),
    /// The LIGGGHTS driver and the stock LIGGGHTS against the reference integrator and the
    /// relaxed solver; non-zero exit status when out of tolerance.
    Liggghts(super::validate_liggghts::Args),
    /// The exported LAMMPS (BPM) element tests against the relaxed solver, 1 and 2 processes.
    Lammps(super::validate_lammps::Args),
}

/// Arguments of `validate yade`.
#[derive(clap::Args)]
pub struct YadeValidateArgs {
    #[command(flatten)]
    pub input: BondedInput,
    /// Output directory (created if missing); default: a temporary directory, removed.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Strain of every path, applied in one step (engineering; extension positive).
    #[arg(long, default_value_t = 1e-5)]
    pub strain: f64,
    /// Particle density (kg/m³) of both codes.
    #[arg(long, default_value_t = 2600.0)]
    pub density: f64,
    /// Time step (s) of both codes; default: --safety × anisobond's critical estimate.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Fraction of the critical time step used when --dt is not given.
    #[arg(long, default_value_t = 0.8)]
    pub safety: f64,
    /// Steps of the undamped runs (strain step included).
    #[arg(long, default_value_t = 1000)]
    pub undamped_steps: usize,
    /// Paths of the undamped comparison, Voigt labels.
    #[arg(long, default_value = "11,12")]
    pub undamped_paths: String,
    /// Steps of every damped path (strain step included).
    #[arg(long, default_value_t = 200)]
    pub damped_steps: usize,
    /// Cundall local damping of the damped runs.
    #[arg(long, default_value_t = 0.4)]
    pub damping: f64,
    /// Relative CG residual of the relaxed solver.
    #[arg(long, default_value_t = 1e-8)]
    pub cg_tolerance: f64,
    /// Largest admissible max |Δσ| / max |σ| of the undamped histories.
    #[arg(long, default_value_t = 1e-6)]
    pub history_tolerance: f64,
    /// Largest admissible relative difference of the damped tensors, YADE vs anisobond.
    #[arg(long, default_value_t = 1e-3)]
    pub tensor_tolerance: f64,
    /// Largest admissible relative difference of each damped tensor from the relaxed one.
    #[arg(long, default_value_t = 1e-3)]
    pub relaxed_tolerance: f64,
    /// The specimen test instead of the element tests.
    #[command(flatten)]
    pub specimen: SpecimenFlags,
}

impl YadeValidateArgs {
    /// The YADE engine with these settings.
    fn engine(&self) -> Result<Yade> {
        Ok(Yade(YadeValidationOptions {
            strain: self.strain,
            density: self.density,
            time_step: self.dt,
            safety: self.safety,
            undamped_steps: self.undamped_steps,
            undamped_paths: parse_paths(&self.undamped_paths)?,
            damped_steps: self.damped_steps,
            damping: self.damping,
            cg_tolerance: self.cg_tolerance,
            tolerances: Tolerances {
                history: self.history_tolerance,
                tensor: self.tensor_tolerance,
                relaxed: self.relaxed_tolerance,
                processes: 0.0,
            },
        }))
    }
}

/// Run `validate`.
pub fn run(a: ValidateArgs) -> Result<()> {
    match a.target {
        ValidateTarget::Yade(y) => {
            dispatch(&y.engine()?, &y.input, y.output.as_deref(), &y.specimen)
        }
        ValidateTarget::Liggghts(a) => {
            dispatch(&a.engine()?, &a.input, Some(&a.output), &a.specimen)
        }
        ValidateTarget::Lammps(a) => dispatch(&a.engine()?, &a.input, Some(&a.output), &a.specimen),
    }
}

/// The element tests, or the specimen test with `--specimen`.
fn dispatch<E: Engine>(
    engine: &E,
    input: &BondedInput,
    output: Option<&Path>,
    specimen: &SpecimenFlags,
) -> Result<()> {
    if specimen.specimen {
        run_specimen(engine, input, output, specimen)
    } else {
        run_engine(engine, input, output)
    }
}

/// `validate ENGINE --specimen`: as [`run_engine`], with the specimen test.
fn run_specimen<E: Engine>(
    engine: &E,
    input: &BondedInput,
    output: Option<&Path>,
    flags: &SpecimenFlags,
) -> Result<()> {
    engine.check()?;
    let name = E::Details::ENGINE;
    let mut set = OutputSet::new(&input.paths());
    let staged = set.optional_dir(output)?;
    let asm = input.assembly()?;
    let test = flags.test(&asm);
    test.check(name)?;
    let temp;
    let dir = match &staged {
        Some(d) => d.clone(),
        None => {
            temp = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
            temp.path().to_path_buf()
        }
    };
    println!(
        "validate {name} --specimen: {} particles, {} bonds; runs in {}",
        asm.packing.len(),
        asm.bonds.len(),
        dir.display()
    );
    let t0 = std::time::Instant::now();
    let progress = |m: &str| eprintln!("[{:7.1} s] {m}", t0.elapsed().as_secs_f64());
    let report = validate_specimen(engine, &Problem::of(&dir, &asm), &test, &progress)?;
    print!("{}", specimen::summary(&report));
    if let Some(out) = output {
        let files = specimen::write_files(&dir, &report)?;
        set.commit()?;
        println!();
        super::output::print_written("wrote ", &files, &dir, out);
    }
    finish(name, &report)
}

/// The end of every validation (its files already written): [`Error::OutOfTolerance`]
/// naming the failed checks; else [`Error::NotConverged`] when a compared run had not
/// settled (its checks not judged: neither a pass nor a failure, so not a success either);
/// else exit 0.
fn finish<D>(name: &str, report: &anisobond::validate::Report<D>) -> Result<()> {
    let unsettled = unsettled_lines(report);
    for line in &unsettled {
        println!("not judged: {line}");
    }
    let failures = failure_lines(report);
    if failures.is_empty() && !unsettled.is_empty() {
        return Err(Error::NotConverged(format!(
            "validate {name}: {} of {} checks not judged, the compared run had not settled \
             (relax longer: more steps or a looser settling tolerance):\n  {}",
            unsettled.len(),
            report.checks.len(),
            unsettled.join("\n  ")
        )));
    }
    if failures.is_empty() {
        println!("PASSED: {name} and anisobond agree within every tolerance");
        return Ok(());
    }
    Err(Error::OutOfTolerance {
        failed: failures.len(),
        checks: report.checks.len(),
        message: format!(
            "validate {name} FAILED ({} of {} checks outside tolerance):\n  {}",
            failures.len(),
            report.checks.len(),
            failures.join("\n  ")
        ),
    })
}

/// Every `validate ENGINE`: options checked, the bonded input read, the engine run in the
/// staged `output` (a temporary directory, removed, without one) with one progress line
/// per stage, the summary printed, the report files written and moved into place, and the
/// end ([`finish`]): exit 0 when every check is within its tolerance, else
/// [`Error::OutOfTolerance`] naming the failed checks, else [`Error::NotConverged`] when a
/// compared run had not settled (an engine that failed has ended earlier with
/// [`Error::EngineFailed`]).
fn run_engine<E: Engine>(engine: &E, input: &BondedInput, output: Option<&Path>) -> Result<()> {
    engine.check()?;
    let name = E::Details::ENGINE;
    let mut set = OutputSet::new(&input.paths());
    let staged = set.optional_dir(output)?;
    let asm = input.assembly()?;
    let temp;
    let dir = match &staged {
        Some(d) => d.clone(),
        None => {
            temp = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
            temp.path().to_path_buf()
        }
    };
    println!(
        "validate {name}: {} particles, {} bonds; runs in {}{}",
        asm.packing.len(),
        asm.bonds.len(),
        dir.display(),
        output.map_or(String::new(), |o| format!(
            " (moved to {} when done)",
            o.display()
        ))
    );
    let t0 = std::time::Instant::now();
    let progress = |m: &str| eprintln!("[{:7.1} s] {m}", t0.elapsed().as_secs_f64());
    let report = validate(engine, &Problem::of(&dir, &asm), &progress)?;
    print!("{}", summary(&report));
    if let Some(out) = output {
        let files = engine.write_files(&dir, &report)?;
        set.commit()?;
        println!();
        super::output::print_written("wrote ", &files, &dir, out);
    }
    finish(name, &report)
}
