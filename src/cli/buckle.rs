//! `anisobond buckle`: Kumar 2016 Sec. 5's clamped round bars at several slenderness ratios
//! and preparation routes, with the bonded network's own linearised critical stress beside
//! Euler (Eq. 14, k = 0.5) and Mazzilli (Eq. 15), E from the bar's own axial modulus.

use anisobond::assembly::Assembly;
use anisobond::bonds::BondingRule;
use anisobond::dem::buckling::{
    compress_clamped_bar_with_progress, CompressionOptions, CompressionResult, Loading,
};
use anisobond::dem::check_run_size;
use anisobond::homogenize::buckling::{
    euler_stress, extensible_stress, mazzilli_stress, BucklingOptions, BucklingResult, PreBuckling,
    RoundBar,
};
use anisobond::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use anisobond::io::{write_string_atomic, OutputSet};
use anisobond::model::{Model, SchemeSpec};
use anisobond::packing::container::container_particles;
use anisobond::packing::routes::{prepare, PreparationRoute, RouteOptions};
use anisobond::plot::{plot_series, Series};
use anisobond::schemes::{Convention, Geometry, Moments};
use anisobond::tensor::elastic::compliance;
use anisobond::{Error, Result};
use std::path::PathBuf;
use std::time::Instant;

/// Kumar 2016's preparation routes (Sec. 3).
#[derive(Clone, Copy, clap::ValueEnum, PartialEq, Eq, Debug)]
pub enum BuckleRoute {
    /// Random gas at 0.3, affine densification to 0.65.
    Unjammed,
    /// Repulsive compression to 0.5, then affine.
    WeaklyJammed,
    /// Compression to the jamming point (≈ 0.636), then affine.
    Jammed,
}

impl BuckleRoute {
    fn route(self) -> PreparationRoute {
        match self {
            BuckleRoute::Unjammed => PreparationRoute::Unjammed,
            BuckleRoute::WeaklyJammed => PreparationRoute::WeaklyJammed,
            BuckleRoute::Jammed => PreparationRoute::Jammed,
        }
    }
}

/// How the bars' spheres are packed.
#[derive(Clone, Copy, clap::ValueEnum, PartialEq, Eq, Debug)]
pub enum Preparation {
    /// Cut out of one periodic cell per route (tiled along the bar).
    Cut,
    /// Kumar's own: each bar packed by the route inside a rigid cylinder of radius r and two
    /// planes, which are then removed; the spheres touching the planes are clamped.
    Container,
}

