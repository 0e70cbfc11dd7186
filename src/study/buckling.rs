//! Kumar 2016 Sec. 5's clamped round bars (docs/buckling.md): bars of several slenderness
//! ratios, packed by several routes, with the bonded network's own linearised critical stress
//! beside Euler (Eq. 14, k = 0.5) and Mazzilli (Eq. 15), E from the bar's own axial modulus;
//! optionally compressed with the integrator. [`run`] makes the [`BucklingReport`] that
//! `anisobond buckle` writes (buckling.json, buckling.csv, buckling.png, history_*.csv);
//! [`BarRow`] is also what `anisobond.buckle_bar` returns for one bar.
//!
//! One small bar (l/r = 10, r = 4 R̄, cut from a 500-sphere cell): σ_Euler is Kumar's Eq. 14
//! with k = 0.5 for a round bar, π²E/(l/r)², with the bar's own E.
//! ```
//! use anisobond::packing::PreparationRoute;
//! use anisobond::study::buckling::{run, BucklingStudyOptions};
//! let opts = BucklingStudyOptions {
//!     slenderness: vec![10.0],
//!     routes: vec![PreparationRoute::Unjammed],
//!     radius_particles: 4.0,
//!     cell_particles: 500,
//!     ..Default::default()
//! };
//! let report = run(&opts, &|_| {}).unwrap();
//! let bar = &report.rows[0];
//! let euler = std::f64::consts::PI.powi(2) * bar.modulus_pa / 100.0;
//! assert!((bar.sigma_euler_pa - euler).abs() <= 1e-9 * euler);
//! println!("σ_network / σ_Euler = {:.3}", bar.network_over_euler);
//! ```

use super::{finite, require_finite, OptionNames};
use crate::assembly::Assembly;
use crate::bonds::BondingRule;
use crate::dem::buckling::{
    compress_clamped_bar_with_progress, CompressionOptions, CompressionResult, Loading,
};
use crate::dem::check_run_size;
use crate::homogenize::buckling::{
    euler_stress, extensible_stress, mazzilli_stress, BucklingOptions, BucklingResult, PreBuckling,
    RoundBar,
};
use crate::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use crate::model::{Model, SchemeSpec};
use crate::packing::container::container_particles;
use crate::packing::routes::{prepare, PreparationRoute, RouteOptions};
use crate::packing::Packing;
#[cfg(feature = "plot")]
use crate::plot::{plot_series, Series};
use crate::schemes::{Convention, Geometry, Moments};
use crate::tensor::elastic::compliance;
use crate::{Error, Result};
use std::time::Instant;

/// How the bars' spheres are packed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BarPreparation {
    /// Cut out of one periodic cell per route (tiled along the bar).
    Cut,
    /// Kumar's own: each bar packed by the route inside a rigid cylinder of radius r and two
    /// planes, which are then removed; the spheres touching the planes are clamped.
    Container,
}

impl BarPreparation {
    /// The name in buckling.json (`cut`, `container`).
    pub fn as_str(self) -> &'static str {
        match self {
            BarPreparation::Cut => "cut",
            BarPreparation::Container => "container",
        }
    }
}

/// Slenderness ratios of the default study (Kumar 2016: 10 to 120).
pub const DEFAULT_SLENDERNESS: [f64; 5] = [10.0, 20.0, 40.0, 80.0, 120.0];
/// Routes of the default study (Kumar 2016 Sec. 3).
pub const DEFAULT_ROUTES: [PreparationRoute; 3] = [
    PreparationRoute::Unjammed,
    PreparationRoute::WeaklyJammed,
    PreparationRoute::Jammed,
];

