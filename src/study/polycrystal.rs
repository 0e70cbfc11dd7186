//! What a materials user asks of a polycrystal (issue 34; docs/polycrystal.md): its relaxed
//! tensor beside the random-texture estimates of its single crystal — Voigt, Reuss, Hill,
//! the Hashin–Shtrikman bounds and the self-consistent estimate (docs/polycrystal-bounds.md)
//! of the single crystal's relaxed tensor on the same packing — how far from isotropy it is,
//! and each grain's mean stress and strain under a macroscopic uniaxial strain against the
//! grain's own stiffness along the load (stiff directions carry more stress). [`run`] makes
//! the [`PolycrystalReport`] that is polycrystal.json of `anisobond polycrystal` and the dict
//! of `anisobond.polycrystal`.
//!
//! A 1,000-sphere packing cut into 8 random grains of the paper's cubic crystal:
//! ```
//! use anisobond::packing::{generate, GenerateOptions};
//! use anisobond::prelude::*;
//! use anisobond::study::{polycrystal, OptionNames};
//! let packing = generate(&GenerateOptions { n_particles: 1000, ..Default::default() }, &|_| {}).unwrap();
//! let mut text = Model::truszkowska_mrv().to_toml_string();
//! text.push_str("\n[grains]\ncount = 8\nseed = 3\n");
//! let model = Model::from_toml_str(&text, "polycrystal.toml").unwrap();
//! let r = polycrystal::run(&packing, &model, &polycrystal::PolycrystalOptions::default(), OptionNames::Keywords, &|_| {}).unwrap();
//! assert_eq!(r.grains.len(), 8);
//! println!("G = {:.3e} Pa, HS bounds {:.3e}–{:.3e} Pa", r.shear_pa, r.single_crystal.hs_lower_shear_pa, r.single_crystal.hs_upper_shear_pa);
//! ```

use super::OptionNames;
use crate::assembly::{Assembly, Method};
use crate::grains::{GrainMap, Grains};
use crate::homogenize::{LocalOptions, RelaxedOptions};
use crate::model::Model;
use crate::packing::Packing;
use crate::tensor::{
    isotropic_projection, orientation_averages, voigt_average, PolycrystalReference, Stiffness6,
    Voigt6,
};
use crate::{Error, Mat3, Result};
use serde::Serialize;

/// The options of the study.
#[derive(Clone, Debug)]
pub struct PolycrystalOptions {
    /// The macroscopic load: a uniaxial engineering strain along `load_axis` (|ε| ≤ 0.1).
    pub strain: f64,
    /// The load axis: 0 = x, 1 = y, 2 = z.
    pub load_axis: usize,
    /// The relaxed solves (solver, tolerance).
    pub relaxed: RelaxedOptions,
    /// Grain counts of a convergence series: for each, the model's `[grains]` with
    /// `count = n` (same seed, same orientation rule) and one more relaxed solve; empty for
    /// none.
    pub grain_counts: Vec<usize>,
}

impl Default for PolycrystalOptions {
    fn default() -> Self {
        PolycrystalOptions {
            strain: 1e-4,
            load_axis: 0,
            relaxed: RelaxedOptions::default(),
            grain_counts: Vec::new(),
        }
    }
}

impl PolycrystalOptions {
    /// Refuse a strain that is zero, not finite or beyond 0.1, an axis beyond z, and a grain
    /// count of 0, each named as `names` does.
    pub fn check(&self, names: OptionNames) -> Result<()> {
        if !(self.strain.is_finite() && self.strain != 0.0 && self.strain.abs() <= 0.1) {
            return Err(Error::Invalid(format!(
                "{} = {}: expected a finite, non-zero strain with |ε| ≤ 0.1",
                names.name("strain"),
                self.strain
            )));
        }
        if self.load_axis > 2 {
            return Err(Error::Invalid(format!(
                "{} = {}: expected 0 (x), 1 (y) or 2 (z)",
                names.name("load_axis"),
                self.load_axis
            )));
        }
        if self.grain_counts.contains(&0) {
            return Err(Error::Invalid(format!(
                "{}: a grain count must be at least 1",
                names.name("grain_counts")
            )));
        }
        Ok(())
    }
}