/// Options of `anisobond buckle`.
#[derive(clap::Args)]
pub struct BuckleArgs {
    /// Slenderness ratios l/r, comma-separated (Kumar 2016: 10 to 120; each > 2π, where
    /// Mazzilli's Eq. 15 has a root).
    #[arg(long, value_delimiter = ',', default_values_t = [10.0, 20.0, 40.0, 80.0, 120.0])]
    slenderness: Vec<f64>,
    /// Preparation routes, comma-separated.
    #[arg(long, value_delimiter = ',', default_values = ["unjammed", "weakly-jammed", "jammed"])]
    route: Vec<BuckleRoute>,
    /// Bar radius r in mean particle radii R̄, the same at every l/r (so the particles per
    /// unit length are the same, as Kumar's).
    #[arg(long, default_value_t = 5.0)]
    radius_particles: f64,
    /// How the bars are prepared: cut from a periodic cell, or packed one by one in a rigid
    /// cylinder and two planes (Kumar's; as many spheres per unit length as a cut bar).
    #[arg(long, value_enum, default_value_t = Preparation::Cut)]
    preparation: Preparation,
    /// Particles of the periodic cell (Kumar's route, R̄ = 1 mm ± 5 %, D = 0.65) that the
    /// bars are cut from; the cell is tiled along the bar.
    #[arg(long, default_value_t = 1000)]
    cell_particles: usize,
    /// A model file (docs/formats.md) instead of Kumar's bonds (then --alpha, --kappa and
    /// --sigma-n are not used): e.g. a cubic crystal rotated so that <100> or <111> lies
    /// along the bar axis z. E along the axis is compared with 1/S'₃₃ of the periodic cell's
    /// relaxed tensor.
    #[arg(long, conflicts_with_all = ["alpha", "kappa", "sigma_n"])]
    model: Option<PathBuf>,
    /// α = Σ_T/Σ_N, tangential to normal bond stiffness (Kumar 2016: 0.2).
    #[arg(long, default_value_t = 0.2)]
    alpha: f64,
    /// κ, interaction range of the bonding (Kumar 2016 Eq. 10: 1).
    #[arg(long, default_value_t = 1.0)]
    kappa: f64,
    /// Σ_N, normal bond stiffness magnitude (Pa; Kumar Eqs. 1–3). Stresses scale with it.
    #[arg(long, default_value_t = 1.0e8)]
    sigma_n: f64,
    /// Seed of the packing.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Depth of the clamped end sets in R̄ (spheres whose centres are within it of an end
    /// face: Kumar's spheres touching the end planes at 1). Cut bars only: a container's
    /// end sets are the spheres touching its planes.
    #[arg(long, default_value_t = 1.0)]
    clamp_depth: f64,
    /// Relative residual of the eigen-iteration (and of the deformed bar's fixed point), in
    /// [1e-12, 1e-4]. σ_network is certified within 10 × this of the lowest mode (an inertia
    /// test); a tighter one is below the solves' rounding. Not reached in 2000 iterations:
    /// an error.
    #[arg(long, default_value_t = 1e-6)]
    tolerance: f64,
    /// Skip the second eigenproblem on the bar deformed by its pre-buckling shortening (the
    /// extensible bar, Mazzilli's Eq. 15); it costs about as much again as the linear one.
    #[arg(long)]
    linear_only: bool,
    /// Also compress every bar with the integrator (Kumar's law) over this many time steps
    /// to `--dem-strain` × the linearised critical strain, and report the maximum stress
    /// and Kumar's Ẽ_kin (Eq. 16) before it; 0 (default) skips it. About 2e-7 s per
    /// sphere and step here (50,000 steps: 6 s for 600 spheres). Runs beyond 1e12 sphere ×
    /// steps (the steps with --kinetic-limit: --dem-max-steps) are refused up front.
    #[arg(long, default_value_t = 0)]
    dem_steps: usize,
    /// Final strain of the compression, in units of the linearised critical strain.
    #[arg(long, default_value_t = 2.5)]
    dem_strain: f64,
    /// Compress a bar with a stress-free geometric imperfection instead of the perfect one:
    /// the centres moved along the network's first buckling mode, this amplitude (in R̄) at
    /// its largest. 0 (default): the random packing's own imperfection only.
    #[arg(long, default_value_t = 0.0)]
    imperfection: f64,
    /// Quasi-static compression by Kumar's criterion (Eq. 16; he asks for 1e-8): the end
    /// moves at the `--dem-steps` rate only while Ẽ_kin is below this limit (checked every
    /// 1/200 of the loading) and holds still until the bar has relaxed below it otherwise;
    /// points are recorded at relaxed states only (and, flagged, where the end stopped). The
    /// hold steps come on top of `--dem-steps`.
    #[arg(long)]
    kinetic_limit: Option<f64>,
    /// Cundall local damping λ while the end holds (with `--kinetic-limit`); 0 relaxes by the
    /// bond damping alone, which is slow for the bar's own modes.
    #[arg(long, default_value_t = 0.7, requires = "kinetic_limit")]
    hold_damping: f64,
    /// Cap on the total steps (loading + holds) with `--kinetic-limit`; default 20 ×
    /// `--dem-steps`. Reaching it after the stress maximum ends the run (reported);
    /// before it is an error.
    #[arg(long, requires = "kinetic_limit")]
    dem_max_steps: Option<usize>,
    /// Output folder: buckling.csv, buckling.json, buckling.png (and with --dem-steps
    /// history_ROUTE_LR.csv: strain, stress [Pa], Ẽ_kin per bar; with --kinetic-limit also
    /// whether the point met the limit and the steps so far).
    #[arg(short, long, default_value = "anisobond-buckle")]
    output: PathBuf,
}

