//! `anisobond calibrate`: scheme parameters that reproduce a target tensor (docs/formats.md), at the
//! mean-field level (no packing) or on the user's packing with the exact relaxed solver.

use super::LeverArmArg;
use anisobond::assembly::Assembly;
use anisobond::calibrate::ManyBodyCalibration;
use anisobond::calibrate::{calibrate, CalibrateOn, Calibration, CrossCalibration};
use anisobond::calibrate::{CubicCalibration, CubicOptions, CubicTarget, Family, Level, Target};
use anisobond::homogenize::RelaxedOptions;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::schemes::CubicModel;
use anisobond::{Error, Result};
use clap::ValueEnum;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which of the equivalent cubic parameter sets to return.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum FamilyArg {
    /// Nearest a_n = a_s = 1 (least microscopic heterogeneity; distance in ln a).
    Nearest,
    /// On the equi-anisotropy plane a_n = a_s.
    Equi,
    /// Prolate normal-stiffness spheroids (a_n ≥ 1), nearest a_n = a_s = 1.
    Prolate,
    /// Oblate normal-stiffness spheroids (a_n ≤ 1), nearest a_n = a_s = 1.
    Oblate,
}

impl From<FamilyArg> for Family {
    fn from(f: FamilyArg) -> Self {
        match f {
            FamilyArg::Nearest => Family::Nearest,
            FamilyArg::Equi => Family::Equi,
            FamilyArg::Prolate => Family::Prolate,
            FamilyArg::Oblate => Family::Oblate,
        }
    }
}

/// Which cubic model to use.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum CubicModelArg {
    /// By the target's Zener ratio: > 1 zener-above-1, < 1 zener-below-1.
    Auto,
    /// k_n on the four <111> spheroids, k_s on the three <100>.
    ZenerAbove1,
    /// k_n on the three <100> spheroids, k_s on the four <111>.
    ZenerBelow1,
}

/// Options of `anisobond calibrate`.
#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// Model file (TOML or JSON): scheme kind, geometry and bonding; the scheme parameters
    /// are replaced by the calibrated ones.
    #[arg(long)]
    model: PathBuf,
    /// Target: `C11=…,C12=…,C44=…` (Pa, or with a unit suffix GPa/MPa/kPa), the ratios
    /// `C12/C11=…,C44/C11=…`, or for cross-anisotropy `C11=…,C33=…,C13=…,C12=…[,C44=…]`.
    /// A stable target the springs cannot reach gets a `[manybody]` term.
    #[arg(long)]
    target: String,
    /// Level: `mean-field` (no packing; a PACKING after it only supplies the bond density
    /// for absolute targets) or `relaxed PACKING` (the exact relaxed tensor of that packing).
    #[arg(long, num_args = 1..=2, value_names = ["LEVEL", "PACKING"], default_values_t = ["mean-field".to_string()])]
    on: Vec<String>,
    /// Calibrated model file to write: JSON when it ends in `.json`, TOML otherwise.
    #[arg(short, long)]
    output: PathBuf,
    /// Cubic: which of the equivalent parameter sets (Truszkowska 2018 Sec. 6.3).
    #[arg(long, value_enum, default_value_t = FamilyArg::Nearest)]
    family: FamilyArg,
    /// Cubic: use the extended <110> models (Sec. 6.1); default: the model file's setting.
    #[arg(long)]
    extended: bool,
    /// Cubic: which model.
    #[arg(long, value_enum, default_value_t = CubicModelArg::Auto)]
    cubic_model: CubicModelArg,
    /// Relaxed level: relative tolerance on every calibrated ratio/constant.
    #[arg(long, default_value_t = 5e-4)]
    tolerance: f64,
    /// Relaxed level: maximum number of relaxed solves.
    #[arg(long, default_value_t = 30)]
    max_iterations: usize,
    /// Relaxed level: contact point (lever arm) of the bonds.
    #[arg(long, value_enum, default_value_t = LeverArmArg::MidGap)]
    lever_arm: LeverArmArg,
    /// Mean field without a packing (absolute targets).
    #[command(flatten)]
    spheres: super::EqualSphereArgs,
}

