//! `anisobond calibrate-strength`: the `[strength]` table's scale(s) that make the virtual
//! laboratory reach a target tensile strength (one or two directions) or UCS on the packing
//! ([`anisobond::calibrate::calibrate_strength`]); writes the calibrated model file.

use super::strength_test::LabArgs;
use anisobond::calibrate::{
    calibrate_strength, StrengthCalibration, StrengthCalibrationOptions,
    StrengthCalibrationProgress, StrengthTarget,
};
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::study::OptionNames;
use anisobond::{Error, Result};
use std::path::PathBuf;

/// The defaults (the library's, once).
fn d() -> StrengthCalibrationOptions {
    StrengthCalibrationOptions::default()
}

/// Options of `anisobond calibrate-strength`.
#[derive(clap::Args)]
pub struct CalibrateStrengthArgs {
    /// Model file (TOML or JSON) with a [strength] table: its values are the starting point
    /// and their ratios are kept; bonding and stiffness are used as they are.
    #[arg(long)]
    model: PathBuf,
    /// Target: `tension=…` (direct tension along z at --bedding-deg), `ucs=…`, or
    /// `tension-along=…,tension-across=…` (along and across the [strength] axis); Pa, or
    /// with a unit suffix kPa/MPa/GPa.
    #[arg(long)]
    target: String,
    /// Calibrated model file to write: JSON when it ends in `.json`, TOML otherwise.
    #[arg(short, long)]
    output: PathBuf,
    /// The calibration's report (JSON): fitted scales and table, the verification run's
    /// measured peaks, every iteration.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Relative tolerance on every peak, |P/T − 1|.
    #[arg(long, default_value_t = d().tolerance)]
    tolerance: f64,
    /// Iterations allowed (one lab run per target value each), before the verification run.
    #[arg(long, default_value_t = d().max_iterations)]
    max_iterations: usize,
    /// The specimens, their loading and the generated packing (as `strength-test`'s; the
    /// bedding angle applies to a tension or ucs target, and is set from the axis for
    /// tension-along/tension-across).
    #[command(flatten)]
    lab: LabArgs,
}

impl CalibrateStrengthArgs {
    fn options(&self) -> Result<StrengthCalibrationOptions> {
        Ok(StrengthCalibrationOptions {
            lab: self.lab.options(d().lab.test, None)?,
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
        })
    }
}

fn print_summary(c: &StrengthCalibration) {
    let list = |v: &[f64], f: &dyn Fn(f64) -> String| -> String {
        v.iter().map(|&x| f(x)).collect::<Vec<_>>().join(", ")
    };
    println!(
        "calibrated ({}): fitted {} = {}; {} iterations, {} lab runs (verification included)",
        c.kind,
        c.parameters.join(", "),
        list(&c.fitted_scale, &|x| format!("{x:.6}")),
        c.iterations,
        c.runs
    );
    let s = &c.fitted_strength;
    println!(
        "  fitted [strength.bond] tensile = {:.6e} Pa, cohesion = {:.6e} Pa",
        s.bond.tensile, s.bond.cohesion
    );
    if let Some(a) = &s.along {
        println!(
            "  fitted [strength.along] tensile = {:.6e} Pa, cohesion = {:.6e} Pa",
            a.tensile, a.cohesion
        );
    }
    println!(
        "  {:<16} {:>8} {:>14} {:>14} {:>9}",
        "", "β (°)", "target Pa", "measured Pa", "error"
    );
    for (k, name) in c.targets.iter().enumerate() {
        println!(
            "  {:<16} {:>8.2} {:>14.6e} {:>14.6e} {:>+8.3} %",
            name,
            c.bedding_deg[k],
            c.target_pa[k],
            c.measured_peak_pa[k],
            100.0 * c.measured_relative_error[k]
        );
    }
    println!("  (measured: the verification run of the calibrated model as written)");
}

/// Run `anisobond calibrate-strength`.
pub fn run(a: CalibrateStrengthArgs) -> Result<()> {
    let base = Model::from_path(&a.model)?;
    let target = StrengthTarget::parse(&a.target)?;
    let opts = a.options()?;
    let inputs: Vec<&std::path::Path> = [a.lab.packing.as_deref(), Some(a.model.as_path())]
        .into_iter()
        .flatten()
        .collect();
    let mut out = OutputSet::new(&inputs);
    let staged = out.file(&a.output)?;
    let staged_report = out.optional_file(a.report.as_deref())?;
    let cal = calibrate_strength(&base, &target, &opts, OptionNames::Flags, &|p| match p {
        StrengthCalibrationProgress::Run {
            run,
            target,
            scale,
            peak_pa,
            target_pa,
            failed,
            verification,
        } => println!(
            "run {run}{}: {target} scale {scale:.6} peak {peak_pa:.6e} Pa (target {target_pa:.6e} Pa, {:+.3} %){}",
            if verification { " (verification)" } else { "" },
            100.0 * (peak_pa / target_pa - 1.0),
            if failed { "" } else { ", did not fail" }
        ),
    })
    .map_err(|e| match e {
        Error::Model(m) => Error::Model(format!("{}: {m}", a.model.display())),
        other => other,
    })?;
    print_summary(&cal);
    // Round trip: the written file must read back as the verified model.
    let text = cal.model.to_string_for(&a.output);
    if Model::from_str_for(&text, &a.output)? != cal.model {
        return Err(Error::Invalid(format!(
            "{}: the calibrated model does not read back as the one verified",
            a.output.display()
        )));
    }
    anisobond::io::write_string_atomic(&staged, &text)?;
    if let Some(r) = &staged_report {
        anisobond::io::write_string_atomic(r, &(cal.to_json()? + "\n"))?;
    }
    out.commit()?;
    println!("wrote {}", a.output.display());
    if let Some(r) = &a.report {
        println!("wrote {}", r.display());
    }
    Ok(())
}
