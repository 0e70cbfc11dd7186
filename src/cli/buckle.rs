//! `anisobond buckle`: Kumar 2016 Sec. 5's clamped round bars at several slenderness ratios
//! and preparation routes, with the bonded network's own linearised critical stress beside
//! Euler (Eq. 14, k = 0.5) and Mazzilli (Eq. 15), E from the bar's own axial modulus.

use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::packing::PreparationRoute;
use anisobond::study::buckling::{
    run as run_study, BarPreparation, BarRow, BucklingProgress, BucklingStudyOptions,
    DEFAULT_ROUTES, DEFAULT_SLENDERNESS,
};
use anisobond::Result;
use indicatif::ProgressBar;
use std::path::PathBuf;
use std::sync::Mutex;

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

impl From<PreparationRoute> for BuckleRoute {
    fn from(r: PreparationRoute) -> Self {
        match r {
            PreparationRoute::Unjammed => BuckleRoute::Unjammed,
            PreparationRoute::WeaklyJammed => BuckleRoute::WeaklyJammed,
            PreparationRoute::Jammed => BuckleRoute::Jammed,
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

impl From<BarPreparation> for Preparation {
    fn from(p: BarPreparation) -> Self {
        match p {
            BarPreparation::Cut => Preparation::Cut,
            BarPreparation::Container => Preparation::Container,
        }
    }
}

/// The study's defaults (the library's, once).
fn d() -> BucklingStudyOptions {
    BucklingStudyOptions::default()
}

/// Options of `anisobond buckle`.
#[derive(clap::Args)]
pub struct BuckleArgs {
    /// Slenderness ratios l/r, comma-separated (Kumar 2016: 10 to 120; each > 2π, where
    /// Mazzilli's Eq. 15 has a root).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_SLENDERNESS)]
    slenderness: Vec<f64>,
    /// Preparation routes, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = DEFAULT_ROUTES.map(BuckleRoute::from))]
    route: Vec<BuckleRoute>,
    /// Bar radius r in mean particle radii R̄, the same at every l/r (so the particles per
    /// unit length are the same, as Kumar's).
    #[arg(long, default_value_t = d().radius_particles)]
    radius_particles: f64,
    /// How the bars are prepared: cut from a periodic cell, or packed one by one in a rigid
    /// cylinder and two planes (Kumar's; as many spheres per unit length as a cut bar).
    #[arg(long, value_enum, default_value_t = d().preparation.into())]
    preparation: Preparation,
    /// Particles of the periodic cell (Kumar's route, R̄ = 1 mm ± 5 %, D = 0.65) that the
    /// bars are cut from; the cell is tiled along the bar.
    #[arg(long, default_value_t = d().cell_particles)]
    cell_particles: usize,
    /// A model file (docs/formats.md) instead of Kumar's bonds (then --alpha, --kappa and
    /// --sigma-n are not used): e.g. a cubic crystal rotated so that <100> or <111> lies
    /// along the bar axis z. E along the axis is compared with 1/S'₃₃ of the periodic cell's
    /// relaxed tensor.
    #[arg(long, conflicts_with_all = ["alpha", "kappa", "sigma_n"])]
    model: Option<PathBuf>,
    /// α = Σ_T/Σ_N, tangential to normal bond stiffness (Kumar 2016: 0.2).
    #[arg(long, default_value_t = d().alpha)]
    alpha: f64,
    /// κ, interaction range of the bonding (Kumar 2016 Eq. 10: 1).
    #[arg(long, default_value_t = d().kappa)]
    kappa: f64,
    /// Σ_N, normal bond stiffness magnitude (Pa; Kumar Eqs. 1–3). Stresses scale with it.
    #[arg(long, default_value_t = d().sigma_n)]
    sigma_n: f64,
    /// Seed of the packing.
    #[arg(long, default_value_t = d().seed)]
    seed: u64,
    /// Depth of the clamped end sets in R̄ (spheres whose centres are within it of an end
    /// face: Kumar's spheres touching the end planes at 1). Cut bars only: a container's
    /// end sets are the spheres touching its planes.
    #[arg(long, default_value_t = d().clamp_depth)]
    clamp_depth: f64,
    /// Relative residual of the eigen-iteration (and of the deformed bar's fixed point), in
    /// [1e-12, 1e-4]. σ_network is certified within 10 × this of the lowest mode (an inertia
    /// test); a tighter one is below the solves' rounding. Not reached in 2000 iterations:
    /// an error.
    #[arg(long, default_value_t = d().tolerance)]
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
    #[arg(long, default_value_t = d().dem_steps)]
    dem_steps: usize,
    /// Final strain of the compression, in units of the linearised critical strain.
    #[arg(long, default_value_t = d().dem_strain)]
    dem_strain: f64,
    /// Compress a bar with a stress-free geometric imperfection instead of the perfect one:
    /// the centres moved along the network's first buckling mode, this amplitude (in R̄) at
    /// its largest. 0 (default): the random packing's own imperfection only.
    #[arg(long, default_value_t = d().imperfection)]
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
    #[arg(long, default_value_t = d().hold_damping, requires = "kinetic_limit")]
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

impl BuckleArgs {
    /// The study's options (the model file read).
    fn options(&self) -> Result<BucklingStudyOptions> {
        Ok(BucklingStudyOptions {
            slenderness: self.slenderness.clone(),
            routes: self.route.iter().map(|r| r.route()).collect(),
            radius_particles: self.radius_particles,
            preparation: match self.preparation {
                Preparation::Cut => BarPreparation::Cut,
                Preparation::Container => BarPreparation::Container,
            },
            cell_particles: self.cell_particles,
            model: self.model.as_deref().map(Model::from_path).transpose()?,
            alpha: self.alpha,
            kappa: self.kappa,
            sigma_n: self.sigma_n,
            seed: self.seed,
            clamp_depth: self.clamp_depth,
            tolerance: self.tolerance,
            deformed: !self.linear_only,
            dem_steps: self.dem_steps,
            dem_strain: self.dem_strain,
            imperfection: self.imperfection,
            kinetic_limit: self.kinetic_limit,
            hold_damping: self.hold_damping,
            dem_max_steps: self.dem_max_steps,
        })
    }
}

/// A ratio to four decimals, or "-" when not computed.
fn fixed4(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.4}")).unwrap_or_else(|| "-".into())
}

/// The table's header, after the line naming the bars.
fn print_header(a: &BuckleArgs) {
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
}

/// A bar's line of the table.
fn print_row(r: &BarRow) {
    let maz = r.sigma_mazzilli_pa.unwrap_or(f64::NAN);
    println!(
        "{:<14} {:>6} {:>7} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>8} {:>8}",
        r.route.unwrap_or_default(),
        r.slenderness,
        r.particles,
        r.modulus_pa,
        r.sigma_euler_pa,
        maz,
        r.sigma_network_pa,
        r.network_over_euler,
        r.network_over_mazzilli.unwrap_or(f64::NAN),
        r.bending_ratio,
        r.network_over_engesser_own.unwrap_or(f64::NAN),
        fixed4(r.sigma_deformed_pa.map(|d| d / r.sigma_euler_pa)),
        fixed4(r.sigma_deformed_pa.map(|d| d / maz))
    );
}

/// The line after a bar's compression.
fn print_compressed(a: &BuckleArgs, r: &BarRow, seconds: f64) {
    let steps = match a.kinetic_limit {
        None => format!("{} steps", a.dem_steps),
        Some(l) => format!(
            "{} loading steps + holds = {} steps{}, Ẽ_kin < {l:e} at every recorded point",
            a.dem_steps,
            r.dem_total_steps.unwrap_or_default(),
            if r.dem_ran_out == Some(true) {
                " (step cap reached after the maximum)"
            } else {
                ""
            }
        ),
    };
    let max = r.dem_max_stress_pa.unwrap_or(f64::NAN);
    println!(
        "  DEM {steps} ({seconds:.1} s): σ_max = {max:.4e} Pa = {:.4} σ_Euler = {:.4} σ_network \
         at ε = {:.3e}{}; max Ẽ_kin before it {:.2e}",
        max / r.sigma_euler_pa,
        max / r.sigma_network_pa,
        r.dem_strain_at_max.unwrap_or(f64::NAN),
        if r.dem_peak_at_end == Some(true) {
            " (the run's last point: no stress drop by the final strain)"
        } else {
            ""
        },
        r.dem_max_kinetic_ratio.unwrap_or(f64::NAN)
    );
}

/// What the study reports as it goes, printed (a progress bar per compression).
fn print_progress(a: &BuckleArgs, bar: &Mutex<Option<ProgressBar>>, p: BucklingProgress) {
    match p {
        BucklingProgress::Cell {
            route,
            spheres,
            seconds,
            modulus_cell_pa,
        } => println!(
            "  ({} cell of {spheres} spheres prepared in {seconds:.1} s; its relaxed tensor gives E_z = 1/S'33 = {modulus_cell_pa:.4e} Pa)",
            route.as_str(),
        ),
        BucklingProgress::ContainerBar {
            route,
            slenderness,
            spheres,
            seconds,
            compressed_solid_fraction,
            solid_fraction,
        } => println!(
            "  ({} container bar, l/r = {slenderness}: {spheres} spheres packed in {seconds:.1} s, \
             compressed to D = {compressed_solid_fraction:.4}, then affine to {solid_fraction})",
            route.as_str(),
        ),
        BucklingProgress::Compression { row, fraction } => {
            let mut b = bar.lock().unwrap_or_else(|e| e.into_inner());
            let b = b.get_or_insert_with(|| {
                super::output::progress_bar(&format!(
                    "compression {} l/r = {}",
                    row.route.unwrap_or_default(),
                    row.slenderness
                ))
            });
            b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
        }
        BucklingProgress::Compressed { row, seconds } => {
            if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
                b.finish_and_clear();
            }
            print_compressed(a, row, seconds);
        }
        BucklingProgress::Row(r) => print_row(r),
    }
}

/// Run `anisobond buckle`: the library's study, its table printed as it goes.
pub fn run(a: BuckleArgs) -> Result<()> {
    let opts = a.options()?;
    opts.check(anisobond::study::OptionNames::Flags)?;
    let inputs: Vec<&std::path::Path> = a.model.as_deref().into_iter().collect();
    let mut out = OutputSet::new(&inputs);
    let dir = out.dir(&a.output)?;
    print_header(&a);
    let bar = Mutex::new(None);
    let report = run_study(&opts, &|p| print_progress(&a, &bar, p));
    if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
        b.finish_and_clear();
    }
    report?.write(&dir, &opts.routes)?;
    out.commit()?;
    println!(
        "wrote {}/buckling.csv, buckling.json, buckling.png",
        a.output.display()
    );
    Ok(())
}