/// The options of the study; [`Default`] is Kumar 2016's study (the defaults of
/// `anisobond buckle`). Lengths in mean particle radii R̄ where so named.
#[derive(Clone, Debug)]
pub struct BucklingStudyOptions {
    /// Slenderness ratios l/r (each > 2π, where Mazzilli's Eq. 15 has a root).
    pub slenderness: Vec<f64>,
    /// Preparation routes.
    pub routes: Vec<PreparationRoute>,
    /// Bar radius r in R̄, the same at every l/r.
    pub radius_particles: f64,
    /// Cut from a periodic cell, or packed one by one in a container.
    pub preparation: BarPreparation,
    /// Particles of the periodic cell the bars are cut from (also E_cell's cell).
    pub cell_particles: usize,
    /// A model instead of Kumar's bonds (then `alpha`, `kappa`, `sigma_n` are not used).
    pub model: Option<Model>,
    /// α = Σ_T/Σ_N (Kumar 2016: 0.2).
    pub alpha: f64,
    /// κ, interaction range of the bonding (Kumar 2016 Eq. 10: 1).
    pub kappa: f64,
    /// Σ_N, normal bond stiffness magnitude (Pa; Kumar Eqs. 1–3).
    pub sigma_n: f64,
    /// Seed of the packing.
    pub seed: u64,
    /// Depth of the clamped end sets in R̄ (cut bars).
    pub clamp_depth: f64,
    /// Relative residual of the eigen-iteration, in [1e-12, 1e-4].
    pub tolerance: f64,
    /// Also solve the bar deformed by its pre-buckling shortening (Mazzilli's Eq. 15).
    pub deformed: bool,
    /// Time steps of the integrator's compression of every bar; 0 skips it.
    pub dem_steps: usize,
    /// Final strain of the compression, in units of the linearised critical strain.
    pub dem_strain: f64,
    /// Amplitude (R̄) of a stress-free imperfection along the first mode; 0: none.
    pub imperfection: f64,
    /// Kumar's quasi-static criterion on Ẽ_kin (Eq. 16); `None`: constant rate.
    pub kinetic_limit: Option<f64>,
    /// Cundall local damping while the end holds (with `kinetic_limit`).
    pub hold_damping: f64,
    /// Cap on all steps with `kinetic_limit`; `None`: 20 × `dem_steps`.
    pub dem_max_steps: Option<usize>,
}

impl Default for BucklingStudyOptions {
    fn default() -> Self {
        BucklingStudyOptions {
            slenderness: DEFAULT_SLENDERNESS.to_vec(),
            routes: DEFAULT_ROUTES.to_vec(),
            radius_particles: 5.0,
            preparation: BarPreparation::Cut,
            cell_particles: 1000,
            model: None,
            alpha: 0.2,
            kappa: 1.0,
            sigma_n: 1.0e8,
            seed: 1,
            clamp_depth: 1.0,
            tolerance: BucklingOptions::default().tolerance,
            deformed: true,
            dem_steps: 0,
            dem_strain: 2.5,
            imperfection: 0.0,
            kinetic_limit: None,
            hold_damping: 0.7,
            dem_max_steps: None,
        }
    }
}

/// Kumar 2016's bonds (Eqs. 1–3, 10): isotropic Σ_N and α·Σ_N, range factor κ, his radius
/// convention and moments.
pub fn kumar_model(alpha: f64, kappa: f64, sigma_n: f64) -> Model {
    Model {
        bonding: BondingRule::Factor(kappa),
        scheme: SchemeSpec::Isotropic {
            normal: sigma_n,
            shear: alpha * sigma_n,
        },
        geometry: Geometry {
            convention: Convention::Kumar,
            moments: Moments::Kumar,
            ..Geometry::default()
        },
        strength: None,
        manybody: None,
        grains: None,
    }
}

impl BucklingStudyOptions {
    /// The model the bars are bonded by: `model`, or Kumar's bonds of `alpha`, `kappa`,
    /// `sigma_n`.
    pub fn bar_model(&self) -> Model {
        self.model
            .clone()
            .unwrap_or_else(|| kumar_model(self.alpha, self.kappa, self.sigma_n))
    }

    /// The step cap of the compression with `kinetic_limit`.
    pub fn max_steps(&self) -> usize {
        self.dem_max_steps.unwrap_or(20 * self.dem_steps)
    }

    /// The eigen-solver's options.
    fn buckling_options(&self) -> BucklingOptions {
        BucklingOptions {
            tolerance: self.tolerance,
            pre_buckling: if self.deformed {
                PreBuckling::UpdatedGeometry
            } else {
                PreBuckling::Linear
            },
            ..BucklingOptions::default()
        }
    }