fn load_model(path: &Path) -> Result<Model> {
    Model::from_path(path)
}

fn row(name: &str, target: f64, achieved: f64) {
    let err = if target != 0.0 {
        format!("{:+.3} %", 100.0 * (achieved - target) / target.abs())
    } else {
        "—".into()
    };
    println!(
        "  {name:<8} {:>12.4} {:>12.4} {:>10}",
        target / 1e9,
        achieved / 1e9,
        err
    );
}

fn ratio_row(name: &str, target: f64, achieved: f64) {
    println!(
        "  {name:<8} {:>12.4} {:>12.4} {:>+9.3} %",
        target,
        achieved,
        100.0 * (achieved - target) / target.abs()
    );
}

fn print_cubic(cal: &CubicCalibration, secs: f64) {
    let p = cal.parameters;
    println!(
        "calibrated ({}): cubic {}{}, a_n = {:.6}, a_s = {:.6}, shear/normal = {:.6}; normal = {:.6e}, shear = {:.6e} (unit of the geometry convention)",
        match cal.level {
            Level::MeanField => "mean field",
            Level::Relaxed => "relaxed, on the packing",
        },
        p.model.as_str(),
        if p.extended { " (extended)" } else { "" },
        p.a_n,
        p.a_s,
        p.shear_over_normal,
        cal.normal,
        cal.shear
    );
    println!(
        "  distance from a_n = a_s = 1: √((ln a_n)² + (ln a_s)²) = {:.4}",
        p.log_distance()
    );
    if let Some(s) = cal.mean_field_start {
        println!(
            "  started from the mean-field solution a_n = {:.4}, a_s = {:.4}, shear/normal = {:.4}; {} relaxed solves, CG iterations {:?}",
            s.a_n,
            s.a_s,
            s.shear_over_normal,
            cal.history.len(),
            cal.history.iter().map(|h| h.cg_iterations).collect::<Vec<_>>()
        );
    }
    let (t11, t12, t44) = cal.target_constants();
    let a = &cal.achieved_cubic;
    println!(
        "  {:<8} {:>12} {:>12} {:>10}",
        "", "target GPa", "achieved GPa", "error"
    );
    row("C11", t11, a.c11);
    row("C12", t12, a.c12);
    row("C44", t44, a.c44);
    ratio_row("C12/C11", cal.target.c12_over_c11, a.c12 / a.c11);
    ratio_row("C44/C11", cal.target.c44_over_c11, a.c44 / a.c11);
    ratio_row("Zener", cal.target.zener(), a.zener);
    if cal.target.c11.is_none() {
        println!(
            "  (ratio target: C11 is the achieved one, set by the model file's normal magnitude)"
        );
    }
    println!(
        "  cubic symmetry of the achieved tensor: spread {}, off-symmetry terms {:.3e} GPa",
        super::output::spread_gpa(&a.uncertainty),
        a.uncertainty.zero_terms / 1e9
    );
    println!("  time {secs:.2} s");
}

