//! `anisobond domain`: the accessible (C12/C11, C44/C11) domain of the cubic models, sampled
//! in the log-normalised parameter space (Truszkowska 2018 Eq. 16, Fig. 8, Fig. C.1a), as
//! CSV and PNG. The study is the library's ([`anisobond::study::domain`]); this file parses,
//! calls and prints.

use anisobond::assembly::Assembly;
use anisobond::calibrate::DomainOptions;
use anisobond::calibrate::Target;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::study::domain::{run as run_study, DomainOn, DomainReport};
use anisobond::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The sampling's defaults (the library's, once).
fn d() -> DomainOptions {
    DomainOptions::default()
}

/// Options of `anisobond domain`.
#[derive(clap::Args)]
pub struct DomainArgs {
    /// `mean-field` (default, fast) or `relaxed PACKING` (one relaxed solve per sample).
    #[arg(long, num_args = 1..=2, value_names = ["LEVEL", "PACKING"], default_values_t = ["mean-field".to_string()])]
    on: Vec<String>,
    /// Model file giving the bonding rule and geometry for `--on relaxed` (default: the
    /// paper's gap 0.17 R̄, area convention).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Samples per model variant (zener-above-1, zener-below-1, each plain and extended).
    #[arg(long)]
    samples: Option<usize>,
    /// Random seed.
    #[arg(long, default_value_t = d().seed)]
    seed: u64,
    /// Plain models only.
    #[arg(long)]
    no_extended: bool,
    /// Smallest aspect ratio a_n, a_s sampled (Truszkowska 2018: 0.022).
    #[arg(long, default_value_t = d().a_min)]
    a_min: f64,
    /// Largest aspect ratio sampled (Truszkowska 2018: 5).
    #[arg(long, default_value_t = d().a_max)]
    a_max: f64,
    /// Smallest shear/normal ratio (Truszkowska 2018: 0.005).
    #[arg(long, default_value_t = d().ratio_min)]
    ratio_min: f64,
    /// Largest shear/normal ratio (Truszkowska 2018: 1).
    #[arg(long, default_value_t = d().ratio_max)]
    ratio_max: f64,
    /// Mean field: keep extended models whose shear stiffness goes negative somewhere
    /// (Truszkowska 2018 Fig. C.1a; such models cannot be used in DEM).
    #[arg(long)]
    allow_negative: bool,
    /// Mark this target on the map (same form as `calibrate --target`, cubic).
    #[arg(long)]
    target: Option<String>,
    /// Output folder: domain.csv and domain.png.
    #[arg(short, long, default_value = "anisobond-domain")]
    output: PathBuf,
}

/// The ranges of every model variant.
fn print_summary(r: &DomainReport) {
    for v in r.summary() {
        println!(
            "  {:<28} {:>6} samples: Zener {:.3}–{:.3}, C12/C11 {:.3}–{:.3}, C44/C11 {:.3}–{:.3}, max (C12 − C44)/C11 {:+.4}",
            format!("{}{}", v.model, if v.extended { " extended" } else { "" }),
            v.samples,
            v.zener.0,
            v.zener.1,
            v.c12_over_c11.0,
            v.c12_over_c11.1,
            v.c44_over_c11.0,
            v.c44_over_c11.1,
            v.max_c12_minus_c44_over_c11
        );
    }
}

/// `--target` as the point (C12/C11, C44/C11) to mark.
fn target_point(target: Option<&str>) -> Result<Option<(f64, f64)>> {
    match target {
        Some(t) => match Target::parse(t)? {
            Target::Cubic(c) => Ok(Some((c.c12_over_c11, c.c44_over_c11))),
            _ => Err(Error::Invalid(
                "--target: the domain map is cubic; give C11, C12, C44 or the ratios".into(),
            )),
        },
        None => Ok(None),
    }
}

/// Run `anisobond domain`.
pub fn run(a: DomainArgs) -> Result<()> {
    let inputs: Vec<&Path> =
        a.on.get(1)
            .map(Path::new)
            .into_iter()
            .chain(a.model.as_deref())
            .collect();
    let mut out = OutputSet::new(&inputs);
    let dir = out.dir(&a.output)?;
    let relaxed = match a.on.first().map(String::as_str) {
        Some("mean-field") | None => false,
        Some("relaxed") => true,
        Some(other) => {
            return Err(Error::Invalid(format!(
                "--on {other}: expected `mean-field` or `relaxed PACKING`"
            )))
        }
    };
    let target = target_point(a.target.as_deref())?;
    let assembly = if relaxed {
        let path = a.on.get(1).ok_or_else(|| {
            Error::Invalid("--on relaxed needs the packing: --on relaxed PACKING".into())
        })?;
        let model = match &a.model {
            Some(m) => Model::from_path(m)?,
            None => Model::truszkowska_mrv(),
        };
        Some(Assembly::new(super::cell::read(Path::new(path))?, model)?)
    } else {
        None
    };
    let on = match &assembly {
        Some(b) => DomainOn::Relaxed(b),
        None => DomainOn::MeanField,
    };
    let opts = DomainOptions {
        samples: a.samples.unwrap_or(on.default_samples()),
        seed: a.seed,
        a_min: a.a_min,
        a_max: a.a_max,
        ratio_min: a.ratio_min,
        ratio_max: a.ratio_max,
        extended: !a.no_extended,
        allow_negative: a.allow_negative,
    };
    let start = Instant::now();
    let r = run_study(on, &opts)?;
    let secs = start.elapsed().as_secs_f64();
    println!(
        "accessible domain ({}): {} samples in {secs:.2} s; {} extended samples skipped (negative stiffness)",
        r.label,
        r.samples.len(),
        r.skipped
    );
    print_summary(&r);
    if let Some((x, y)) = target {
        // Target::parse has refused an unstable target, so this one is inside the stable
        // domain: the springs reach it where the map's samples do, the term elsewhere.
        println!(
            "target C12/C11 = {x:.4}, C44/C11 = {y:.4}: inside the stable domain (−1/2 < C12/C11 < 1, C44 > 0), so `calibrate` reaches it{}",
            if x > y {
                "; beyond the Cauchy line C12 = C44, so with the many-body term"
            } else {
                ""
            }
        );
    }
    println!("  domain.png also draws the stable domain's bounds and marks Ni, Cu, Fe, Al, W (all reached with the many-body term)");
    r.write(&dir, target)?;
    out.commit()?;
    for name in ["domain.csv", "domain.png"] {
        println!("wrote {}", a.output.join(name).display());
    }
    Ok(())
}