    /// Refuse options that cannot give a result, before any packing is made; messages name
    /// the options as `names` does.
    pub fn check(&self, names: OptionNames) -> Result<()> {
        let n = |f: &str| names.name(f);
        if self.slenderness.is_empty() || self.routes.is_empty() {
            return Err(Error::Invalid(format!(
                "{} and {} need at least one value",
                n("slenderness"),
                n("route")
            )));
        }
        if let Some(s) = self
            .slenderness
            .iter()
            .find(|s| !(s.is_finite() && **s > 2.0 * std::f64::consts::PI))
        {
            return Err(Error::Invalid(format!(
                "{} {s}: expected l/r > 2π (Mazzilli's Eq. 15 needs k·l/r > π, k = 0.5)",
                n("slenderness")
            )));
        }
        names.require_positive(&[
            ("radius_particles", self.radius_particles),
            ("kappa", self.kappa),
            ("sigma_n", self.sigma_n),
            ("clamp_depth", self.clamp_depth),
            ("dem_strain", self.dem_strain),
        ])?;
        self.buckling_options()
            .check()
            .map_err(|e| e.in_context(format!("{} {}", n("tolerance"), self.tolerance)))?;
        self.check_compression(names)?;
        if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            return Err(Error::Invalid(format!(
                "{} {}: expected a finite value ≥ 0",
                n("alpha"),
                self.alpha
            )));
        }
        Ok(())
    }

    /// The compression's options: imperfection, kinetic limit, hold damping, step counts.
    fn check_compression(&self, names: OptionNames) -> Result<()> {
        let n = |f: &str| names.name(f);
        if !(self.imperfection.is_finite() && self.imperfection >= 0.0) {
            return Err(Error::Invalid(format!(
                "{} {}: expected a finite value ≥ 0 (in mean radii)",
                n("imperfection"),
                self.imperfection
            )));
        }
        if self.imperfection > 0.0 && self.dem_steps == 0 {
            return Err(Error::Invalid(format!(
                "{} needs {} N > 0 (it shapes the compressed bar)",
                n("imperfection"),
                n("dem_steps")
            )));
        }
        if let Some(l) = self.kinetic_limit {
            if !(l.is_finite() && l > 0.0) {
                return Err(Error::Invalid(format!(
                    "{} {l:?}: expected a finite value > 0 (Kumar's criterion: 1e-8)",
                    n("kinetic_limit")
                )));
            }
            if self.dem_steps == 0 {
                return Err(Error::Invalid(format!(
                    "{} needs {} N > 0 (the loading steps)",
                    n("kinetic_limit"),
                    n("dem_steps")
                )));
            }
            if !(self.hold_damping.is_finite() && (0.0..1.0).contains(&self.hold_damping)) {
                return Err(Error::Invalid(format!(
                    "{} {}: expected a value in [0, 1)",
                    n("hold_damping"),
                    self.hold_damping
                )));
            }
        }
        if self.dem_steps > 0 {
            self.check_run_size(names)?;
        }
        if let Some(m) = self.dem_max_steps {
            if m < self.dem_steps {
                return Err(Error::Invalid(format!(
                    "{} {m}: expected at least {} ({})",
                    n("dem_max_steps"),
                    n("dem_steps"),
                    self.dem_steps
                )));
            }
        }
        Ok(())
    }

    /// Before any packing is made: the longest bar's spheres (as many per unit length as a
    /// container bar, the count of a cut bar on average) × the steps it may take.
    fn check_run_size(&self, names: OptionNames) -> Result<()> {
        let n = |f: &str| names.name(f);
        let ro = RouteOptions::default();
        let longest = self.slenderness.iter().copied().fold(0.0, f64::max);
        let spheres = container_particles(self.radius_particles * ro.mean_radius, longest, &ro);
        let (steps, which) = match self.kinetic_limit {
            None => (self.dem_steps as f64, n("dem_steps")),
            Some(_) => (
                self.dem_max_steps
                    .map_or(20.0 * self.dem_steps as f64, |m| m as f64),
                format!("{} (default 20 × {})", n("dem_max_steps"), n("dem_steps")),
            ),
        };
        check_run_size(
            &format!(
                "{which}: the compression of the l/r = {longest} bar (about {spheres} spheres)"
            ),
            spheres,
            steps,
        )
    }
}