/// What [`run`] reports as it goes.
#[derive(Clone, Copy, Debug)]
pub enum PolycrystalProgress {
    /// The single crystal's relaxed solve started.
    SingleCrystal,
    /// The polycrystal's relaxed solve with local fields started.
    Polycrystal,
    /// The convergence series' solve `index` (0-based) of `of`, with `grains` grains.
    Series {
        /// Index in the series.
        index: usize,
        /// Solves in the series.
        of: usize,
        /// Its grain count.
        grains: usize,
    },
}

/// One grain: its orientation, its stiffness along the load and its mean local fields.
#[derive(Clone, Debug, Serialize)]
pub struct GrainRow {
    /// Grain id.
    pub grain: u32,
    /// Its particles.
    pub particles: usize,
    /// Σ V_p of its particles (m³; docs/references.md "Local fields").
    pub volume_m3: f64,
    /// Bunge angles φ1, Φ, φ2 of its orientation (degrees).
    pub bunge_deg: [f64; 3],
    /// The single crystal's longitudinal modulus along the load axis a in this grain's
    /// orientation, a·a·C_g·a·a with C_g the single crystal's relaxed tensor turned into the
    /// grain: the stress a uniaxial strain along a gives the grain alone, per unit strain (Pa).
    pub longitudinal_modulus_pa: f64,
    /// Volume-weighted mean stress σ_aa along the load axis over the grain (Pa).
    pub mean_stress_pa: f64,
    /// Its volume-weighted standard deviation over the grain (Pa).
    pub std_stress_pa: f64,
    /// Mean fitted strain ε_aa along the load axis over the grain; `None` when no particle
    /// of the grain has a fitted strain.
    pub mean_strain: Option<f64>,
}

/// One polycrystal of the convergence series.
#[derive(Clone, Debug, Serialize)]
pub struct SeriesRow {
    /// Grain count.
    pub grains: usize,
    /// Bulk modulus of the isotropic projection of its relaxed tensor (Pa).
    pub bulk_pa: f64,
    /// Shear modulus of that projection (Pa).
    pub shear_pa: f64,
    /// Its distance from isotropy, |C − iso(C)| / |C| (Frobenius, Mandel form).
    pub anisotropy: f64,
}

/// The report: polycrystal.json.
#[derive(Clone, Debug, Serialize)]
pub struct PolycrystalReport {
    /// Particles of the packing.
    pub particles: usize,
    /// Bonds.
    pub bonds: usize,
    /// Load axis (0 = x, 1 = y, 2 = z).
    pub load_axis: usize,
    /// Uniaxial engineering strain applied along it.
    pub strain: f64,
    /// The single crystal's relaxed tensor: the same packing and model without `[grains]`
    /// (Pa, Voigt).
    pub single_crystal_tensor_pa: [[f64; 6]; 6],
    /// Its random-texture estimates (Voigt, Reuss, Hill, Hashin–Shtrikman, self-consistent).
    pub single_crystal: PolycrystalReference,
    /// The single crystal's distance from isotropy, |C − iso(C)| / |C|.
    pub single_crystal_anisotropy: f64,
    /// The polycrystal's relaxed tensor (Pa, Voigt).
    pub tensor_pa: [[f64; 6]; 6],
    /// Bulk modulus of its isotropic projection (Pa).
    pub bulk_pa: f64,
    /// Shear modulus of its isotropic projection (Pa).
    pub shear_pa: f64,
    /// Its distance from isotropy, |C − iso(C)| / |C|.
    pub anisotropy: f64,
    /// K inside the single crystal's Hashin–Shtrikman bounds.
    pub bulk_within_hs_bounds: bool,
    /// G inside them.
    pub shear_within_hs_bounds: bool,
    /// (G − G_SC)/G_SC against the self-consistent estimate.
    pub shear_vs_self_consistent: f64,
    /// The Voigt average of the grains' actual orientations, volume-weighted (Pa, Voigt):
    /// the texture's upper estimate.
    pub texture_voigt_pa: [[f64; 6]; 6],
    /// Their Reuss average (Pa, Voigt): the texture's lower estimate.
    pub texture_reuss_pa: [[f64; 6]; 6],
    /// Pearson's correlation, over the grains, of the longitudinal modulus along the load
    /// with the mean stress along it.
    pub stress_stiffness_correlation: f64,
    /// Mean stress along the load over the cell (Pa).
    pub cell_mean_stress_pa: f64,
    /// Its volume-weighted standard deviation over the particles (Pa): the local field's
    /// spread.
    pub cell_std_stress_pa: f64,
    /// The grains.
    pub grains: Vec<GrainRow>,
    /// The convergence series (empty unless asked for).
    pub series: Vec<SeriesRow>,
}

