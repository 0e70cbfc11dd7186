//! `anisobond demo`: the main job on an embedded default — Truszkowska 2018's standard
//! assembly (void fraction 0.40, radius range ΔR = R̄/6, gap cutoff 0.17 R̄) at a size that runs in
//! seconds, her MRV cubic Zener>1 model, and the tensor by every method beside the paper's.
//! The study is the library's ([`anisobond::study::demo`]); this file calls and prints.

use super::{output, LeverArmArg, SolverArg, StaticArgs};
use anisobond::io::OutputSet;
use anisobond::study::demo::{run as run_demo, DemoOptions, DemoProgress, PAPER_EQ30_GPA};
use anisobond::Result;
use indicatif::ProgressBar;
use std::path::PathBuf;
use std::sync::Mutex;

/// Options of `anisobond demo`.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Output folder (created if missing).
    #[arg(short, long, default_value = "anisobond-demo")]
    output: PathBuf,
    /// Number of particles of the generated periodic packing (the paper's MRV is 30,700).
    #[arg(long, default_value_t = DemoOptions::default().particles)]
    particles: usize,
    /// Random seed of the packing.
    #[arg(long, default_value_t = DemoOptions::default().seed)]
    seed: u64,
}

/// The static options the library's demo runs with (for the solvers' notes).
const STATICS: StaticArgs = StaticArgs {
    lever_arm: LeverArmArg::MidGap,
    cg_tolerance: 1e-6,
    solver: SolverArg::Cg,
    prestress: 0.0,
    shell: 2,
    energy: false,
};

/// A progress bar named `what`, made on first use and moved to `fraction`.
fn advance(bar: &Mutex<Option<ProgressBar>>, what: &str, fraction: f64) {
    let mut b = bar.lock().unwrap_or_else(|e| e.into_inner());
    let b = b.get_or_insert_with(|| output::progress_bar(what));
    b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
}

/// Clear the progress bar, if any.
fn clear(bar: &Mutex<Option<ProgressBar>>) {
    if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
        b.finish_and_clear();
    }
}

/// What the demo reports as it goes, printed.
fn print_progress(bar: &Mutex<Option<ProgressBar>>, p: DemoProgress) {
    match p {
        DemoProgress::Generating(f) => advance(bar, "generating packing", f),
        DemoProgress::ElementTests(f) => advance(bar, "element tests", f),
        DemoProgress::Bonded(b) => {
            clear(bar);
            println!(
                "packing: {} particles, solid fraction {:.4}; bonds: {} (coordination Z = {:.3}; paper: 7.7)",
                b.packing.len(),
                b.packing.solid_fraction(),
                b.bonds.len(),
                b.bonds.coordination(b.packing.len())
            );
            println!();
            println!(
                "{:<22} {:>10} {:>10} {:>10} {:>9} {:>9} {:>8}",
                "method", "C11 [GPa]", "C12 [GPa]", "C44 [GPa]", "C12/C11", "C44/C11", "Zener"
            );
        }
        DemoProgress::ElementTestsDone(d) => {
            clear(bar);
            super::run::print_stability(d);
        }
        DemoProgress::Method {
            name,
            report,
            detail,
            seconds,
        } => {
            if let Some(d) = detail {
                super::print_detail(d, &STATICS);
            }
            let [c11, c12, c44, r12, r44, zener] = output::cubic_row(&report.cubic);
            println!(
                "{name:<22} {c11:>10.3} {c12:>10.3} {c44:>10.3} {r12:>9.4} {r44:>9.4} {zener:>8.4}   ({seconds:.2} s)"
            );
        }
    }
}

/// The paper's row and what the table shows.
fn print_paper() {
    let (p11, p12, p44) = PAPER_EQ30_GPA;
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
}

/// Run `anisobond demo`.
pub fn run(a: DemoArgs) -> Result<()> {
    // Everything is written into a staging folder beside DIR and moved into place at the end.
    let mut out = OutputSet::new(&[]);
    let dir = out.dir(&a.output)?;
    println!(
        "anisobond demo: Truszkowska et al. 2018 standard assembly (void fraction 0.40, radii uniform over a range ΔR = R̄/6, R̄ = 1 mm, gap cutoff 0.17 R̄), {} particles, seed {}",
        a.particles, a.seed
    );
    println!("model: cubic zener-above-1, a_n = 4.31, a_s = 10.0, normal 1e13 Pa/m, shear 3.55e12 Pa/m (parallel-bond area convention)");
    let opts = DemoOptions {
        particles: a.particles,
        seed: a.seed,
    };
    let bar = Mutex::new(None);
    let report = run_demo(&opts, &|p| print_progress(&bar, p));
    clear(&bar);
    let written = report?.write(&dir)?;
    print_paper();
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