/// One bar of the study: the one schema of buckling.json's rows and of
/// `anisobond.buckle_bar`'s dict. Stresses in Pa, lengths in m, forces in N (the unit in
/// the key); ratios are 1. `None` (null) where a value has no finite value or was not run.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BarRow {
    /// Preparation route (the study; `None` for a bar of a given packing).
    pub route: Option<&'static str>,
    /// l/r.
    pub slenderness: f64,
    /// Bar radius r (m).
    pub radius_m: f64,
    /// Bar length l (m).
    pub length_m: f64,
    /// Spheres of the bar.
    pub particles: usize,
    /// Bonds of the bar.
    pub bonds: usize,
    /// The bar's own axial modulus E (Pa).
    pub modulus_pa: f64,
    /// 1/S'₃₃ of the periodic cell's relaxed tensor (Pa): E along the axis of the material
    /// the bar is cut from (the study only).
    pub modulus_cell_pa: Option<f64>,
    /// σ_Euler, Kumar 2016 Eq. 14 (Pa).
    pub sigma_euler_pa: f64,
    /// σ_Mazzilli, Eq. 15 (Pa); `None` below l/r = 2π (no root).
    pub sigma_mazzilli_pa: Option<f64>,
    /// Linearised critical stress of the network (Pa).
    pub sigma_network_pa: f64,
    /// σ_network / σ_Euler.
    pub network_over_euler: f64,
    /// σ_network / σ_Mazzilli.
    pub network_over_mazzilli: Option<f64>,
    /// Critical stress on the deformed pre-buckling geometry (Pa; nominal, ε·E).
    pub sigma_deformed_pa: Option<f64>,
    /// σ_deformed over Mazzilli's σ(1 − σ/E) = σ_network (the extensible rod with the
    /// network's own small-strain load).
    pub deformed_over_extensible_own: Option<f64>,
    /// EI/(E·πr⁴/4).
    pub bending_ratio: f64,
    /// P_cr/(4π²EI/l²) with the bar's own EI.
    pub network_over_euler_own_ei: f64,
    /// P_cr over Engesser's P_E/(1 + P_E/κGA) with the bar's own EI, κGA.
    pub network_over_engesser_own: Option<f64>,
    /// κGA of the bar (N); `None` for a bar without measurable shear flexibility.
    pub shear_stiffness_n: Option<f64>,
    /// Share of the axial stress carried by the bonds' normal forces.
    pub normal_force_share: f64,
    /// Subspace iterations.
    pub iterations: usize,
    /// Larger of the two lowest modes' final residuals.
    pub residual: f64,
    /// DEM maximum stress (Pa), when run.
    pub dem_max_stress_pa: Option<f64>,
    /// Strain at the DEM maximum.
    pub dem_strain_at_max: Option<f64>,
    /// Largest Ẽ_kin (Eq. 16) up to the DEM maximum.
    pub dem_max_kinetic_ratio: Option<f64>,
    /// True when the DEM maximum is the run's last point (no stress drop by the final strain).
    pub dem_peak_at_end: Option<bool>,
    /// Time steps of the compression (loading + holds).
    pub dem_total_steps: Option<usize>,
    /// True when the step cap ended the compression after the maximum.
    pub dem_ran_out: Option<bool>,
    /// The network's full result (EI, load factors, solver figures, the deformed bar).
    pub network: BucklingResult,
}

impl BarRow {
    /// The row of `bar` of slenderness `s` and its buckling result `r`; refuses a result
    /// whose stresses or ratios are not finite.
    pub fn new(
        route: Option<PreparationRoute>,
        s: f64,
        bar: &RoundBar,
        r: &BucklingResult,
        modulus_cell: Option<f64>,
    ) -> Result<BarRow> {
        let (e, l) = (r.modulus, bar.length);
        let (se, sm) = (euler_stress(e, s), finite(mazzilli_stress(e, s)));
        let sn = r.critical_stress;
        let ratio = |x: f64, what: &str| require_finite(x, &format!("buckling: {what}"));
        Ok(BarRow {
            route: route.map(PreparationRoute::as_str),
            slenderness: s,
            radius_m: bar.radius,
            length_m: l,
            particles: bar.assembly.packing.len(),
            bonds: bar.assembly.bonds.len(),
            modulus_pa: ratio(e, "E")?,
            modulus_cell_pa: modulus_cell,
            sigma_euler_pa: ratio(se, "σ_Euler")?,
            sigma_mazzilli_pa: sm,
            sigma_network_pa: ratio(sn, "σ_network")?,
            network_over_euler: ratio(sn / se, "σ_network/σ_Euler")?,
            network_over_mazzilli: sm.and_then(|m| finite(sn / m)),
            sigma_deformed_pa: r.updated_geometry.map(|u| u.critical_stress),
            deformed_over_extensible_own: r
                .updated_geometry
                .map(|u| u.critical_stress / extensible_stress(sn, e)),
            bending_ratio: ratio(r.bending_ratio(bar.area()), "EI ratio")?,
            network_over_euler_own_ei: ratio(
                r.critical_force / r.euler_force_own(l),
                "P_cr over Euler with the bar's EI",
            )?,
            network_over_engesser_own: finite(r.critical_force / r.engesser_force_own(l)),
            shear_stiffness_n: finite(r.shear_stiffness(l)),
            normal_force_share: r.normal_force_share,
            iterations: r.iterations,
            residual: r.residuals[0].max(r.residuals[1]),
            network: r.clone(),
            // The DEM columns: filled by a compression ([`BarRow::set_compression`]).
            ..BarRow::default()
        })
    }

