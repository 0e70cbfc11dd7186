//! `anisobond stress-test`: Šmilauer's stress-controlled element tests with the
//! reference integrator — three unconfined uniaxial tests under servo-controlled zero lateral
//! stress and three strain-controlled pure shears — printing the engineering constants, the
//! orthotropic and the transversely isotropic (about z) stiffness, and writing the
//! orthotropic tensor as a SPEC JSON report.

use super::run::{check_damping, check_max_steps, check_positive, LawArg, StepArgs};
use anisobond::dem::{
    ServoOptions, StressControlledResult, StressTestOptions, DEFAULT_UNBALANCED_TOLERANCE,
};
use anisobond::homogenize::TensorReport;
use anisobond::io::OutputSet;
use anisobond::{Error, Result};
use std::path::PathBuf;

/// Arguments of `anisobond stress-test`.
#[derive(clap::Args, Clone, Debug)]
pub struct StressTestArgs {
    #[command(flatten)]
    pub input: super::cell::BondedInput,
    /// Bond law.
    #[arg(long, value_enum, default_value_t = LawArg::Yade)]
    pub law: LawArg,
    /// Prescribed axial strain ε̂ of the uniaxial tests (half the engineering strain of the
    /// shears); the paper uses −0.01.
    #[arg(long, default_value_t = -1e-5, allow_hyphen_values = true)]
    pub strain: f64,
    /// Relative lateral-stress tolerance t_r (|σ_lateral| < t_r·|σ_axial|).
    #[arg(long, default_value_t = 1e-3)]
    pub stress_tolerance: f64,
    /// Steadiness: relative stress change over 10 steps.
    #[arg(long, default_value_t = 1e-7)]
    pub tolerance: f64,
    /// Equilibrium: largest unbalanced force and torque (mean resultant over mean bond
    /// force/torque, as YADE's unbalancedForce) at which a test counts as converged.
    #[arg(long, default_value_t = DEFAULT_UNBALANCED_TOLERANCE)]
    pub unbalanced_tolerance: f64,
    /// Servo gain in (0, 1] on the predicted stress error.
    #[arg(long, default_value_t = 0.5)]
    pub gain: f64,
    /// Largest strain increment per step (ramps large strains; default: none).
    #[arg(long)]
    pub max_strain_increment: Option<f64>,
    /// Step limit per test; a test not converged within it is an error.
    #[arg(long, default_value_t = 50_000)]
    pub max_steps: usize,
    /// Cundall local damping λ.
    #[arg(long, default_value_t = 0.4)]
    pub damping: f64,
    #[command(flatten)]
    pub step: StepArgs,
    /// Tensor report (SPEC JSON) of the orthotropic stiffness.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Check every option before any work, with messages naming the option.
fn validate(a: &StressTestArgs) -> Result<()> {
    if !(a.strain.is_finite() && a.strain != 0.0 && a.strain.abs() < 0.1) {
        return Err(Error::Invalid(format!(
            "--strain must be non-zero with |ε̂| < 0.1, got {}",
            a.strain
        )));
    }
    check_positive("--stress-tolerance", a.stress_tolerance)?;
    check_positive("--tolerance", a.tolerance)?;
    check_positive("--unbalanced-tolerance", a.unbalanced_tolerance)?;
    if !(a.gain.is_finite() && a.gain > 0.0 && a.gain <= 1.0) {
        return Err(Error::Invalid(format!(
            "--gain must be in (0, 1], got {}",
            a.gain
        )));
    }
    if let Some(m) = a.max_strain_increment {
        check_positive("--max-strain-increment", m)?;
    }
    check_max_steps(a.max_steps)?;
    check_damping(a.damping)?;
    a.step.validate()
}

/// Axis names of the uniaxial tests.
const AXES: [&str; 3] = ["x", "y", "z"];
/// Shear components of the pure shears (Voigt 4, 5, 6).
const SHEARS: [&str; 3] = ["yz", "xz", "xy"];

/// Run the stress-controlled tests, print the moduli and write the report.
pub fn run(a: StressTestArgs) -> Result<()> {
    validate(&a)?;
    let mut out = OutputSet::new(&a.input.paths());
    let staged = out.optional_file(a.output.as_deref())?;
    let asm = a.input.assembly()?;
    let dem = a.step.dem_options(a.damping);
    let opts = StressTestOptions {
        strain: a.strain,
        local_damping: a.damping,
        servo: ServoOptions {
            gain: a.gain,
            stress_tolerance: a.stress_tolerance,
            steady_tolerance: a.tolerance,
            unbalanced_tolerance: a.unbalanced_tolerance,
            max_steps: a.max_steps,
            max_strain_increment: a.max_strain_increment.unwrap_or(f64::INFINITY),
            ..Default::default()
        },
    };
    let bar = super::output::progress_bar("stress tests");
    let result = asm.stress_tests(a.law.into(), &dem, &opts, &|f: f64| {
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
    });
    bar.finish_and_clear();
    let r = result?;
    eprintln!(
        "time step {:.4e} s (critical estimate {:.4e} s)",
        r.time_step, r.critical_time_step
    );
    print_moduli(&a, &r);
    let report = TensorReport::new(
        "stress-controlled",
        r.c_orthotropic,
        Some((&asm.packing, &asm.bonds)),
    )?;
    println!("orthotropic stiffness (GPa; Voigt order 11 22 33 23 13 12):");
    for row in &report.c {
        let cells: Vec<String> = row.iter().map(|v| format!("{:10.4}", v / 1e9)).collect();
        println!("  {}", cells.join(" "));
    }
    if let (Some(path), Some(shown)) = (&staged, &a.output) {
        let engineering = engineering_json(a.strain, &r);
        super::output::write_json_with(path, &report, vec![("engineering", engineering)])?;
        out.commit()?;
        println!("wrote {}", shown.display());
    }
    Ok(())
}

/// Print the engineering constants measured: Young's moduli and Poisson ratios of the
/// uniaxial tests, the shear moduli, the reciprocity check and the transversely isotropic
/// fit about z.
fn print_moduli(a: &StressTestArgs, r: &StressControlledResult) {
    println!(
        "unconfined uniaxial tests (ε̂ = {:e}, lateral stress < {:.0e}·axial):",
        a.strain, a.stress_tolerance
    );
    for u in &r.uniaxial {
        let others: Vec<String> = (0..3)
            .filter(|&j| j != u.axis)
            .map(|j| format!("ν_{}{} = {:.4}", AXES[u.axis], AXES[j], u.poisson[j]))
            .collect();
        println!(
            "  E_{} = {:10.4} MPa, {}  ({} steps, |σ_lat|/|σ_ax| = {:.1e}, unbalanced force \
             {:.1e})",
            AXES[u.axis],
            u.young / 1e6,
            others.join(", "),
            u.outcome.steps,
            u.outcome.relative_stress_error,
            u.outcome.unbalance.force
        );
    }
    println!("pure shears (strain-controlled):");
    for g in &r.shear {
        println!(
            "  G_{} = {:10.4} MPa  ({} steps, unbalanced force {:.1e})",
            SHEARS[g.component - 3],
            g.modulus / 1e6,
            g.outcome.steps,
            g.outcome.unbalance.force
        );
    }
    println!(
        "reciprocity ν_ij/E_i vs ν_ji/E_j: largest relative mismatch {:.2e}",
        r.reciprocity_mismatch
    );
    let [c11, c12, c13, c33, c44] = r.cross_anisotropic.map(|x| x / 1e6);
    println!(
        "transversely isotropic about z (MPa): C11 {c11:.3}, C33 {c33:.3}, C13 {c13:.3}, \
         C12 {c12:.3}, C44 {c44:.3}"
    );
}

/// The measured engineering constants (Pa, dimensionless) added to the SPEC tensor report
/// as its `engineering` object.
fn engineering_json(strain: f64, r: &StressControlledResult) -> serde_json::Value {
    let mut young = serde_json::Map::new();
    let mut poisson = serde_json::Map::new();
    for u in &r.uniaxial {
        young.insert(format!("E_{}", AXES[u.axis]), u.young.into());
        for j in (0..3).filter(|&j| j != u.axis) {
            poisson.insert(
                format!("nu_{}{}", AXES[u.axis], AXES[j]),
                u.poisson[j].into(),
            );
        }
    }
    let shear: serde_json::Map<String, serde_json::Value> = r
        .shear
        .iter()
        .map(|g| (format!("G_{}", SHEARS[g.component - 3]), g.modulus.into()))
        .collect();
    serde_json::json!({
        "units": "Pa (moduli); Poisson ratios dimensionless, nu_ij = −ε_j/ε_i under σ_i",
        "strain": strain,
        "young": young,
        "poisson": poisson,
        "shear": shear,
        "reciprocity_mismatch": r.reciprocity_mismatch,
        "transverse_isotropic_z": {"C11": r.cross_anisotropic[0], "C12": r.cross_anisotropic[1],
            "C13": r.cross_anisotropic[2], "C33": r.cross_anisotropic[3], "C44": r.cross_anisotropic[4]},
    })
}
