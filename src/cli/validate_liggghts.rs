//! `anisobond validate liggghts PACKING --model MODEL [-o DIR] [--np N]`: the same bonded
//! packing in the LIGGGHTS driver, the stock LIGGGHTS harmonic deck, the reference
//! integrator and the relaxed solver; a table of the differences, files in DIR, and a
//! non-zero exit naming the checks outside tolerance.

use anisobond::export::liggghts::which;
use anisobond::io::OutputSet;
use anisobond::validate::harness::checks_table;
use anisobond::validate::liggghts::{validate_liggghts, write_report, Programs, ValidateOptions};
use anisobond::{Error, Result};
use std::path::PathBuf;

/// Validate the LIGGGHTS driver against the reference integrator and the relaxed solver.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub input: super::cell::BondedInput,
    /// Output directory: report.json, checks.csv, undamped_history.csv, tensors.csv,
    /// driver_stress_strain.png, and one sub-directory per LIGGGHTS run.
    #[arg(short, long, default_value = "validate-liggghts")]
    pub output: PathBuf,
    /// MPI processes of the parallel driver runs: 1 (skips the MPI checks) or 2 (the rank
    /// count the MPI checks are established for; LIGGGHTS 3.8 runs only the normal load cases
    /// under MPI).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=2))]
    pub np: u32,
    /// The driver program; default: `anisobond-liggghts` on PATH, else `target/cpp/` next
    /// to this executable (built by `make -C cpp`).
    #[arg(long)]
    pub driver: Option<PathBuf>,
    /// The stock LIGGGHTS program.
    #[arg(long, default_value = "liggghts")]
    pub liggghts: PathBuf,
    /// Particle density (kg/m³).
    #[arg(long, default_value_t = 2500.0)]
    pub density: f64,
    /// Time step (s); default: 0.3 of the stiffest particle's period bound.
    #[arg(long)]
    pub timestep: Option<f64>,
    /// Steps of the undamped history comparison.
    #[arg(long, default_value_t = 1000)]
    pub history_steps: u64,
    /// Steps LIGGGHTS holds each strain increment (damped relaxation).
    #[arg(long, default_value_t = 10_000)]
    pub relax_steps: u64,
    /// Tolerance of the undamped histories (relative).
    #[arg(long, default_value_t = 1e-6)]
    pub history_tolerance: f64,
    /// Tolerance of the quasi-static tensors (relative).
    #[arg(long, default_value_t = 5e-3)]
    pub tensor_tolerance: f64,
}

fn find_driver(given: Option<PathBuf>) -> Result<PathBuf> {
    if let Some(p) = given {
        return Ok(p);
    }
    if which("anisobond-liggghts") {
        return Ok("anisobond-liggghts".into());
    }
    let beside = std::env::current_exe().ok().and_then(|exe| {
        exe.parent()
            .and_then(|d| d.parent())
            .map(|t| t.join("cpp").join("anisobond-liggghts"))
    });
    match beside {
        Some(p) if p.is_file() => Ok(p),
        _ => Err(Error::Invalid(
            "the LIGGGHTS driver anisobond-liggghts was not found on PATH nor in target/cpp/: \
             build it with `make -C cpp` (needs liggghts libliggghts-dev mpi-default-dev) or \
             pass --driver PATH"
                .into(),
        )),
    }
}

/// Run the command.
pub fn run(a: Args) -> Result<()> {
    let mut set = OutputSet::new(&a.input.paths());
    let dir = set.dir(&a.output)?;
    let programs = Programs {
        driver: find_driver(a.driver)?,
        liggghts: a.liggghts,
    };
    let asm = a.input.assembly()?;
    let (packing, bonds, k) = (&asm.packing, &asm.bonds, &asm.springs);
    let opts = ValidateOptions {
        density: a.density,
        timestep: a.timestep,
        history_steps: a.history_steps,
        relax_steps: a.relax_steps,
        processes: a.np as usize,
        history_tolerance: a.history_tolerance,
        tensor_tolerance: a.tensor_tolerance,
        ..ValidateOptions::default()
    };
    println!(
        "validate liggghts: {} particles, {} bonds; runs in {} (moved to {} when done)",
        packing.len(),
        bonds.len(),
        dir.display(),
        a.output.display()
    );
    let t0 = std::time::Instant::now();
    let report = validate_liggghts(&dir, packing, bonds, k, &programs, &opts, &mut |stage| {
        println!("[{:7.1} s] {stage}", t0.elapsed().as_secs_f64())
    })?;
    println!("time step {:.4e} s\n", report.time_step);
    println!("relative differences (dimensionless; stresses in Pa, tensors in Pa):");
    print!("{}", checks_table(&report));
    let tensors = [
        ("driver", report.driver_tensor),
        ("integrator", report.integrator_tensor),
        ("relaxed", report.relaxed_tensor),
    ]
    .map(|(name, c)| (name.to_string(), c));
    let files = write_report(&dir, &report)?;
    set.commit()?;
    super::validate::finish("liggghts", &report, &tensors, &files, &dir, &a.output)
}