/// |C − iso(C)| / |C| in Mandel form (the shear rows and columns weighted so that the
/// Frobenius norm is the tensor's).
pub fn anisotropy_distance(c: &Stiffness6) -> f64 {
    let iso = isotropic_projection(c);
    let w = |i: usize| if i < 3 { 1.0 } else { 2.0 };
    let (mut d, mut n) = (0.0, 0.0);
    for i in 0..6 {
        for j in 0..6 {
            let f = w(i) * w(j);
            d += f * (c[(i, j)] - iso[(i, j)]).powi(2);
            n += f * c[(i, j)].powi(2);
        }
    }
    (d / n).sqrt()
}

/// Bulk and shear moduli of the isotropic projection (Voigt's K_V, G_V of `c`).
fn moduli(c: &Stiffness6) -> (f64, f64) {
    let m = voigt_average(c);
    (m.bulk, m.shear)
}

/// Bunge angles (degrees) of a Bunge matrix g (sample → crystal): g = R_z(φ2) R_x(Φ) R_z(φ1)
/// as rows, so g33 = cos Φ, g31 = sin φ2 sin Φ… (Bunge 1982).
fn bunge_angles(g: &Mat3) -> [f64; 3] {
    let big_phi = g[(2, 2)].clamp(-1.0, 1.0).acos();
    let (phi1, phi2) = if big_phi.sin().abs() > 1e-12 {
        (g[(2, 0)].atan2(-g[(2, 1)]), g[(0, 2)].atan2(g[(1, 2)]))
    } else {
        (g[(0, 1)].atan2(g[(0, 0)]), 0.0)
    };
    let deg = |x: f64| x.to_degrees().rem_euclid(360.0);
    [deg(phi1), big_phi.to_degrees(), deg(phi2)]
}

/// Pearson's correlation of two equally long series; 0 when either is constant.
fn correlation(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx > 0.0 && syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        0.0
    }
}

/// A report's rows as a matrix.
fn matrix(r: &[[f64; 6]; 6]) -> Stiffness6 {
    Stiffness6::from_fn(|i, j| r[i][j])
}

/// A matrix as rows for the report.
fn rows(c: &Stiffness6) -> [[f64; 6]; 6] {
    let mut r = [[0.0; 6]; 6];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = c[(i, j)];
        }
    }
    r
}

