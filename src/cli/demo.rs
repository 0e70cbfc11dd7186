//! `anisobond demo`: the main job on an embedded default — Truszkowska 2018's standard
//! assembly (void fraction 0.40, radius range ΔR = R̄/6, gap cutoff 0.17 R̄) at a size that runs in
//! seconds, her MRV cubic Zener>1 model, and the tensor by every method beside the paper's.

use super::{output, report_of, LeverArmArg, MethodArg, StaticArgs};
use anisobond::assembly::Assembly;
use anisobond::bonds::table;
use anisobond::export::{liggghts, vtk, yade};
use anisobond::homogenize::relaxed::RelaxedOptions;
use anisobond::homogenize::report::TensorReport;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::packing::{self, generate};
use anisobond::plot;
use anisobond::tensor::Voigt6;
use anisobond::Result;
use std::path::PathBuf;

/// Options of `anisobond demo`.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Output folder (created if missing).
    #[arg(short, long, default_value = "anisobond-demo")]
    output: PathBuf,
    /// Number of particles of the generated periodic packing (the paper's MRV is 30,700).
    #[arg(long, default_value_t = 4000)]
    particles: usize,
    /// Random seed of the packing.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Truszkowska 2018 Eq. 30 (DEM, symmetrised): C11, C12, C44 in GPa.
const PAPER_EQ30_GPA: (f64, f64, f64) = (76.0, 30.6, 28.6);

