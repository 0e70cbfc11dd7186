//! `anisobond validate yade|liggghts|lammps PACKING --model MODEL [-o DIR]`: the same problem
//! in another DEM code and in anisobond through the engine's [`Engine`] implementation, the
//! differences as a table with units, files in DIR, and a non-zero exit status when any
//! agreement is outside its tolerance ([`run_engine`], the one path every engine takes).

use super::cell::BondedInput;
use super::validate_strength::FreeTestFlags;
use anisobond::export::yade::parse_paths;
use anisobond::io::OutputSet;
use anisobond::validate::yade::{Yade, YadeValidationOptions};
use anisobond::validate::{
    checks_summary, outcome, summary, unsettled_lines, write_report_files, EngineDetails, Progress,
    Report, SharedDetails,
};
use anisobond::validate::{
    validate, validate_specimen, validate_strength, Engine, Problem, Tolerances,
};
use anisobond::Result;
use clap::Subcommand;
use std::path::{Path, PathBuf};

/// The codes to validate against (the subcommands of `validate`).
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
    /// The masses and the time step, the same in both codes.
    #[command(flatten)]
    pub step: super::export::YadeStepArgs,
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
    /// The specimen or the strength test instead of the element tests.
    #[command(flatten)]
    pub tests: FreeTestFlags,
}

impl YadeValidateArgs {
    /// The YADE engine with these settings.
    fn engine(&self) -> Result<Yade> {
        Ok(Yade(YadeValidationOptions {
            strain: self.strain,
            density: self.step.density,
            time_step: self.step.dt,
            safety: self.step.safety,
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
pub fn run(target: ValidateTarget) -> Result<()> {
    match target {
        ValidateTarget::Yade(y) => dispatch(&y.engine()?, &y.input, y.output.as_deref(), &y.tests),
        ValidateTarget::Liggghts(a) => dispatch(&a.engine()?, &a.input, Some(&a.output), &a.tests),
        ValidateTarget::Lammps(a) => dispatch(&a.engine()?, &a.input, Some(&a.output), &a.tests),
    }
}

/// The element tests, the specimen test with `--specimen` or the strength test with
/// `--strength`: the engine's options checked, the output staged and the bonded input read
/// ([`RunDir::open`]), then the run.
fn dispatch<E: Engine>(
    engine: &E,
    input: &BondedInput,
    output: Option<&Path>,
    tests: &FreeTestFlags,
) -> Result<()> {
    let run = RunDir::open(engine, input, output)?;
    let (specimen, name) = (&tests.specimen, E::Details::ENGINE);
    if tests.strength.strength {
        let test = tests.strength.test(specimen, &run.asm);
        test.check(name)?;
        run_free_test(name, run, "--strength", |p, progress| {
            validate_strength(engine, p, &test, progress)
        })
    } else if specimen.specimen {
        let test = specimen.test(&run.asm);
        test.check(name)?;
        run_free_test(name, run, "--specimen", |p, progress| {
            validate_specimen(engine, p, &test, progress)
        })
    } else {
        run_engine(engine, run)
    }
}

/// `validate ENGINE --specimen` or `--strength` (`flag`), as [`run_engine`]: the test
/// announced, run on the problem by `validate_test`, the summary printed, the report files
/// kept and the end ([`finish`]).
fn run_free_test<D: SharedDetails>(
    name: &str,
    run: RunDir,
    flag: &str,
    validate_test: impl FnOnce(&Problem, Progress) -> Result<Report<D>>,
) -> Result<()> {
    run.announce(&format!("validate {name} {flag}"), "");
    let problem = Problem::of(&run.dir, &run.asm);
    let report = validate_test(&problem, &|m| run.progress(m))?;
    print!("{}", checks_summary(&report));
    run.keep(|dir| write_report_files(dir, &report))?;
    finish(name, &report)
}

/// Where a validation runs: the bonded input read, the staged `output` (a temporary
/// directory, removed when dropped, without one), and the start time of the progress lines.
struct RunDir {
    set: OutputSet,
    /// Where the report files go (`-o`), if anywhere.
    output: Option<PathBuf>,
    dir: PathBuf,
    /// Keeps a temporary directory until the run is over.
    _work: anisobond::io::WorkDir,
    asm: anisobond::assembly::Assembly,
    t0: std::time::Instant,
}

impl RunDir {
    /// The engine's options checked, the output staged, the bonded input read.
    fn open<E: Engine>(engine: &E, input: &BondedInput, output: Option<&Path>) -> Result<RunDir> {
        engine.check()?;
        let mut set = OutputSet::new(&input.paths());
        let work = set.dir_or_temporary(output)?;
        let asm = input.assembly()?;
        Ok(RunDir {
            set,
            output: output.map(Path::to_path_buf),
            dir: work.path().to_path_buf(),
            _work: work,
            asm,
            t0: std::time::Instant::now(),
        })
    }

    /// The first line of `command`'s run: the input's size and where it runs, then `tail`.
    fn announce(&self, command: &str, tail: &str) {
        println!(
            "{command}: {} particles, {} bonds; runs in {}{tail}",
            self.asm.packing.len(),
            self.asm.bonds.len(),
            self.dir.display()
        );
    }

    /// A progress line on stderr with the seconds since the run started.
    fn progress(&self, m: &str) {
        eprintln!("[{:7.1} s] {m}", self.t0.elapsed().as_secs_f64());
    }

    /// With an `output`: the report files written by `write` into the staged directory,
    /// moved into place, and listed.
    fn keep(self, write: impl FnOnce(&Path) -> Result<Vec<PathBuf>>) -> Result<()> {
        if let Some(out) = &self.output {
            let files = write(&self.dir)?;
            self.set.commit()?;
            println!();
            super::output::print_written("wrote ", &files, &self.dir, out);
        }
        Ok(())
    }
}

/// The end of every validation (its files already written): [`Error::OutOfTolerance`]
/// naming the failed checks; else [`Error::NotConverged`] when a compared run had not
/// settled (its checks not judged: neither a pass nor a failure, so not a success either);
/// else exit 0.
fn finish<D>(name: &str, report: &Report<D>) -> Result<()> {
    for line in &unsettled_lines(report) {
        println!("not judged: {line}");
    }
    outcome(name, report)?;
    println!("PASSED: {name} and anisobond agree within every tolerance");
    Ok(())
}

/// Every `validate ENGINE` in its [`RunDir`] (options checked, the bonded input read): the
/// engine run in the staged output (a temporary directory, removed, without one) with one
/// progress line per stage, the summary printed, the report files written and moved into place, and the
/// end ([`finish`]): exit 0 when every check is within its tolerance, else
/// [`Error::OutOfTolerance`] naming the failed checks, else [`Error::NotConverged`] when a
/// compared run had not settled (an engine that failed has ended earlier with
/// [`Error::EngineFailed`]).
fn run_engine<E: Engine>(engine: &E, run: RunDir) -> Result<()> {
    let name = E::Details::ENGINE;
    let moved = run.output.as_ref().map_or(String::new(), |o| {
        format!(" (moved to {} when done)", o.display())
    });
    run.announce(&format!("validate {name}"), &moved);
    let problem = Problem::of(&run.dir, &run.asm);
    let report = validate(engine, &problem, &|m| run.progress(m))?;
    print!("{}", summary(&report));
    run.keep(|dir| engine.write_files(dir, &report))?;
    finish(name, &report)
}
