//! `anisobond pack`: seeded periodic random packings, by Truszkowska's random-and-relax
//! generation or by one of Kumar 2016's three preparation routes, with presets for both
//! papers' standard assemblies.

use anisobond::bonds::build_bonds;
use anisobond::bonds::BondingRule;
use anisobond::io::OutputSet;
use anisobond::packing::presets::{self, Route, TRUSZKOWSKA_STANDARD_GAP};
use anisobond::packing::{self, Packing};
use anisobond::packing::{generate_with_report, GenerateOptions, Polydispersity};
use anisobond::packing::{
    prepare_with_status, ForceBalance, PreparationRoute, RouteOptions, RouteStage, RouteStatus,
    DEFAULT_JAMMING_BALANCE,
};
use anisobond::{Error, Result};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// How the packing is made.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum RouteArg {
    /// Random positions at the target solid fraction, overlaps removed by energy
    /// minimisation (Truszkowska 2018 Sec. 4.1; needs φ ≤ 0.64).
    Random,
    /// Kumar 2016: random gas at 0.3, affine densification to the target.
    Unjammed,
    /// Kumar 2016: frictionless repulsive compression to 0.5, then affine to the target.
    WeaklyJammed,
    /// Kumar 2016: compression to the jamming point (≈ 0.636, Z ≈ 6), then affine.
    Jammed,
}

/// Named standard assemblies (the library's `packing::presets`).
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum Preset {
    /// Truszkowska 2018's standard assembly: 30,700 particles, void fraction 0.40, radius
    /// range ΔR = R̄/6 (half width 1/12), random route. Bond it with gap 0.17 R̄ (Eq. 4):
    /// mean coordination ≈ 7.7 (the paper's 118,008 bonds).
    TruszkowskaStandard,
    /// Kumar 2016's samples: 5000 particles, solid fraction 0.65, R̄ ± 5 %, jammed route
    /// (choose another with --route). Bond with `factor` κ = 1.000 … 1.075 (Eq. 10).
    #[value(name = "kumar-2016")]
    Kumar2016,
}

impl Preset {
    /// The library's preset.
    fn library(self) -> presets::Preset {
        match self {
            Preset::TruszkowskaStandard => presets::TRUSZKOWSKA_STANDARD,
            Preset::Kumar2016 => presets::KUMAR_2016,
        }
    }
}

#[derive(clap::Args)]
pub struct PackArgs {
    /// Start from a named standard assembly; the other options override its values.
    #[arg(long, value_enum)]
    preset: Option<Preset>,
    /// Preparation route [default: random].
    #[arg(long, value_enum)]
    route: Option<RouteArg>,
    /// Number of particles [default: 2000, or the preset's].
    #[arg(long)]
    particles: Option<usize>,
    /// Solid fraction φ (volume of spheres / cell volume) [default: 0.6, or the preset's].
    #[arg(long, conflicts_with = "void_fraction")]
    solid_fraction: Option<f64>,
    /// Void fraction 1 − φ, as Truszkowska 2018 states it (alternative to
    /// --solid-fraction).
    #[arg(long)]
    void_fraction: Option<f64>,
    /// Radius polydispersity h: radii uniform in [R̄(1−h), R̄(1+h)] [default: 1/12, the
    /// range ΔR = R̄/6 of Truszkowska 2018; Kumar's preset: 0.05].
    #[arg(long)]
    polydispersity: Option<f64>,
    /// Mean radius R̄ (m).
    #[arg(long, default_value_t = 1e-3)]
    mean_radius: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Force balance of the jammed route's jammed state: `mean:R` (YADE's unbalanced
    /// force: mean net force ≤ R × mean contact force; default mean:2e-3) or `max:R`
    /// (Kumar 2016's rule over the whole packing: largest net force ≤ R × largest contact
    /// force; `max:1e-3` needed 2.6–6.9× more iterations at 30,000 particles). A bare number is `mean:`.
    #[arg(long, value_parser = parse_balance, value_name = "mean:R|max:R")]
    jam_balance: Option<ForceBalance>,
    /// Do not draw the progress bar.
    #[arg(long)]
    quiet: bool,
    /// Output packing file (SPEC text `x y z r` in m).
    #[arg(short, long)]
    output: PathBuf,
}

/// The options of `pack` after applying the preset and the defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    pub route: RouteArg,
    pub particles: usize,
    pub solid_fraction: f64,
    pub half_width: f64,
}