pub fn run(a: DemoArgs) -> Result<()> {
    // Everything is written into a staging folder beside DIR and moved into place at the end.
    let mut out = OutputSet::new(&[]);
    let dir = out.dir(&a.output)?;
    let model = Model::truszkowska_mrv();
    let opts = generate::GenerateOptions {
        n_particles: a.particles,
        solid_fraction: 0.60,
        mean_radius: 1e-3,
        polydispersity: generate::Polydispersity::Uniform {
            half_width: generate::TRUSZKOWSKA_2018_HALF_WIDTH,
        },
        seed: a.seed,
        ..Default::default()
    };
    println!(
        "anisobond demo: Truszkowska et al. 2018 standard assembly (void fraction 0.40, radii uniform over a range ΔR = R̄/6, R̄ = 1 mm, gap cutoff 0.17 R̄), {} particles, seed {}",
        a.particles, a.seed
    );
    println!("model: cubic zener-above-1, a_n = 4.31, a_s = 10.0, normal 1e13 Pa/m, shear 3.55e12 Pa/m (parallel-bond area convention)");
    let p = output::generate_with_progress(&opts)?;
    let b = Assembly::new(p, model.clone())?;
    println!(
        "packing: {} particles, solid fraction {:.4}; bonds: {} (coordination Z = {:.3}; paper: 7.7)",
        b.packing.len(),
        b.packing.solid_fraction(),
        b.bonds.len(),
        b.bonds.coordination(b.packing.len())
    );
    packing::io::write_packing(&dir.join("packing.txt"), &b.packing)?;
    anisobond::io::write_string_atomic(&dir.join("model.toml"), &model.to_toml_string())?;
    table::write_bond_table(&dir.join("bonds.csv"), &b.bonds, &b.springs)?;

    let (p11, p12, p44) = PAPER_EQ30_GPA;
    println!();
    println!(
        "{:<22} {:>10} {:>10} {:>10} {:>9} {:>9} {:>8}",
        "method", "C11 [GPa]", "C12 [GPa]", "C44 [GPa]", "C12/C11", "C44/C11", "Zener"
    );
    let mut written: Vec<String> = ["packing.txt", "model.toml", "bonds.csv"]
        .map(String::from)
        .into();
    let mut plots = Vec::new();
    let statics = StaticArgs {
        lever_arm: LeverArmArg::MidGap,
        cg_tolerance: 1e-6,
        solver: super::SolverArg::Cg,
        prestress: 0.0,
        shell: 2,
        energy: false,
    };
    for m in [
        MethodArg::MeanField,
        MethodArg::Voigt,
        MethodArg::Laf,
        MethodArg::Relaxed,
        MethodArg::Dynamic,
    ] {
        let t = std::time::Instant::now();
        let args = super::run::IntegratorArgs::default();
        let r = if m == MethodArg::Dynamic {
            let result = super::run::run_element_tests(&b, &args, true)?;
            super::run::plot_element_tests(&dir.join("element-tests.png"), &result, &args)?;
            plots.push("element-tests.png");
            TensorReport::new(m.name(), result.c, Some((&b.packing, &b.bonds)))?
        } else {
            report_of(&b, m, &statics, &args)?
        };
        let secs = t.elapsed().as_secs_f64();
        let [c11, c12, c44, r12, r44, zener] = output::cubic_row(&r.cubic);
        let name = if m == MethodArg::Laf {
            "laf (m = 2, stress)"
        } else {
            r.method.as_str()
        };
        println!(
            "{name:<22} {c11:>10.3} {c12:>10.3} {c44:>10.3} {r12:>9.4} {r44:>9.4} {zener:>8.4}   ({secs:.2} s)"
        );
        let name = format!("tensor-{}.json", r.method);
        output::write_json(&dir.join(&name), &r)?;
        written.push(name);
    }
    println!(
        "{:<22} {:>10.3} {:>10.3} {:>10.3} {:>9.4} {:>9.4} {:>8.4}",
        "paper Eq. 30 (DEM)",
        p11,
        p12,
        p44,
        p12 / p11,
        p44 / p11,
        2.0 * p44 / (p11 - p12)
    );
    println!();
    println!(
        "mean-field and voigt assume uniform strain (affine bonds); relaxed is the exact static"
    );
    println!(
        "equilibrium of the same bond network; dynamic runs the six damped element tests with the"
    );
    println!("reference DEM integrator and converges to it; laf is Kruyt's local estimate of it.");
    println!("The paper's parallel bonds also carry moments, which stiffen the network (add");
    println!(
        "`moments = \"parallel-bond\"` to [geometry]). Absolute values scale with R̄ under the"
    );
    println!("area convention; the paper does not give R̄, so compare the ratios.");

    // Files for the other tools and for looking at.
    let scheme = model.build_scheme(Some((&b.packing, &b.bonds)))?;
    plot::plot_stiffness_sections(
        &dir.join("stiffness.png"),
        scheme.as_ref(),
        &plot::Section::cubic_planes(&anisobond::Mat3::identity()),
        "cubic zener-above-1 (Truszkowska MRV): normal (blue) and shear (gold) magnitudes",
        "Pa/m",
    )?;
    written.push("stiffness.png".into());
    written.extend(plots.into_iter().map(String::from));
    let strain = Voigt6::new(-1e-4, 0.0, 0.0, 0.0, 0.0, 0.0);
    let state = vtk::strained_state(
        &b.packing,
        &b.bonds,
        &b.springs,
        &strain,
        &RelaxedOptions::default(),
    )?;
    vtk::write_particles_vtu(&dir.join("particles.vtu"), &b.packing, Some(&state))?;
    vtk::write_bonds_vtu(
        &dir.join("bonds.vtu"),
        &b.packing,
        &b.bonds,
        &b.springs,
        Some(&state),
    )?;
    written.extend(["particles.vtu", "bonds.vtu"].map(String::from));
    yade::write_yade_export(
        &dir.join("yade"),
        &b.packing,
        &b.bonds,
        &b.springs,
        Some(&model),
        &yade::YadeRunOptions::default(),
    )?;
    written.push("yade/run.py".into());
    liggghts::export_liggghts(
        &dir.join("liggghts"),
        &b.packing,
        &b.bonds,
        &b.springs,
        &liggghts::DeckOptions::default(),
    )?;
    written.extend(["liggghts/anisobond.in", "liggghts/harmonic.in"].map(String::from));
    out.commit()?;

    println!();
    println!("wrote:");
    for w in written {
        println!("  {}", a.output.join(w).display());
    }
    println!("(particles.vtu/bonds.vtu: the relaxed state under a uniaxial strain e11 = −1e-4, for ParaView;");
    println!(" yade/run.py runs with `yade -n -x`; liggghts/: see its run.sh and cpp/README.md)");
    Ok(())
}