/// One bar of the table.
#[derive(serde::Serialize)]
struct Row {
    route: &'static str,
    slenderness: f64,
    particles: usize,
    bonds: usize,
    /// E (Pa).
    modulus: f64,
    /// 1/S'₃₃ of the periodic cell's relaxed tensor (Pa): E along the axis of the material
    /// the bar is cut from.
    modulus_cell: f64,
    /// σ_Euler, Eq. 14 (Pa).
    sigma_euler: f64,
    /// σ_Mazzilli, Eq. 15 (Pa).
    sigma_mazzilli: f64,
    /// Linearised critical stress of the network (Pa).
    sigma_network: f64,
    network_over_euler: f64,
    network_over_mazzilli: f64,
    /// Critical stress on the deformed pre-buckling geometry (Pa; nominal, ε·E).
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma_deformed: Option<f64>,
    /// σ_deformed over Mazzilli's σ(1 − σ/E) = σ_network (the extensible rod with the
    /// network's own small-strain load).
    #[serde(skip_serializing_if = "Option::is_none")]
    deformed_over_extensible_own: Option<f64>,
    /// EI/(E·πr⁴/4).
    bending_ratio: f64,
    /// P_cr/(4π²EI/l²) with the bar's own EI.
    network_over_euler_own_ei: f64,
    /// P_cr over Engesser's P_E/(1 + P_E/κGA) with the bar's own EI, κGA.
    network_over_engesser_own: f64,
    normal_force_share: f64,
    iterations: usize,
    residual: f64,
    /// DEM maximum stress (Pa), when run.
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_max_stress: Option<f64>,
    /// Strain at the DEM maximum.
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_strain_at_max: Option<f64>,
    /// Largest Ẽ_kin (Eq. 16) up to the DEM maximum.
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_max_kinetic_ratio: Option<f64>,
    /// True when the DEM maximum is the run's last point (no stress drop by the final strain).
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_peak_at_end: Option<bool>,
    /// Time steps of the compression (loading + holds).
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_total_steps: Option<usize>,
    /// True when the step cap ended the compression after the maximum (`--kinetic-limit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    dem_ran_out: Option<bool>,
}

fn check(a: &BuckleArgs) -> Result<()> {
    if a.slenderness.is_empty() || a.route.is_empty() {
        return Err(Error::Invalid(
            "--slenderness and --route need at least one value".into(),
        ));
    }
    if let Some(s) = a
        .slenderness
        .iter()
        .find(|s| !(s.is_finite() && **s > 2.0 * std::f64::consts::PI))
    {
        return Err(Error::Invalid(format!(
            "--slenderness {s}: expected l/r > 2π (Mazzilli's Eq. 15 needs k·l/r > π, k = 0.5)"
        )));
    }
    for (name, v) in [
        ("--radius-particles", a.radius_particles),
        ("--kappa", a.kappa),
        ("--sigma-n", a.sigma_n),
        ("--clamp-depth", a.clamp_depth),
        ("--dem-strain", a.dem_strain),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Invalid(format!(
                "{name} {v}: expected a finite value > 0"
            )));
        }
    }
    BucklingOptions {
        tolerance: a.tolerance,
        ..BucklingOptions::default()
    }
    .check()
    .map_err(|e| e.in_context(format!("--tolerance {}", a.tolerance)))?;
    if !(a.imperfection.is_finite() && a.imperfection >= 0.0) {
        return Err(Error::Invalid(format!(
            "--imperfection {}: expected a finite value ≥ 0 (in mean radii)",
            a.imperfection
        )));
    }
    if a.imperfection > 0.0 && a.dem_steps == 0 {
        return Err(Error::Invalid(
            "--imperfection needs --dem-steps N > 0 (it shapes the compressed bar)".into(),
        ));
    }
    if let Some(l) = a.kinetic_limit {
        if !(l.is_finite() && l > 0.0) {
            return Err(Error::Invalid(format!(
                "--kinetic-limit {l:?}: expected a finite value > 0 (Kumar's criterion: 1e-8)"
            )));
        }
        if a.dem_steps == 0 {
            return Err(Error::Invalid(
                "--kinetic-limit needs --dem-steps N > 0 (the loading steps)".into(),
            ));
        }
        if !(a.hold_damping.is_finite() && (0.0..1.0).contains(&a.hold_damping)) {
            return Err(Error::Invalid(format!(
                "--hold-damping {}: expected a value in [0, 1)",
                a.hold_damping
            )));
        }
    }
    if a.dem_steps > 0 {
        // Before any packing is made: the longest bar's spheres (as many per unit length as
        // a container bar, the count of a cut bar on average) × the steps it may take.
        let ro = RouteOptions::default();
        let longest = a.slenderness.iter().copied().fold(0.0, f64::max);
        let spheres = container_particles(a.radius_particles * ro.mean_radius, longest, &ro);
        let (steps, which) = match a.kinetic_limit {
            None => (a.dem_steps as f64, "--dem-steps"),
            Some(_) => (
                a.dem_max_steps
                    .map_or(20.0 * a.dem_steps as f64, |m| m as f64),
                "--dem-max-steps (default 20 × --dem-steps)",
            ),
        };
        check_run_size(
            &format!(
                "{which}: the compression of the l/r = {longest} bar (about {spheres} spheres)"
            ),
            spheres,
            steps,
        )?;
    }
    if let Some(m) = a.dem_max_steps {
        if m < a.dem_steps {
            return Err(Error::Invalid(format!(
                "--dem-max-steps {m}: expected at least --dem-steps ({})",
                a.dem_steps
            )));
        }
    }
    if !(a.alpha.is_finite() && a.alpha >= 0.0) {
        return Err(Error::Invalid(format!(
            "--alpha {}: expected a finite value ≥ 0",
            a.alpha
        )));
    }
    Ok(())
}