/// The polycrystal study of `packing` and `model` (which must have `[grains]`; docs in the
/// module): the single crystal's relaxed tensor and references, the polycrystal's relaxed
/// tensor and local fields under a uniaxial strain, and the optional convergence series.
pub fn run(
    packing: &Packing,
    model: &Model,
    options: &PolycrystalOptions,
    names: OptionNames,
    progress: &dyn Fn(PolycrystalProgress),
) -> Result<PolycrystalReport> {
    options.check(names)?;
    if model.grains.is_none() {
        return Err(Error::Model(
            "polycrystal: the model has no [grains] table (docs/polycrystal.md): nothing to \
             compare with the single crystal"
                .into(),
        ));
    }
    let method = Method::Relaxed(options.relaxed);
    progress(PolycrystalProgress::SingleCrystal);
    let single_model = Model {
        grains: None,
        ..model.clone()
    };
    // The single crystal and every polycrystal share the packing's bonds (the same rule on
    // the same packing): built once here, their springs assigned by each model.
    let single = Assembly::new(packing.clone(), single_model)?;
    let c_single = matrix(&single.tensor(&method)?.report.c);
    let reference = PolycrystalReference::of(&c_single)?;

    progress(PolycrystalProgress::Polycrystal);
    let poly = Assembly::with_bonds(packing.clone(), model.clone(), single.bonds)?;
    let grains: &Grains = poly
        .grains()
        .ok_or_else(|| Error::Model("polycrystal: the assembly has no grains".into()))?;
    let mut strain = Voigt6::zeros();
    // The normal strain along axis a is Voigt component a (11, 22, 33 first).
    let a = options.load_axis;
    strain[a] = options.strain;
    let fields = poly.local_fields(
        &strain,
        &LocalOptions {
            relaxed: options.relaxed,
            ..Default::default()
        },
    )?;
    let c_poly = fields.relaxed.c;
    let (bulk, shear) = moduli(&c_poly);
    let stats = fields.statistics(&grains.grain)?;
    let axis = {
        let mut v = crate::Vec3::zeros();
        v[options.load_axis] = 1.0;
        v
    };
    let directional = |g: &Mat3| {
        // The grain's lab tensor is the single crystal's turned by gᵀ (springs m(g·n)), so
        // its modulus along the lab axis a is the crystal's along g·a.
        longitudinal_modulus(&c_single, &(g * axis))
    };
    let sizes = grains.sizes();
    let mut rows_out = Vec::new();
    for st in &stats.groups {
        let g = st.label.expect("grouped statistics carry their label");
        let orientation = &grains.orientation[g as usize];
        rows_out.push(GrainRow {
            grain: g,
            particles: sizes[g as usize],
            volume_m3: st.volume_m3,
            bunge_deg: bunge_angles(orientation),
            longitudinal_modulus_pa: directional(orientation),
            mean_stress_pa: st.mean_stress_pa[a],
            std_stress_pa: st.std_stress_pa[a],
            mean_strain: st.mean_strain.map(|e| e[a]),
        });
    }
    let weights: Vec<f64> = (0..grains.len())
        .map(|g| {
            stats
                .groups
                .iter()
                .find(|s| s.label == Some(g as u32))
                .map_or(0.0, |s| s.volume_m3)
        })
        .collect();
    let turns: Vec<Mat3> = grains.orientation.iter().map(|g| g.transpose()).collect();
    let texture = orientation_averages(&c_single, &turns, Some(&weights))?;
    let e: Vec<f64> = rows_out.iter().map(|r| r.longitudinal_modulus_pa).collect();
    let s: Vec<f64> = rows_out.iter().map(|r| r.mean_stress_pa).collect();
    let mut series = Vec::new();
    for (index, &n) in options.grain_counts.iter().enumerate() {
        progress(PolycrystalProgress::Series {
            index,
            of: options.grain_counts.len(),
            grains: n,
        });
        let mut m = model.clone();
        if let Some(spec) = m.grains.as_mut() {
            spec.map = GrainMap::Count(n);
        }
        let c = matrix(
            &Assembly::with_bonds(packing.clone(), m, poly.bonds.clone())?
                .tensor(&method)?
                .report
                .c,
        );
        let (k, g) = moduli(&c);
        series.push(SeriesRow {
            grains: n,
            bulk_pa: k,
            shear_pa: g,
            anisotropy: anisotropy_distance(&c),
        });
    }
    let within = |x: f64, lo: f64, hi: f64| x >= lo * (1.0 - 1e-12) && x <= hi * (1.0 + 1e-12);
    Ok(PolycrystalReport {
        particles: packing.len(),
        bonds: poly.bonds.len(),
        load_axis: options.load_axis,
        strain: options.strain,
        single_crystal_tensor_pa: rows(&c_single),
        single_crystal_anisotropy: anisotropy_distance(&c_single),
        tensor_pa: rows(&c_poly),
        bulk_pa: bulk,
        shear_pa: shear,
        anisotropy: anisotropy_distance(&c_poly),
        bulk_within_hs_bounds: within(bulk, reference.hs_lower_bulk_pa, reference.hs_upper_bulk_pa),
        shear_within_hs_bounds: within(
            shear,
            reference.hs_lower_shear_pa,
            reference.hs_upper_shear_pa,
        ),
        shear_vs_self_consistent: (shear - reference.self_consistent_shear_pa)
            / reference.self_consistent_shear_pa,
        single_crystal: reference,
        texture_voigt_pa: rows(&texture.voigt),
        texture_reuss_pa: rows(&texture.reuss),
        stress_stiffness_correlation: correlation(&e, &s),
        cell_mean_stress_pa: stats.cell.mean_stress_pa[a],
        cell_std_stress_pa: stats.cell.std_stress_pa[a],
        grains: rows_out,
        series,
    })
}

