//! `anisobond validate yade PACKING --model MODEL [-o DIR]`: the same problem in YADE and in
//! anisobond, the differences as a table with units, files in DIR, and a non-zero exit
//! status when any agreement is outside its tolerance.

use anisobond::assembly::Assembly;
use anisobond::export::yade::parse_paths;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::tensor::Stiffness6;
use anisobond::validate::harness::{checks_table, failure_lines, unsettled_lines, Report};
use anisobond::validate::yade::{
    validate_yade, write_validation_files, Tolerances, YadeValidation, YadeValidationOptions,
};
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
    pub input: super::cell::BondedInput,
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
}

/// Run `validate`.
pub fn run(a: ValidateArgs) -> Result<()> {
    match a.target {
        ValidateTarget::Yade(y) => validate_yade_cmd(y),
        ValidateTarget::Liggghts(a) => super::validate_liggghts::run(a),
        ValidateTarget::Lammps(a) => super::validate_lammps::run(a),
    }
}

fn validate_yade_cmd(a: YadeValidateArgs) -> Result<()> {
    let opts = YadeValidationOptions {
        strain: a.strain,
        density: a.density,
        time_step: a.dt,
        safety: a.safety,
        undamped_steps: a.undamped_steps,
        undamped_paths: parse_paths(&a.undamped_paths)?,
        damped_steps: a.damped_steps,
        damping: a.damping,
        cg_tolerance: a.cg_tolerance,
        tolerances: Tolerances {
            history: a.history_tolerance,
            tensor: a.tensor_tolerance,
            relaxed: a.relaxed_tolerance,
        },
    };
    opts.validate()?;
    let mut set = OutputSet::new(&a.input.paths());
    let staged = set.optional_dir(a.output.as_deref())?;
    let model = Model::from_path(&a.input.model)?;
    let Assembly {
        packing,
        bonds: b,
        springs: k,
        ..
    } = super::cell::assembly_with(&a.input.packing, model.clone(), &a.input.model)?;
    let temp;
    let dir = match &staged {
        Some(d) => d.clone(),
        None => {
            temp = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
            temp.path().to_path_buf()
        }
    };
    eprintln!(
        "validate yade: {} particles, {} bonds; running YADE and anisobond …",
        packing.len(),
        b.len()
    );
    let v = validate_yade(&dir, &packing, &b, &k, Some(&model), &opts, &|m: &str| {
        eprintln!("  {m}")
    })?;
    print_table(&v);
    if let Some(out) = &a.output {
        let written = write_validation_files(&dir, &v)?;
        set.commit()?;
        super::output::print_written("wrote ", &written, &dir, out);
        println!(
            "YADE export and YADE's own outputs: {}",
            super::output::final_path(&v.yade_dir, &dir, out).display()
        );
    }
    verdict(
        &v,
        "PASSED: YADE and anisobond agree within every tolerance",
        |failures| {
            format!(
                "validate yade FAILED ({} of {} checks out of tolerance):\n  {}",
                failures.len(),
                v.checks.len(),
                failures.join("\n  ")
            )
        },
    )
}

/// The end of a validation: `passed` printed when every check of `report` is within its
/// tolerance, else the error that `failed` words from the lines of the failed checks.
fn verdict<D>(
    report: &Report<D>,
    passed: &str,
    failed: impl FnOnce(&[String]) -> String,
) -> Result<()> {
    let failures = failure_lines(report);
    if failures.is_empty() {
        println!("{passed}");
        Ok(())
    } else {
        Err(Error::OutOfTolerance {
            failed: failures.len(),
            checks: report.checks.len(),
            message: failed(&failures),
        })
    }
}

fn gpa_row(c: &Stiffness6, i: usize) -> String {
    (0..6)
        .map(|j| format!("{:9.4}", c[(i, j)] / 1e9))
        .collect::<Vec<_>>()
        .join(" ")
}

fn print_table(v: &YadeValidation) {
    let o = &v.options;
    println!(
        "YADE {} vs anisobond: {} particles, {} bonds, dt {:.4e} s (critical estimate {:.4e} s), \
         density {} kg/m³, strain {:e} in one step",
        v.yade_version,
        v.n_particles,
        v.n_bonds,
        v.time_step,
        v.critical_time_step,
        o.density,
        o.strain
    );
    println!();
    println!(
        "undamped stress histories ({} steps, damping 0):",
        o.undamped_steps
    );
    println!(
        "  {:<6} {:>14} {:>16} {:>12} {:>11}",
        "path", "max |σ| (Pa)", "max |Δσ| (Pa)", "relative", "worst step"
    );
    for h in &v.undamped {
        println!(
            "  {:<6} {:>14.4e} {:>16.4e} {:>12.3e} {:>11}",
            h.label, h.max_stress, h.max_difference, h.relative, h.worst_step
        );
    }
    println!();
    println!(
        "damped element tests (Cundall {}, {} steps per path, C = S·E⁻¹), GPa, Voigt 11 22 33 23 13 12:",
        o.damping, o.damped_steps
    );
    for (name, c) in [
        ("YADE", &v.c_yade),
        ("anisobond", &v.c_anisobond),
        ("relaxed", &v.c_relaxed),
    ] {
        println!("  {name}:");
        for i in 0..6 {
            println!("    {}", gpa_row(c, i));
        }
    }
    println!();
    print!("{}", checks_table(v));
    println!();
    let times: Vec<String> = v
        .timings
        .iter()
        .map(|t| format!("{} {:.2}", t.stage, t.seconds))
        .collect();
    println!("time (s): {}", times.join(", "));
}

/// The end of `validate liggghts|lammps`: the tensors' diagonal and C12 (GPa), the wall times,
/// the files written (named under `output`), and an error listing the checks outside their
/// tolerance.
pub(super) fn finish<D>(
    engine: &str,
    report: &Report<D>,
    tensors: &[(String, Stiffness6)],
    files: &[PathBuf],
    staged: &Path,
    output: &Path,
) -> Result<()> {
    let gpa = |c: &Stiffness6, i: usize, j: usize| c[(i, j)] / 1e9;
    println!("\nC11 C22 C33 C12 C44 C55 C66 (GPa):");
    for (name, c) in tensors {
        println!(
            "  {name:<14} {:9.4} {:9.4} {:9.4} {:9.4} {:9.4} {:9.4} {:9.4}",
            gpa(c, 0, 0),
            gpa(c, 1, 1),
            gpa(c, 2, 2),
            gpa(c, 0, 1),
            gpa(c, 3, 3),
            gpa(c, 4, 4),
            gpa(c, 5, 5)
        );
    }
    println!("\nwall time:");
    for t in &report.timings {
        println!("  {:<40} {:8.2} s", t.stage, t.seconds);
    }
    println!();
    super::output::print_written("wrote ", files, staged, output);
    for line in unsettled_lines(report) {
        println!("not judged: {line}");
    }
    verdict(report, "all checks within tolerance", |failed| {
        format!(
            "validate {engine}: {} check(s) outside tolerance: {}",
            failed.len(),
            failed.join("; ")
        )
    })
}