/// A ratio to four decimals, or "-" when not computed.
fn fixed4(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.4}")).unwrap_or_else(|| "-".into())
}

fn row(route: BuckleRoute, s: f64, bar: &RoundBar, r: &BucklingResult, e_cell: f64) -> Row {
    let (e, l) = (r.modulus, bar.length);
    let (se, sm) = (euler_stress(e, s), mazzilli_stress(e, s));
    Row {
        route: route.route().as_str(),
        slenderness: s,
        particles: bar.assembly.packing.len(),
        bonds: bar.assembly.bonds.len(),
        modulus: e,
        modulus_cell: e_cell,
        sigma_euler: se,
        sigma_mazzilli: sm,
        sigma_network: r.critical_stress,
        network_over_euler: r.critical_stress / se,
        network_over_mazzilli: r.critical_stress / sm,
        sigma_deformed: r.updated_geometry.map(|u| u.critical_stress),
        deformed_over_extensible_own: r
            .updated_geometry
            .map(|u| u.critical_stress / extensible_stress(r.critical_stress, e)),
        bending_ratio: r.bending_ratio(bar.area()),
        network_over_euler_own_ei: r.critical_force / r.euler_force_own(l),
        network_over_engesser_own: r.critical_force / r.engesser_force_own(l),
        normal_force_share: r.normal_force_share,
        iterations: r.iterations,
        residual: r.residuals[0].max(r.residuals[1]),
        dem_max_stress: None,
        dem_strain_at_max: None,
        dem_max_kinetic_ratio: None,
        dem_peak_at_end: None,
        dem_total_steps: None,
        dem_ran_out: None,
    }
}

/// The compression history: strain, stress (Pa), Ẽ_kin; with `--kinetic-limit` also whether
/// the point met the limit and the time steps so far.
fn history_csv(c: &CompressionResult, limited: bool) -> String {
    let mut h = String::from(if limited {
        "strain,stress [Pa],kinetic_ratio,met_limit,steps\n"
    } else {
        "strain,stress [Pa],kinetic_ratio\n"
    });
    for pt in &c.history {
        h += &format!("{:e},{:e},{:e}", pt.strain, pt.stress, pt.kinetic_ratio);
        if limited {
            h += &format!(",{},{}", pt.met_limit, pt.steps);
        }
        h.push('\n');
    }
    h
}

