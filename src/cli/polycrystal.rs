//! `anisobond polycrystal`: a polycrystal's relaxed tensor beside its single crystal's
//! random-texture bounds and estimates, and each grain's stress against its orientation
//! (docs/polycrystal.md). The study is the library's ([`anisobond::study::polycrystal`]);
//! this file parses, calls and prints.

use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::study::polycrystal::{run as run_study, PolycrystalOptions, PolycrystalProgress};
use anisobond::study::OptionNames;
use anisobond::Result;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The study's defaults (the library's, once).
fn d() -> PolycrystalOptions {
    PolycrystalOptions::default()
}

/// Options of `anisobond polycrystal`.
#[derive(clap::Args)]
pub struct PolycrystalArgs {
    /// Periodic packing file (SPEC text, YADE text, LIGGGHTS data).
    packing: PathBuf,
    /// Model file with a `[grains]` table (docs/polycrystal.md).
    #[arg(long)]
    model: PathBuf,
    /// Uniaxial engineering strain of the local fields' load.
    #[arg(long, default_value_t = d().strain, allow_hyphen_values = true)]
    strain: f64,
    /// Load axis: x, y or z.
    #[arg(long, default_value = "x")]
    load_axis: String,
    /// Grain counts of a convergence series (comma-separated, e.g. 1,8,64): one more
    /// relaxed solve each, with the model's seed and orientation rule.
    #[arg(long, value_delimiter = ',')]
    grain_counts: Vec<usize>,
    /// Output folder: polycrystal.json, polycrystal_grains.csv, polycrystal.png.
    #[arg(short, long, default_value = "anisobond-polycrystal")]
    output: PathBuf,
}

/// Run `anisobond polycrystal`.
pub fn run(a: PolycrystalArgs) -> Result<()> {
    let mut out = OutputSet::new(&[a.packing.as_path(), a.model.as_path()]);
    let dir = out.dir(&a.output)?;
    let load_axis = match a.load_axis.as_str() {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        other => {
            return Err(anisobond::Error::Invalid(format!(
                "--load-axis {other}: expected x, y or z"
            )))
        }
    };
    let opts = PolycrystalOptions {
        strain: a.strain,
        load_axis,
        grain_counts: a.grain_counts.clone(),
        ..d()
    };
    opts.check(OptionNames::Flags)?;
    let packing = super::cell::read(&a.packing)?;
    let model = Model::from_path(&a.model)?;
    let start = Instant::now();
    let r = run_study(&packing, &model, &opts, OptionNames::Flags, &|p| match p {
        PolycrystalProgress::SingleCrystal => eprintln!("single crystal: relaxed solve"),
        PolycrystalProgress::Polycrystal => {
            eprintln!("polycrystal: relaxed solve and local fields")
        }
        PolycrystalProgress::Series { index, of, grains } => {
            eprintln!("series {}/{of}: {grains} grains", index + 1)
        }
    })?;
    let gpa = |x: f64| x / 1e9;
    let s = &r.single_crystal;
    println!(
        "polycrystal: {} particles, {} bonds, {} grains, in {:.1} s",
        r.particles,
        r.bonds,
        r.grains.len(),
        start.elapsed().as_secs_f64()
    );
    println!("                       K (GPa)    G (GPa)");
    for (name, k, g) in [
        ("single crystal Voigt", s.voigt_bulk_pa, s.voigt_shear_pa),
        ("HS upper", s.hs_upper_bulk_pa, s.hs_upper_shear_pa),
        (
            "self-consistent",
            s.self_consistent_bulk_pa,
            s.self_consistent_shear_pa,
        ),
        ("HS lower", s.hs_lower_bulk_pa, s.hs_lower_shear_pa),
        ("single crystal Reuss", s.reuss_bulk_pa, s.reuss_shear_pa),
        ("polycrystal (relaxed)", r.bulk_pa, r.shear_pa),
    ] {
        println!("  {name:<22} {:>9.4}  {:>9.4}", gpa(k), gpa(g));
    }
    println!(
        "  polycrystal inside the HS bounds: K {}, G {}; G vs self-consistent {:+.2} %",
        yes(r.bulk_within_hs_bounds),
        yes(r.shear_within_hs_bounds),
        100.0 * r.shear_vs_self_consistent
    );
    println!(
        "  distance from isotropy |C − iso(C)|/|C|: single crystal {:.4}, polycrystal {:.4}",
        r.single_crystal_anisotropy, r.anisotropy
    );
    println!(
        "  grain stress along the load vs the grain's longitudinal modulus along it: correlation {:.3}; local σ spread {:.3e} Pa about {:.3e} Pa",
        r.stress_stiffness_correlation, r.cell_std_stress_pa, r.cell_mean_stress_pa
    );
    for row in &r.series {
        println!(
            "  {:>6} grains: K {:.4} GPa, G {:.4} GPa, distance from isotropy {:.4}",
            row.grains,
            gpa(row.bulk_pa),
            gpa(row.shear_pa),
            row.anisotropy
        );
    }
    let names = r.write(&dir)?;
    out.commit()?;
    for name in names {
        println!("wrote {}", Path::new(&a.output).join(name).display());
    }
    Ok(())
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}