    /// Fill the DEM columns from a compression.
    fn set_compression(&mut self, c: &CompressionResult) {
        self.dem_max_stress_pa = Some(c.max_stress);
        self.dem_strain_at_max = Some(c.strain_at_max);
        self.dem_max_kinetic_ratio = Some(c.max_kinetic_ratio_before_peak);
        self.dem_peak_at_end = Some(c.peak_at_end);
        self.dem_total_steps = Some(c.total_steps);
        self.dem_ran_out = Some(c.ran_out);
    }
}

/// What [`run`] reports as it goes (the library never prints; a client may).
pub enum BucklingProgress<'a> {
    /// A route's periodic cell is prepared and its relaxed tensor solved.
    Cell {
        /// The route.
        route: PreparationRoute,
        /// Its spheres.
        spheres: usize,
        /// Seconds for both.
        seconds: f64,
        /// 1/S'₃₃ of its relaxed tensor (Pa).
        modulus_cell_pa: f64,
    },
    /// A container bar is packed.
    ContainerBar {
        /// The route.
        route: PreparationRoute,
        /// l/r.
        slenderness: f64,
        /// Its spheres.
        spheres: usize,
        /// Seconds to pack it.
        seconds: f64,
        /// Solid fraction of the compressed state.
        compressed_solid_fraction: f64,
        /// Solid fraction after the affine step.
        solid_fraction: f64,
    },
    /// The compression of a bar advances (`fraction` of its loading done, 0–1).
    Compression {
        /// The bar's row (DEM columns not yet filled).
        row: &'a BarRow,
        /// Completed fraction.
        fraction: f64,
    },
    /// A bar's compression is done (its DEM columns are filled).
    Compressed {
        /// The bar's row.
        row: &'a BarRow,
        /// Seconds the compression took.
        seconds: f64,
    },
    /// A bar is done.
    Row(&'a BarRow),
}

/// The study's report: buckling.json ([`BucklingReport::to_json`]), buckling.csv
/// ([`BucklingReport::to_csv`]), the plot and the compression histories.
#[derive(serde::Serialize)]
pub struct BucklingReport {
    /// Units of the keys without a unit suffix.
    pub units: serde_json::Value,
    /// The options the study ran with.
    pub parameters: serde_json::Value,
    /// One row per bar, routes outer, slenderness inner.
    pub rows: Vec<BarRow>,
    /// `history_ROUTE_LR.csv` per compressed bar: file name and text.
    #[serde(skip)]
    pub histories: Vec<(String, String)>,
}

/// The compression history: strain, stress (Pa), Ẽ_kin; with a kinetic limit also whether
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

/// The study's `parameters` section.
fn parameters(o: &BucklingStudyOptions) -> serde_json::Value {
    let mut p = serde_json::json!({
        "radius_in_mean_radii": o.radius_particles, "cell_particles": o.cell_particles,
        "preparation": o.preparation.as_str(),
        "alpha": o.alpha, "kappa": o.kappa, "sigma_n_pa": o.sigma_n, "seed": o.seed,
        "clamp_depth_in_mean_radii": o.clamp_depth, "tolerance": o.tolerance,
        "deformed_bar": o.deformed, "dem_steps": o.dem_steps,
        "dem_strain_over_critical": o.dem_strain,
        "dem_imperfection_in_mean_radii": o.imperfection,
        "euler": "Kumar 2016 Eq. 14, k = 0.5", "mazzilli": "Kumar 2016 Eq. 15, k = 0.5"
    });
    if let Some(limit) = o.kinetic_limit {
        p["dem_kinetic_limit"] = limit.into();
        p["dem_hold_damping"] = o.hold_damping.into();
        p["dem_max_steps"] = o.max_steps().into();
    }
    p
}

/// Run the study: per route a periodic cell (its relaxed tensor's 1/S'₃₃), per slenderness
/// a bar, its linearised buckling and, with `dem_steps`, its compression. Refuses what
/// [`BucklingStudyOptions::check`] refuses (named as flags) before any work.
pub fn run(
    opts: &BucklingStudyOptions,
    progress: &(dyn Fn(BucklingProgress) + Sync),
) -> Result<BucklingReport> {
    opts.check(OptionNames::Flags)?;
    let model = opts.bar_model();
    let mut report = BucklingReport {
        units: serde_json::json!({
            "*_pa": "Pa", "*_m": "m", "*_n": "N", "slenderness": "l/r (1)", "ratios": "1",
            "dem_total_steps": "time steps", "dem_kinetic_limit": "Ẽ_kin, Kumar 2016 Eq. 16 (1)"
        }),
        parameters: parameters(opts),
        rows: Vec::new(),
        histories: Vec::new(),
    };
    for &route in &opts.routes {
        let (ro, packing, e_cell) = route_cell(opts, route, &model, progress)?;
        for &s in &opts.slenderness {
            let row = bar_row(
                opts,
                &ro,
                &packing,
                e_cell,
                s,
                &model,
                &mut report,
                progress,
            )?;
            progress(BucklingProgress::Row(&row));
            report.rows.push(row);
        }
    }
    Ok(report)
}