pub fn run(a: BuckleArgs) -> Result<()> {
    check(&a)?;
    let inputs: Vec<&std::path::Path> = a.model.as_deref().into_iter().collect();
    let mut out = OutputSet::new(&inputs);
    let dir = out.dir(&a.output)?;
    let kumar = Model {
        bonding: BondingRule::Factor(a.kappa),
        scheme: SchemeSpec::Isotropic {
            normal: a.sigma_n,
            shear: a.alpha * a.sigma_n,
        },
        geometry: Geometry {
            convention: Convention::Kumar,
            moments: Moments::Kumar,
            ..Geometry::default()
        },
    };
    let model = match &a.model {
        Some(path) => Model::from_path(path)?,
        None => kumar,
    };
    let opts = BucklingOptions {
        tolerance: a.tolerance,
        pre_buckling: if a.linear_only {
            PreBuckling::Linear
        } else {
            PreBuckling::UpdatedGeometry
        },
        ..BucklingOptions::default()
    };
    match &a.model {
        Some(path) => println!(
            "clamped round bars along z, r = {} R̄, model {}; E, σ in Pa",
            a.radius_particles,
            path.display()
        ),
        None => println!(
            "clamped round bars, r = {} R̄, α = {}, κ = {}, Σ_N = {:e} Pa; E, σ in Pa",
            a.radius_particles, a.alpha, a.kappa, a.sigma_n
        ),
    }
    println!(
        "{:<14} {:>6} {:>7} {:>11} {:>11} {:>11} {:>11} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "route",
        "l/r",
        "spheres",
        "E",
        "σ_Euler",
        "σ_Mazzilli",
        "σ_network",
        "/Euler",
        "/Mazz.",
        "EI ratio",
        "/Eng.own",
        "def/Eul",
        "def/Maz"
    );
    let mut rows = Vec::new();
    for &route in &a.route {
        let t0 = Instant::now();
        let ro = RouteOptions {
            route: route.route(),
            n_particles: a.cell_particles,
            seed: a.seed,
            ..RouteOptions::default()
        };
        let (packing, _) = prepare(&ro, &|_| {})?;
        let rbar = packing.mean_radius();
        let cell = Assembly::new(packing.clone(), model.clone())?;
        let c = relaxed_tensor(
            &cell.packing,
            &cell.bonds,
            &cell.springs,
            &RelaxedOptions::default(),
        )?
        .c;
        let e_cell = 1.0 / compliance(&c, "the cell's relaxed tensor")?[(2, 2)];
        println!(
            "  ({} cell of {} spheres prepared in {:.1} s; its relaxed tensor gives E_z = 1/S'33 = {:.4e} Pa)",
            route.route().as_str(),
            packing.len(),
            t0.elapsed().as_secs_f64(),
            e_cell
        );
        for &s in &a.slenderness {
            let t1 = Instant::now();
            let bar = match a.preparation {
                Preparation::Cut => RoundBar::cut(
                    &packing,
                    model.clone(),
                    a.radius_particles * rbar,
                    s,
                    a.clamp_depth * rbar,
                ),
                Preparation::Container => RoundBar::in_container(
                    &ro,
                    model.clone(),
                    a.radius_particles * ro.mean_radius,
                    s,
                )
                .map(|(bar, rep)| {
                    println!(
                        "  ({} container bar, l/r = {s}: {} spheres packed in {:.1} s, \
                         compressed to D = {:.4}, then affine to {})",
                        route.route().as_str(),
                        bar.assembly.packing.len(),
                        t1.elapsed().as_secs_f64(),
                        rep.compressed_solid_fraction,
                        ro.solid_fraction
                    );
                    bar
                }),
            }
            .map_err(|e| e.in_context(format!("{} bar, l/r = {s}", route.route().as_str())))?;
            let res = bar
                .buckling(&opts)
                .map_err(|e| e.in_context(format!("{} bar, l/r = {s}", route.route().as_str())))?;
            let mut r = row(route, s, &bar, &res, e_cell);
            if a.dem_steps > 0 {
                let record_every = (a.dem_steps / 200).max(1);
                let copts = CompressionOptions {
                    max_strain: a.dem_strain * res.critical_strain,
                    steps: a.dem_steps,
                    record_every,
                    loading: match a.kinetic_limit {
                        None => Loading::ConstantRate,
                        Some(limit) => Loading::KineticLimit {
                            limit,
                            check_every: record_every,
                            max_steps: a.dem_max_steps.unwrap_or(20 * a.dem_steps),
                            hold_damping: a.hold_damping,
                        },
                    },
                    ..CompressionOptions::default()
                };
                let t1 = Instant::now();
                let bar_progress =
                    super::output::progress_bar(&format!("compression {} l/r = {s}", r.route));
                let imperfect;
                let compressed = if a.imperfection > 0.0 {
                    imperfect = bar.imperfect(&res.mode, a.imperfection * rbar)?;
                    &imperfect
                } else {
                    &bar
                };
                let c = compress_clamped_bar_with_progress(compressed, &copts, &|f: f64| {
                    bar_progress.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
                });
                bar_progress.finish_and_clear();
                let c = c.map_err(|e| e.in_context(format!("{} bar, l/r = {s}", r.route)))?;
                write_string_atomic(
                    &dir.join(format!("history_{}_{s}.csv", r.route)),
                    &history_csv(&c, a.kinetic_limit.is_some()),
                )?;
                let steps = match a.kinetic_limit {
                    None => format!("{} steps", a.dem_steps),
                    Some(l) => format!(
                        "{} loading steps + holds = {} steps{}, Ẽ_kin < {l:e} at every recorded point",
                        a.dem_steps,
                        c.total_steps,
                        if c.ran_out {
                            " (step cap reached after the maximum)"
                        } else {
                            ""
                        }
                    ),
                };
                println!(
                    "  DEM {steps} ({:.1} s): σ_max = {:.4e} Pa = {:.4} σ_Euler = {:.4} σ_network \
                     at ε = {:.3e}{}; max Ẽ_kin before it {:.2e}",
                    t1.elapsed().as_secs_f64(),
                    c.max_stress,
                    c.max_stress / r.sigma_euler,
                    c.max_stress / r.sigma_network,
                    c.strain_at_max,
                    if c.peak_at_end {
                        " (the run's last point: no stress drop by the final strain)"
                    } else {
                        ""
                    },
                    c.max_kinetic_ratio_before_peak
                );
                r.dem_max_stress = Some(c.max_stress);
                r.dem_strain_at_max = Some(c.strain_at_max);
                r.dem_max_kinetic_ratio = Some(c.max_kinetic_ratio_before_peak);
                r.dem_peak_at_end = Some(c.peak_at_end);
                r.dem_total_steps = Some(c.total_steps);
                r.dem_ran_out = Some(c.ran_out);
            }
            println!(
                "{:<14} {:>6} {:>7} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>8} {:>8}",
                r.route,
                s,
                r.particles,
                r.modulus,
                r.sigma_euler,
                r.sigma_mazzilli,
                r.sigma_network,
                r.network_over_euler,
                r.network_over_mazzilli,
                r.bending_ratio,
                r.network_over_engesser_own,
                fixed4(r.sigma_deformed.map(|d| d / r.sigma_euler)),
                fixed4(r.sigma_deformed.map(|d| d / r.sigma_mazzilli))
            );
            rows.push(r);
        }
    }
    let opt = |v: Option<f64>| v.map(|x| format!("{x:e}")).unwrap_or_default();
    let mut csv = String::from(
        "route,l_over_r,particles,bonds,E [Pa],E_cell [Pa],sigma_euler [Pa],sigma_mazzilli [Pa],\
         sigma_network [Pa],network_over_euler,network_over_mazzilli,sigma_deformed [Pa],\
         deformed_over_extensible_own,bending_ratio,\
         network_over_euler_own_EI,network_over_engesser_own,normal_force_share,iterations,\
         residual,dem_max_stress [Pa],dem_strain_at_max,dem_max_kinetic_ratio,dem_peak_at_end,\
         dem_total_steps,dem_ran_out\n",
    );
    for r in &rows {
        csv += &format!(
            "{},{},{},{},{:e},{:e},{:e},{:e},{:e},{},{},{},{},{},{},{},{},{},{:e},{},{},{},{},{},{}
",
            r.route,
            r.slenderness,
            r.particles,
            r.bonds,
            r.modulus,
            r.modulus_cell,
            r.sigma_euler,
            r.sigma_mazzilli,
            r.sigma_network,
            r.network_over_euler,
            r.network_over_mazzilli,
            opt(r.sigma_deformed),
            r.deformed_over_extensible_own
                .map(|x| x.to_string())
                .unwrap_or_default(),
            r.bending_ratio,
            r.network_over_euler_own_ei,
            r.network_over_engesser_own,
            r.normal_force_share,
            r.iterations,
            r.residual,
            opt(r.dem_max_stress),
            opt(r.dem_strain_at_max),
            opt(r.dem_max_kinetic_ratio),
            r.dem_peak_at_end.map(|b| b.to_string()).unwrap_or_default(),
            r.dem_total_steps.map(|n| n.to_string()).unwrap_or_default(),
            r.dem_ran_out.map(|b| b.to_string()).unwrap_or_default()
        );
    }
    write_string_atomic(&dir.join("buckling.csv"), &csv)?;
    let mut json = serde_json::json!({
        "units": {
            "modulus": "Pa", "modulus_cell": "Pa", "sigma_euler": "Pa", "sigma_mazzilli": "Pa",
            "sigma_network": "Pa", "sigma_deformed": "Pa", "dem_max_stress": "Pa", "slenderness": "l/r (1)", "ratios": "1",
            "dem_total_steps": "time steps", "dem_kinetic_limit": "Ẽ_kin, Kumar 2016 Eq. 16 (1)"
        },
        "parameters": {
            "radius_in_mean_radii": a.radius_particles, "cell_particles": a.cell_particles,
            "preparation": match a.preparation { Preparation::Cut => "cut", Preparation::Container => "container" },
            "alpha": a.alpha, "kappa": a.kappa, "sigma_n_pa": a.sigma_n, "seed": a.seed,
            "clamp_depth_in_mean_radii": a.clamp_depth, "tolerance": a.tolerance,
            "deformed_bar": !a.linear_only, "dem_steps": a.dem_steps, "dem_strain_over_critical": a.dem_strain,
            "dem_imperfection_in_mean_radii": a.imperfection,
            "euler": "Kumar 2016 Eq. 14, k = 0.5", "mazzilli": "Kumar 2016 Eq. 15, k = 0.5"
        },
        "rows": rows,
    });
    if let Some(limit) = a.kinetic_limit {
        json["parameters"]["dem_kinetic_limit"] = limit.into();
        json["parameters"]["dem_hold_damping"] = a.hold_damping.into();
        json["parameters"]["dem_max_steps"] = a.dem_max_steps.unwrap_or(20 * a.dem_steps).into();
    }
    super::output::check_json_numbers(&json, "buckling.json")?;
    write_string_atomic(
        &dir.join("buckling.json"),
        &serde_json::to_string_pretty(&json).map_err(|e| Error::Invalid(e.to_string()))?,
    )?;
    let mut series: Vec<Series> = a
        .route
        .iter()
        .enumerate()
        .map(|(c, route)| Series {
            label: format!("network, {}", route.route().as_str()),
            points: rows
                .iter()
                .filter(|r| r.route == route.route().as_str())
                .map(|r| (r.slenderness, r.network_over_euler))
                .collect(),
            dashed: false,
            colour: Some(c),
        })
        .collect();
    if a.dem_steps > 0 {
        for (c, route) in a.route.iter().enumerate() {
            series.push(Series {
                label: format!("DEM maximum, {}", route.route().as_str()),
                points: rows
                    .iter()
                    .filter(|r| r.route == route.route().as_str())
                    .filter_map(|r| r.dem_max_stress.map(|m| (r.slenderness, m / r.sigma_euler)))
                    .collect(),
                dashed: true,
                colour: Some(c),
            });
        }
    }
    let (lo, hi) = a
        .slenderness
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(l, h), &s| (l.min(s), h.max(s)));
    let curve = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=100)
            .map(|k| lo + (hi - lo).max(1.0) * k as f64 / 100.0)
            .map(|s| (s, f(s)))
            .collect()
    };
    series.push(Series {
        label: "Mazzilli (Eq. 15)".into(),
        points: curve(&|s| mazzilli_stress(1.0, s) / euler_stress(1.0, s)),
        dashed: true,
        colour: Some(4),
    });
    series.push(Series {
        label: "Euler (Eq. 14)".into(),
        points: curve(&|_| 1.0),
        dashed: true,
        colour: Some(5),
    });
    plot_series(
        &dir.join("buckling.png"),
        &series,
        "clamped round bars: linearised critical stress",
        "l/r",
        "σ_cr / σ_Euler (1)",
    )?;
    out.commit()?;
    println!(
        "wrote {}/buckling.csv, buckling.json, buckling.png",
        a.output.display()
    );
    Ok(())
}