/// d_i d_j d_k d_l C_ijkl for a unit vector d: with the engineering-shear Voigt matrix this is
/// vᵀ C v with v = (d₁², d₂², d₃², 2d₂d₃, 2d₁d₃, 2d₁d₂).
pub fn longitudinal_modulus(c: &Stiffness6, d: &crate::Vec3) -> f64 {
    let v = [
        d[0] * d[0],
        d[1] * d[1],
        d[2] * d[2],
        2.0 * d[1] * d[2],
        2.0 * d[0] * d[2],
        2.0 * d[0] * d[1],
    ];
    let mut x = 0.0;
    for i in 0..6 {
        for j in 0..6 {
            x += v[i] * c[(i, j)] * v[j];
        }
    }
    x
}

impl PolycrystalReport {
    /// polycrystal.json, refused if a number is not finite.
    pub fn to_json(&self) -> Result<String> {
        crate::io::finite_json(self, "polycrystal report")
    }

    /// polycrystal_grains.csv: one row per grain.
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "grain,particles,volume_m3,phi1_deg,Phi_deg,phi2_deg,longitudinal_modulus_pa,mean_stress_pa,std_stress_pa,mean_strain\n",
        );
        for r in &self.grains {
            s.push_str(&format!(
                "{},{},{:e},{},{},{},{:e},{:e},{:e},{}\n",
                r.grain,
                r.particles,
                r.volume_m3,
                r.bunge_deg[0],
                r.bunge_deg[1],
                r.bunge_deg[2],
                r.longitudinal_modulus_pa,
                r.mean_stress_pa,
                r.std_stress_pa,
                r.mean_strain.map_or(String::new(), |e| format!("{e:e}"))
            ));
        }
        s
    }

    #[cfg(feature = "plot")]
    /// polycrystal.png: each grain's mean stress along the load against the single crystal's
    /// Young's modulus along the load in that grain's orientation.
    pub fn plot(&self, path: &std::path::Path) -> Result<()> {
        use crate::plot::{plot_series, Series};
        let axis = ["x", "y", "z"][self.load_axis];
        plot_series(
            path,
            &[Series {
                label: format!(
                    "grains ({}), correlation {:.3}",
                    self.grains.len(),
                    self.stress_stiffness_correlation
                ),
                points: self
                    .grains
                    .iter()
                    .map(|r| (r.longitudinal_modulus_pa / 1e9, r.mean_stress_pa / 1e6))
                    .collect(),
                dashed: true,
                colour: Some(0),
            }],
            &format!("grain stress under ε_{axis}{axis} = {:.1e}", self.strain),
            &format!("single crystal's longitudinal modulus along {axis} in the grain (GPa)"),
            &format!("grain mean σ_{axis}{axis} (MPa)"),
        )
    }

    #[cfg(feature = "plot")]
    /// Write polycrystal.json, polycrystal_grains.csv and (two grains or more)
    /// polycrystal.png into `dir`; the names written.
    pub fn write(&self, dir: &std::path::Path) -> Result<Vec<&'static str>> {
        crate::io::write_string_atomic(&dir.join("polycrystal.json"), &self.to_json()?)?;
        crate::io::write_string_atomic(&dir.join("polycrystal_grains.csv"), &self.to_csv())?;
        let mut names = vec!["polycrystal.json", "polycrystal_grains.csv"];
        if self.grains.len() >= 2 {
            self.plot(&dir.join("polycrystal.png"))?;
            names.push("polycrystal.png");
        }
        Ok(names)
    }
}