/// Apply preset and defaults; explicit options win.
pub fn resolve(a: &PackArgs) -> Result<Resolved> {
    let preset = a.preset.map_or(presets::DEFAULT, Preset::library);
    let route = match preset.route {
        Route::Random => RouteArg::Random,
        Route::Kumar(PreparationRoute::Unjammed) => RouteArg::Unjammed,
        Route::Kumar(PreparationRoute::WeaklyJammed) => RouteArg::WeaklyJammed,
        Route::Kumar(PreparationRoute::Jammed) => RouteArg::Jammed,
    };
    let (particles, phi, h) = (preset.particles, preset.solid_fraction, preset.half_width);
    let solid_fraction = match (a.solid_fraction, a.void_fraction) {
        (Some(s), _) => s,
        (None, Some(v)) => {
            if !v.is_finite() || v <= 0.0 || v >= 1.0 {
                return Err(Error::Invalid(format!(
                    "--void-fraction must be in (0, 1), got {v}"
                )));
            }
            1.0 - v
        }
        (None, None) => phi,
    };
    Ok(Resolved {
        route: a.route.unwrap_or(route),
        particles: a.particles.unwrap_or(particles),
        solid_fraction,
        half_width: a.polydispersity.unwrap_or(h),
    })
}

fn polydispersity(h: f64) -> Polydispersity {
    if h == 0.0 {
        Polydispersity::Monodisperse
    } else {
        Polydispersity::Uniform { half_width: h }
    }
}

/// One line for the progress bar: what the preparation is doing now, with units.
/// `--jam-balance`: `mean:R`, `max:R` or a bare R (mean), R in (0, 0.1].
fn parse_balance(text: &str) -> std::result::Result<ForceBalance, String> {
    let (kind, value) = match text.split_once(':') {
        Some((kind, value)) => (kind.trim(), value.trim()),
        None => ("mean", text.trim()),
    };
    if kind != "mean" && kind != "max" {
        return Err(format!("expected `mean:R` or `max:R`, found `{kind}:`"));
    }
    let ratio: f64 = value
        .parse()
        .map_err(|_| format!("expected a ratio such as 2e-3 after `{kind}:`, found `{value}`"))?;
    if !ratio.is_finite() || ratio <= 0.0 || ratio > 0.1 {
        return Err(format!("the ratio must be in (0, 0.1], got {ratio}"));
    }
    Ok(if kind == "mean" {
        ForceBalance::Mean(ratio)
    } else {
        ForceBalance::Largest(ratio)
    })
}

fn status_line(s: &RouteStatus) -> String {
    match s.stage {
        RouteStage::Gas => format!("random gas at φ = {:.3}", s.solid_fraction),
        RouteStage::Compression {
            target_solid_fraction,
        } => format!(
            "compressing to φ = {target_solid_fraction:.3}: φ = {:.4}, {} FIRE iterations",
            s.solid_fraction, s.iterations
        ),
        RouteStage::Jamming {
            stage,
            stages,
            target_pressure,
            pressure,
            residual,
        } => format!(
            "jamming stage {stage}/{stages} at P_t = {target_pressure:.1e} Σ_N: P = \
             {pressure:.2e} Σ_N, φ = {:.5}, residual {residual:.3} (done at ≤ 1), {} FIRE \
             iterations",
            s.solid_fraction, s.iterations
        ),
        RouteStage::Done => format!("done, φ = {:.4}", s.solid_fraction),
    }
}

/// Generate, write and describe the packing the options ask for.
pub fn run(a: PackArgs) -> Result<()> {
    let r = resolve(&a)?;
    if a.jam_balance.is_some() && r.route != RouteArg::Jammed {
        return Err(Error::Invalid(
            "--jam-balance applies to the jammed route only (add --route jammed)".into(),
        ));
    }
    // The jammed route can take minutes: check the output path first.
    let mut out = OutputSet::new(&[]);
    let staged = out.file(&a.output)?;
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1000)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "packing {msg} [{bar:40}] {percent:>3}% {elapsed_precise} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let route_name = match r.route {
        RouteArg::Random => "random",
        RouteArg::Unjammed => "unjammed",
        RouteArg::WeaklyJammed => "weakly-jammed",
        RouteArg::Jammed => "jammed",
    };
    bar.set_message(format!("{} × {route_name}", r.particles));
    let started = Instant::now();
    let (p, details): (Packing, String) = match r.route {
        RouteArg::Random => pack_random(&a, &r, &bar)?,
        route => {
            let route = match route {
                RouteArg::Unjammed => PreparationRoute::Unjammed,
                RouteArg::WeaklyJammed => PreparationRoute::WeaklyJammed,
                _ => PreparationRoute::Jammed,
            };
            bar.set_prefix(format!("{} × {route_name}", r.particles));
            pack_by_route(&a, &r, route, &bar)?
        }
    };
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    packing::write_packing(&staged, &p)?;
    out.commit()?;
    let l = p.cell.map(|c| c.lengths).unwrap_or_default();
    println!(
        "wrote {} ({} particles, solid fraction {:.4} = void fraction {:.4}, cell {:.4e} × \
         {:.4e} × {:.4e} m = {:.2} R̄; {route_name} route in {seconds:.1} s)",
        a.output.display(),
        p.len(),
        p.solid_fraction(),
        1.0 - p.solid_fraction(),
        l.x,
        l.y,
        l.z,
        l.x / p.mean_radius()
    );
    println!("  {details}");
    print_preset_bonding(a.preset, &p)
}