/// Run `anisobond calibrate`.
pub fn run(a: CalibrateArgs) -> Result<()> {
    let base = load_model(&a.model)?;
    let target = Target::parse(&a.target)?;
    let (relaxed, packing_path) = calibration_level(&a.on)?;
    let inputs = super::output::inputs(packing_path.as_deref(), &a.model);
    let mut out = OutputSet::new(&inputs);
    let staged = out.file(&a.output)?;
    let bonded = match &packing_path {
        Some(p) => {
            let pk = super::cell::read(p)?;
            Some(Assembly::new(pk, base.clone()).map_err(|e| match e {
                Error::Model(m) => Error::Model(format!("{}: {m}", a.model.display())),
                other => other,
            })?)
        }
        None => None,
    };
    let on = match (&bonded, relaxed) {
        (Some(b), true) => CalibrateOn::Relaxed(b),
        (Some(b), false) => CalibrateOn::MeanFieldOf(b),
        (None, _) => CalibrateOn::MeanField(a.spheres.equal_spheres(&base.geometry)?),
    };
    let opts = cubic_options(&a);
    if let Target::Cubic(t) = &target {
        print_cubic_target(t, bonded.as_ref().filter(|_| relaxed));
    }
    let start = Instant::now();
    let calibrated = calibrate(&base, &target, on, &opts)?;
    let secs = start.elapsed().as_secs_f64();
    let (from, to) = (base.scheme.kind_name(), calibrated.model.scheme.kind_name());
    if from != to {
        println!(
            "note: {} has kind = \"{from}\"; the target needs the {to} scheme, so {} is written with kind = \"{to}\"",
            a.model.display(),
            a.output.display()
        );
    }
    match &calibrated.calibration {
        Calibration::Cubic(cal) => print_cubic(cal, secs),
        Calibration::CrossRelaxed(cal) => print_cross(cal, secs),
        Calibration::ManyBody(cal) => print_many_body(cal, secs),
        Calibration::CrossMeanField => println!("calibrated (mean field): cross-anisotropic; Šmilauer's inversion E′ = A⁻¹C/μ reproduces the target exactly under uniform strain, so the model holds the target itself. Its relaxed tensor on a packing is a few % softer: use --on relaxed PACKING to correct for that."),
    }
    // Round trip: the written file must read back as the same model.
    let text = calibrated.model.to_string_for(&a.output);
    Model::from_str_for(&text, &a.output)?;
    anisobond::io::write_string_atomic(&staged, &text)?;
    out.commit()?;
    println!("wrote {}", a.output.display());
    Ok(())
}

/// `--on`: `mean-field` (default) or `relaxed PACKING`; whether relaxed, and the packing
/// (also allowed with `mean-field`: the mean field of that packing's bonds).
fn calibration_level(on: &[String]) -> Result<(bool, Option<PathBuf>)> {
    let (level, packing_path) = match on {
        [l] => (l.as_str(), None),
        [l, p] => (l.as_str(), Some(PathBuf::from(p))),
        _ => ("mean-field", None),
    };
    let relaxed = match level {
        "mean-field" => false,
        "relaxed" => true,
        other => {
            return Err(Error::Invalid(format!(
                "--on {other}: expected `mean-field` or `relaxed PACKING`"
            )))
        }
    };
    if relaxed && packing_path.is_none() {
        return Err(Error::Invalid(
            "--on relaxed needs the packing: --on relaxed PACKING".into(),
        ));
    }
    Ok((relaxed, packing_path))
}