/// A route's periodic cell and E along z of its relaxed tensor (Pa).
fn route_cell(
    opts: &BucklingStudyOptions,
    route: PreparationRoute,
    model: &Model,
    progress: &(dyn Fn(BucklingProgress) + Sync),
) -> Result<(RouteOptions, Packing, f64)> {
    let t0 = Instant::now();
    let ro = RouteOptions {
        route,
        n_particles: opts.cell_particles,
        seed: opts.seed,
        ..RouteOptions::default()
    };
    let (packing, _) = prepare(&ro, &|_| {})?;
    let cell = Assembly::new(packing.clone(), model.clone())?;
    let c = relaxed_tensor(
        &cell.packing,
        &cell.bonds,
        &cell.springs,
        &RelaxedOptions::default(),
    )?
    .c;
    let e_cell = 1.0 / compliance(&c, "the cell's relaxed tensor")?[(2, 2)];
    progress(BucklingProgress::Cell {
        route,
        spheres: packing.len(),
        seconds: t0.elapsed().as_secs_f64(),
        modulus_cell_pa: e_cell,
    });
    Ok((ro, packing, e_cell))
}

/// One bar: made, buckled and (with `dem_steps`) compressed; its history goes into `report`.
#[allow(clippy::too_many_arguments)]
fn bar_row(
    opts: &BucklingStudyOptions,
    ro: &RouteOptions,
    packing: &Packing,
    e_cell: f64,
    s: f64,
    model: &Model,
    report: &mut BucklingReport,
    progress: &(dyn Fn(BucklingProgress) + Sync),
) -> Result<BarRow> {
    let route = ro.route;
    let context = |e: Error| e.in_context(format!("{} bar, l/r = {s}", route.as_str()));
    let rbar = packing.mean_radius();
    let bar = make_bar(opts, ro, packing, s, model, progress).map_err(context)?;
    let res = bar.buckling(&opts.buckling_options()).map_err(context)?;
    let mut row = BarRow::new(Some(route), s, &bar, &res, Some(e_cell))?;
    if opts.dem_steps > 0 {
        let t1 = Instant::now();
        let c = compress(opts, &bar, &res, rbar, &row, progress).map_err(context)?;
        report.histories.push((
            format!("history_{}_{s}.csv", route.as_str()),
            history_csv(&c, opts.kinetic_limit.is_some()),
        ));
        row.set_compression(&c);
        progress(BucklingProgress::Compressed {
            row: &row,
            seconds: t1.elapsed().as_secs_f64(),
        });
    }
    Ok(row)
}

/// The bar of slenderness `s`: cut from `packing`, or packed in its own container.
fn make_bar(
    opts: &BucklingStudyOptions,
    ro: &RouteOptions,
    packing: &Packing,
    s: f64,
    model: &Model,
    progress: &(dyn Fn(BucklingProgress) + Sync),
) -> Result<RoundBar> {
    let rbar = packing.mean_radius();
    match opts.preparation {
        BarPreparation::Cut => RoundBar::cut(
            packing,
            model.clone(),
            opts.radius_particles * rbar,
            s,
            opts.clamp_depth * rbar,
        ),
        BarPreparation::Container => {
            let t1 = Instant::now();
            let (bar, rep) = RoundBar::in_container(
                ro,
                model.clone(),
                opts.radius_particles * ro.mean_radius,
                s,
            )?;
            progress(BucklingProgress::ContainerBar {
                route: ro.route,
                slenderness: s,
                spheres: bar.assembly.packing.len(),
                seconds: t1.elapsed().as_secs_f64(),
                compressed_solid_fraction: rep.compressed_solid_fraction,
                solid_fraction: ro.solid_fraction,
            });
            Ok(bar)
        }
    }
}

