//! `anisobond domain`: the accessible (C12/C11, C44/C11) domain of the cubic models, sampled
//! in the log-normalised parameter space (Truszkowska 2018 Eq. 16, Fig. 8, Fig. C.1a), as
//! CSV and PNG.

use super::LeverArmArg;
use anisobond::assembly::Assembly;
use anisobond::calibrate::domain::{
    sample_mean_field, sample_relaxed, write_csv, DomainOptions, DomainSample,
};
use anisobond::calibrate::target::Target;
use anisobond::homogenize::relaxed::RelaxedOptions;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::schemes::cubic::CubicModel;
use anisobond::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
    #[arg(long, default_value_t = 2018)]
    seed: u64,
    /// Plain models only.
    #[arg(long)]
    no_extended: bool,
    /// Smallest aspect ratio a_n, a_s sampled (Truszkowska 2018: 0.022).
    #[arg(long, default_value_t = 0.022)]
    a_min: f64,
    /// Largest aspect ratio sampled (Truszkowska 2018: 5).
    #[arg(long, default_value_t = 5.0)]
    a_max: f64,
    /// Smallest shear/normal ratio (Truszkowska 2018: 0.005).
    #[arg(long, default_value_t = 0.005)]
    ratio_min: f64,
    /// Largest shear/normal ratio (Truszkowska 2018: 1).
    #[arg(long, default_value_t = 1.0)]
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

fn summary(samples: &[DomainSample]) {
    for model in [CubicModel::ZenerAbove1, CubicModel::ZenerBelow1] {
        for extended in [false, true] {
            let v: Vec<_> = samples
                .iter()
                .filter(|s| s.model == model && s.extended == extended)
                .collect();
            if v.is_empty() {
                continue;
            }
            let lo = |f: &dyn Fn(&DomainSample) -> f64| {
                v.iter().map(|s| f(s)).fold(f64::INFINITY, f64::min)
            };
            let hi = |f: &dyn Fn(&DomainSample) -> f64| {
                v.iter().map(|s| f(s)).fold(f64::NEG_INFINITY, f64::max)
            };
            println!(
                "  {:<28} {:>6} samples: Zener {:.3}–{:.3}, C12/C11 {:.3}–{:.3}, C44/C11 {:.3}–{:.3}, max (C12 − C44)/C11 {:+.4}",
                format!("{}{}", model.as_str(), if extended { " extended" } else { "" }),
                v.len(),
                lo(&|s| s.zener),
                hi(&|s| s.zener),
                lo(&|s| s.c12_over_c11),
                hi(&|s| s.c12_over_c11),
                lo(&|s| s.c44_over_c11),
                hi(&|s| s.c44_over_c11),
                hi(&|s| s.c12_over_c11 - s.c44_over_c11)
            );
        }
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
    let target = match &a.target {
        Some(t) => match Target::parse(t)? {
            Target::Cubic(c) => Some((c.c12_over_c11, c.c44_over_c11)),
            _ => {
                return Err(Error::Invalid(
                    "--target: the domain map is cubic; give C11, C12, C44 or the ratios".into(),
                ))
            }
        },
        None => None,
    };
    let opts = DomainOptions {
        samples: a.samples.unwrap_or(if relaxed { 60 } else { 2500 }),
        seed: a.seed,
        a_min: a.a_min,
        a_max: a.a_max,
        ratio_min: a.ratio_min,
        ratio_max: a.ratio_max,
        extended: !a.no_extended,
        allow_negative: a.allow_negative,
    };
    let start = Instant::now();
    let (samples, skipped, label) = if relaxed {
        let path = a.on.get(1).ok_or_else(|| {
            Error::Invalid("--on relaxed needs the packing: --on relaxed PACKING".into())
        })?;
        let model = match &a.model {
            Some(m) => Model::from_path(m)?,
            None => Model::truszkowska_mrv(),
        };
        let b = Assembly::new(
            super::cell::read(std::path::Path::new(path))?,
            model.clone(),
        )?;
        let (s, k) = sample_relaxed(
            &b.packing,
            &b.bonds,
            &model.geometry,
            &RelaxedOptions {
                lever_arm: LeverArmArg::MidGap.into(),
                ..Default::default()
            },
            &opts,
        )?;
        (s, k, format!("relaxed, {} particles", b.packing.len()))
    } else {
        let (s, k) = sample_mean_field(&opts)?;
        (s, k, "mean field".to_string())
    };
    let secs = start.elapsed().as_secs_f64();
    println!(
        "accessible domain ({label}): {} samples in {secs:.2} s; {skipped} extended samples skipped (negative stiffness)",
        samples.len()
    );
    summary(&samples);
    write_csv(&dir.join("domain.csv"), &samples)?;
    anisobond::plot::plot_domain(
        &dir.join("domain.png"),
        &samples,
        &format!("Accessible cubic domain ({label})"),
        target,
    )?;
    out.commit()?;
    for name in ["domain.csv", "domain.png"] {
        println!("wrote {}", a.output.join(name).display());
    }
    Ok(())
}