/// The cubic calibration's settings from the options.
fn cubic_options(a: &CalibrateArgs) -> CubicOptions {
    CubicOptions {
        family: a.family.into(),
        extended: a.extended,
        model: match a.cubic_model {
            CubicModelArg::Auto => None,
            CubicModelArg::ZenerAbove1 => Some(CubicModel::ZenerAbove1),
            CubicModelArg::ZenerBelow1 => Some(CubicModel::ZenerBelow1),
        },
        tolerance: a.tolerance,
        max_iterations: a.max_iterations,
        relaxed: RelaxedOptions {
            lever_arm: a.lever_arm.into(),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Print the cubic target (ratios, Zener ratio, C11 if given) and, for a relaxed
/// calibration, the packing's size and coordination.
fn print_cubic_target(t: &CubicTarget, relaxed_on: Option<&Assembly>) {
    println!(
        "target: C12/C11 = {:.4}, C44/C11 = {:.4}, Zener {:.4}{}",
        t.c12_over_c11,
        t.c44_over_c11,
        t.zener(),
        t.c11
            .map(|c| format!(", C11 = {:.4} GPa", c / 1e9))
            .unwrap_or_default()
    );
    if let Some(b) = relaxed_on {
        println!(
            "packing: {} particles, {} bonds (coordination Z = {:.3})",
            b.packing.len(),
            b.bonds.len(),
            b.bonds.coordination(b.packing.len())
        );
    }
}

fn print_cross(cal: &CrossCalibration, secs: f64) {
    println!(
        "calibrated (relaxed, on the packing): cross-anisotropic, μ = {:.5}, {} relaxed solves (CG iterations {:?}), {secs:.2} s",
        cal.mu,
        cal.history.len(),
        cal.history.iter().map(|h| h.1).collect::<Vec<_>>()
    );
    println!(
        "  lattice moduli E′ = (E_N^a′, E_N^b′, E_T^a′, E_T^b′) = ({:.5e}, {:.5e}, {:.5e}, {:.5e}) Pa",
        cal.e_prime[0], cal.e_prime[1], cal.e_prime[2], cal.e_prime[3]
    );
    println!(
        "  {:<6} {:>12} {:>14} {:>12} {:>14} {:>10}",
        "", "target GPa", "plain inv. GPa", "written GPa", "achieved GPa", "error"
    );
    let t = &cal.achieved_transverse;
    let got = [t.c11, t.c33, t.c13, t.c12];
    for (k, name) in ["C11", "C33", "C13", "C12"].iter().enumerate() {
        println!(
            "  {name:<6} {:>12.5} {:>14.5} {:>12.5} {:>14.5} {:>+9.3} %",
            cal.target[k] / 1e9,
            cal.plain_inversion[k] / 1e9,
            cal.written[k] / 1e9,
            got[k] / 1e9,
            100.0 * (got[k] - cal.target[k]) / cal.target[k].abs()
        );
    }
    println!(
        "  C44 (not calibrated; the elliptic scheme ties it to the others): {:.5} GPa, C66 {:.5} GPa",
        t.c44 / 1e9,
        t.c66 / 1e9
    );
}

fn print_many_body(cal: &ManyBodyCalibration, secs: f64) {
    println!(
        "the springs alone cannot reach the target:\n  {}",
        cal.pairwise_refusal.replace('\n', "\n  ")
    );
    let level = match cal.level {
        Level::MeanField => "mean field (Voigt level: the term adds φ·D exactly)",
        Level::Relaxed => "relaxed, on the packing",
    };
    println!(
        "calibrated ({level}): springs plus the many-body term; springs at share s = {:.4} of their reachable tensor, term on a volume fraction φ = {:.4}{}",
        cal.share,
        cal.volume_fraction,
        match cal.level {
            Level::Relaxed => format!(", {} relaxed solves", cal.history.len() + 1),
            Level::MeanField => String::new(),
        }
    );
    if let Some(p) = cal.cubic_parameters {
        println!(
            "  springs: cubic {}{}, a_n = {:.6}, a_s = {:.6}, shear/normal = {:.6}",
            p.model.as_str(),
            if p.extended { " (extended)" } else { "" },
            p.a_n,
            p.a_s,
            p.shear_over_normal
        );
    }
    println!(
        "  {:<6} {:>12} {:>12} {:>12} {:>14} {:>10}",
        "", "target GPa", "springs GPa", "D GPa", "achieved GPa", "error"
    );
    for (k, name) in cal.symmetry.names().iter().enumerate() {
        let (t, a) = (cal.target[k], cal.achieved[k]);
        println!(
            "  {name:<6} {:>12.5} {:>12.5} {:>12.5} {:>14.5} {:>+9.4} %",
            t / 1e9,
            cal.pairwise[k] / 1e9,
            cal.d[k] / 1e9,
            a / 1e9,
            100.0 * (a - t) / t.abs()
        );
    }
    println!("  (all constants fitted to the target; D is written as [manybody])");
    println!("  time {secs:.2} s");
}
