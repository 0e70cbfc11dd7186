//! `anisobond validate liggghts PACKING --model MODEL [-o DIR] [--np N]`: the same bonded
//! packing in the LIGGGHTS driver, the stock LIGGGHTS harmonic deck, the reference
//! integrator and the relaxed solver; a table of the differences, files in DIR, and a
//! non-zero exit naming the checks outside tolerance.

use anisobond::export::liggghts::which;
use anisobond::validate::liggghts::{Liggghts, Programs, ValidateOptions};
use anisobond::validate::Tolerances;
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
    /// The specimen or the strength test instead of the element tests.
    #[command(flatten)]
    pub tests: super::validate_strength::FreeTestFlags,
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

impl Args {
    /// The LIGGGHTS engine with these programs and settings.
    pub fn engine(&self) -> Result<Liggghts> {
        let t = ValidateOptions::default().tolerances;
        Ok(Liggghts {
            programs: Programs {
                driver: find_driver(self.driver.clone())?,
                liggghts: self.liggghts.clone(),
            },
            options: ValidateOptions {
                density: self.density,
                timestep: self.timestep,
                history_steps: self.history_steps,
                relax_steps: self.relax_steps,
                processes: self.np as usize,
                tolerances: Tolerances {
                    history: self.history_tolerance,
                    tensor: self.tensor_tolerance,
                    relaxed: self.tensor_tolerance,
                    ..t
                },
                ..ValidateOptions::default()
            },
        })
    }
}