/// The integrator's compression of `bar` (or of its imperfect copy) to `dem_strain` × the
/// linearised critical strain.
fn compress(
    opts: &BucklingStudyOptions,
    bar: &RoundBar,
    res: &BucklingResult,
    rbar: f64,
    row: &BarRow,
    progress: &(dyn Fn(BucklingProgress) + Sync),
) -> Result<CompressionResult> {
    let record_every = (opts.dem_steps / 200).max(1);
    let copts = CompressionOptions {
        max_strain: opts.dem_strain * res.critical_strain,
        steps: opts.dem_steps,
        record_every,
        loading: match opts.kinetic_limit {
            None => Loading::ConstantRate,
            Some(limit) => Loading::KineticLimit {
                limit,
                check_every: record_every,
                max_steps: opts.max_steps(),
                hold_damping: opts.hold_damping,
            },
        },
        ..CompressionOptions::default()
    };
    let imperfect;
    let compressed = if opts.imperfection > 0.0 {
        imperfect = bar.imperfect(&res.mode, opts.imperfection * rbar)?;
        &imperfect
    } else {
        bar
    };
    compress_clamped_bar_with_progress(compressed, &copts, &|f: f64| {
        progress(BucklingProgress::Compression { row, fraction: f })
    })
}

impl BucklingReport {
    /// buckling.json: the report as pretty JSON; refuses a non-finite number in any field
    /// (JSON would write it as `null`, which here means "no finite value by definition").
    pub fn to_json(&self) -> Result<String> {
        crate::io::check_json_numbers(&self.units, "buckling.json units")?;
        crate::io::check_json_numbers(&self.parameters, "buckling.json parameters")?;
        for (i, row) in self.rows.iter().enumerate() {
            crate::io::refuse_non_finite(row, &format!("buckling.json rows[{i}]"))?;
        }
        serde_json::to_string_pretty(self)
            .map_err(|e| Error::Invalid(format!("buckling.json: {e}")))
    }

    /// buckling.csv: one line per bar, units in the header.
    pub fn to_csv(&self) -> String {
        let e = |v: Option<f64>| v.map(|x| format!("{x:e}")).unwrap_or_default();
        let d = text::<f64>;
        let mut csv = String::from(
            "route,l_over_r,particles,bonds,E [Pa],E_cell [Pa],sigma_euler [Pa],sigma_mazzilli [Pa],\
             sigma_network [Pa],network_over_euler,network_over_mazzilli,sigma_deformed [Pa],\
             deformed_over_extensible_own,bending_ratio,\
             network_over_euler_own_EI,network_over_engesser_own,normal_force_share,iterations,\
             residual,dem_max_stress [Pa],dem_strain_at_max,dem_max_kinetic_ratio,dem_peak_at_end,\
             dem_total_steps,dem_ran_out\n",
        );
        for r in &self.rows {
            let cols = [
                r.route.unwrap_or_default().to_string(),
                r.slenderness.to_string(),
                r.particles.to_string(),
                r.bonds.to_string(),
                format!("{:e}", r.modulus_pa),
                e(r.modulus_cell_pa),
                format!("{:e}", r.sigma_euler_pa),
                e(r.sigma_mazzilli_pa),
                format!("{:e}", r.sigma_network_pa),
                r.network_over_euler.to_string(),
                d(r.network_over_mazzilli),
                e(r.sigma_deformed_pa),
                d(r.deformed_over_extensible_own),
                r.bending_ratio.to_string(),
                r.network_over_euler_own_ei.to_string(),
                d(r.network_over_engesser_own),
                r.normal_force_share.to_string(),
                r.iterations.to_string(),
                format!("{:e}", r.residual),
                e(r.dem_max_stress_pa),
                e(r.dem_strain_at_max),
                e(r.dem_max_kinetic_ratio),
                text(r.dem_peak_at_end),
                text(r.dem_total_steps),
                text(r.dem_ran_out),
            ];
            csv += &cols.join(",");
            csv.push('\n');
        }
        csv
    }

    #[cfg(feature = "plot")]
    /// buckling.png: σ_network/σ_Euler against l/r per route (and the DEM maxima, dashed)
    /// beside the Mazzilli and Euler curves.
    pub fn plot(&self, path: &std::path::Path, routes: &[PreparationRoute]) -> Result<()> {
        let of = |route: &PreparationRoute| {
            let name = route.as_str();
            self.rows.iter().filter(move |r| r.route == Some(name))
        };
        let mut series: Vec<Series> = routes
            .iter()
            .enumerate()
            .map(|(c, route)| Series {
                label: format!("network, {}", route.as_str()),
                points: of(route)
                    .map(|r| (r.slenderness, r.network_over_euler))
                    .collect(),
                dashed: false,
                colour: Some(c),
            })
            .collect();
        if self.rows.iter().any(|r| r.dem_max_stress_pa.is_some()) {
            for (c, route) in routes.iter().enumerate() {
                series.push(Series {
                    label: format!("DEM maximum, {}", route.as_str()),
                    points: of(route)
                        .filter_map(|r| {
                            r.dem_max_stress_pa
                                .map(|m| (r.slenderness, m / r.sigma_euler_pa))
                        })
                        .collect(),
                    dashed: true,
                    colour: Some(c),
                });
            }
        }
        series.extend(closed_form_curves(&self.rows));
        plot_series(
            path,
            &series,
            "clamped round bars: linearised critical stress",
            "l/r",
            "σ_cr / σ_Euler (1)",
        )
    }