/// The random route (Truszkowska 2018 Sec. 4.1): the packing and a line on its energy
/// minimisation.
fn pack_random(a: &PackArgs, r: &Resolved, bar: &ProgressBar) -> Result<(Packing, String)> {
    let opts = GenerateOptions {
        n_particles: r.particles,
        solid_fraction: r.solid_fraction,
        mean_radius: a.mean_radius,
        polydispersity: polydispersity(r.half_width),
        seed: a.seed,
        ..Default::default()
    };
    let progress = |f: f64| bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64);
    let (p, rep) = generate_with_report(&opts, &progress)?;
    let details = format!(
        "{} FIRE iterations, largest overlap {:.1e} R̄",
        rep.iterations, rep.max_overlap
    );
    Ok((p, details))
}

/// One of Kumar 2016's routes (Sec. 3): the packing and a line on the compressed state and
/// the work done. The routes report what runs; their fraction can stand still for minutes
/// in the last jamming stage, so the bar shows the live state instead of an ETA.
fn pack_by_route(
    a: &PackArgs,
    r: &Resolved,
    route: PreparationRoute,
    bar: &ProgressBar,
) -> Result<(Packing, String)> {
    let opts = RouteOptions {
        route,
        n_particles: r.particles,
        solid_fraction: r.solid_fraction,
        mean_radius: a.mean_radius,
        polydispersity: polydispersity(r.half_width),
        seed: a.seed,
        jamming_balance: a.jam_balance.unwrap_or(DEFAULT_JAMMING_BALANCE),
        ..Default::default()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "packing {prefix} [{bar:30}] {percent:>3}% {elapsed_precise} · {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let (p, rep) = prepare_with_status(&opts, &|s: &RouteStatus| {
        bar.set_position((s.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
        bar.set_message(status_line(s));
    })?;
    let mut d = format!(
        "solid fraction before the affine step {:.4}",
        rep.compressed_solid_fraction
    );
    if route == PreparationRoute::Jammed {
        d += &format!(
            " (jammed: {:.3} contacts per particle, {} with < 4 contacts, pressure \
             {:.1e} Σ_N; net forces: mean {:.1e} × mean contact force, largest \
             {:.1e} × largest contact force)",
            rep.compressed_coordination,
            rep.rattlers,
            rep.pressure,
            rep.mean_unbalanced,
            rep.largest_unbalanced
        );
    }
    d += &format!(
        ", affine scale {:.5}; {} minimisations, {} FIRE iterations",
        rep.affine_scale, rep.relaxations, rep.iterations
    );
    Ok((p, d))
}

/// For a preset, print the bonding its paper uses on the packing: Truszkowska 2018's gap
/// cutoff (Eq. 4) and bond count, or Kumar 2016's coordination at each range κ (Eq. 10).
fn print_preset_bonding(preset: Option<Preset>, p: &Packing) -> Result<()> {
    if preset == Some(Preset::TruszkowskaStandard) {
        let bonds = build_bonds(p, presets::TRUSZKOWSKA_STANDARD.bonding[0])?;
        println!(
            "  bonding with the paper's gap cutoff {TRUSZKOWSKA_STANDARD_GAP} R̄ (model file: \
             [bonding] rule = \"gap\", value = {TRUSZKOWSKA_STANDARD_GAP}) gives {} bonds, \
             coordination Z = {:.3} (Truszkowska 2018: 118,008 bonds, Z = 7.7)",
            bonds.len(),
            bonds.coordination(p.len())
        );
    }
    if preset == Some(Preset::Kumar2016) {
        let z: Vec<String> = presets::KUMAR_2016_RANGES
            .iter()
            .map(|&k| {
                build_bonds(p, BondingRule::Factor(k))
                    .map(|b| format!("{k:.3}: {:.3}", b.coordination(p.len())))
            })
            .collect::<Result<_>>()?;
        println!(
            "  bonds per particle by interaction range κ ([bonding] rule = \"factor\"): {}",
            z.join(", ")
        );
    }
    Ok(())
}