    #[cfg(feature = "plot")]
    /// Write buckling.csv, buckling.json, buckling.png and the histories into `dir`.
    pub fn write(&self, dir: &std::path::Path, routes: &[PreparationRoute]) -> Result<()> {
        for (name, text) in &self.histories {
            crate::io::write_string_atomic(&dir.join(name), text)?;
        }
        crate::io::write_string_atomic(&dir.join("buckling.csv"), &self.to_csv())?;
        crate::io::write_string_atomic(&dir.join("buckling.json"), &self.to_json()?)?;
        self.plot(&dir.join("buckling.png"), routes)
    }
}

/// `v` as text, or empty when `None`.
fn text<T: ToString>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

#[cfg(feature = "plot")]
/// Mazzilli's and Euler's σ/σ_Euler over the rows' l/r range.
fn closed_form_curves(rows: &[BarRow]) -> [Series; 2] {
    let (lo, hi) = rows.iter().fold((f64::INFINITY, 0.0_f64), |(l, h), r| {
        (l.min(r.slenderness), h.max(r.slenderness))
    });
    let curve = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=100)
            .map(|k| lo + (hi - lo).max(1.0) * k as f64 / 100.0)
            .map(|s| (s, f(s)))
            .collect()
    };
    [
        Series {
            label: "Mazzilli (Eq. 15)".into(),
            points: curve(&|s| mazzilli_stress(1.0, s) / euler_stress(1.0, s)),
            dashed: true,
            colour: Some(4),
        },
        Series {
            label: "Euler (Eq. 14)".into(),
            points: curve(&|_| 1.0),
            dashed: true,
            colour: Some(5),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A report of one bar of hand-set values: `None` where the study has no value (a linear
    /// bar, no compression) and finite numbers elsewhere.
    fn report() -> BucklingReport {
        let network = BucklingResult {
            load_factors: [0.0126, 0.0147],
            critical_stress: 86_900.0,
            residuals: [3e-8, 6e-7],
            static_residual: 4e-14,
            ..BucklingResult::default()
        };
        let row = BarRow {
            route: Some("unjammed"),
            slenderness: 20.0,
            sigma_mazzilli_pa: Some(173_000.0),
            sigma_network_pa: 86_900.0,
            residual: 6e-7,
            network,
            ..BarRow::default()
        };
        BucklingReport {
            units: serde_json::json!({"*_pa": "Pa"}),
            parameters: parameters(&BucklingStudyOptions::default()),
            rows: vec![row],
            histories: Vec::new(),
        }
    }

    #[test]
    fn buckling_json_keeps_null_for_none_but_refuses_a_non_finite_number() {
        // `None` is written as null and accepted.
        let text = report().to_json().unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert!(v["rows"][0]["sigma_deformed_pa"].is_null());
        assert_eq!(v["rows"][0]["sigma_network_pa"], 86_900.0);
        // A non-finite number in a plain field, an optional field, the nested network
        // result, an array and the parameters: each refused, naming the field.
        type Spoil = fn(&mut BucklingReport);
        let cases: [(Spoil, &str); 5] = [
            (|r| r.rows[0].residual = f64::NAN, "rows[0].residual"),
            (
                |r| r.rows[0].sigma_deformed_pa = Some(f64::INFINITY),
                "rows[0].sigma_deformed_pa",
            ),
            (
                |r| r.rows[0].network.static_residual = f64::NAN,
                "rows[0].network.static_residual",
            ),
            (
                |r| r.rows[0].network.load_factors[1] = f64::NEG_INFINITY,
                "rows[0].network.load_factors[1]",
            ),
            (
                |r| {
                    r.parameters = parameters(&BucklingStudyOptions {
                        alpha: f64::NAN,
                        ..BucklingStudyOptions::default()
                    })
                },
                "parameters.alpha",
            ),
        ];
        for (spoil, field) in cases {
            let mut r = report();
            spoil(&mut r);
            let e = r.to_json().unwrap_err().to_string();
            assert!(
                e.contains(field) && e.contains("not a finite number"),
                "{field}: {e}"
            );
        }
    }
}
