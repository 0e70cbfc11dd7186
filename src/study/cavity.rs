//! Šmilauer's pressurised cavity (docs/cavity.md; his cross-anisotropy report, last
//! section): a slab with a circular hole cut from a periodic assembly, the static wall
//! displacement beside Lamé's thick cylinder and the anisotropic continuum of the relaxed
//! tensor, the Christoffel speeds in the slab's plane and, on request, the ramp-loaded
//! cavity in time. [`run`] makes the [`CavityReport`] that is cavity.json of
//! `anisobond cavity` and the dict of `Assembly.cavity`.
//!
//! A hole of 3 R̄ clamped at 6 R̄ in a 1,000-sphere packing (R̄ = 1 mm):
//! ```
//! use anisobond::packing::{generate, GenerateOptions};
//! use anisobond::prelude::*;
//! use anisobond::study::{cavity, OptionNames};
//! let packing = generate(&GenerateOptions { n_particles: 1000, ..Default::default() }, &|_| {}).unwrap();
//! let a = Assembly::new(packing, Model::truszkowska_mrv()).unwrap();
//! let opts = cavity::CavityStudyOptions {
//!     hole_radius: Some(3e-3),
//!     outer_radius: Some(6e-3),
//!     ..Default::default()
//! };
//! let r = cavity::run(&a, &opts, OptionNames::Keywords).unwrap();
//! assert!(r.dem_over_lame > 0.0);
//! println!("DEM / Lamé = {:.3}", r.dem_over_lame);
//! ```

use super::OptionNames;
use crate::assembly::{Assembly, Method};
use crate::cavity::continuum::AnnulusMesh;
use crate::cavity::dynamics::{WaveOptions, WaveRun};
use crate::cavity::statics::{StaticComparison, WallBin};
use crate::cavity::{bulk_density, Cavity, CavityGeometry};
use crate::io::check_json_numbers;
use crate::tensor::{phase_velocities, Stiffness6};
use crate::{Error, Result, Vec3};

/// The options of the study; `None` lengths take [`CavityGeometry::with_defaults`]'
/// defaults (hole 10 R̄, clamped radius 24 R̄, clamp width the longest bond, tiles R̄/4).
#[derive(Clone, Debug)]
pub struct CavityStudyOptions {
    /// Hole radius a (m).
    pub hole_radius: Option<f64>,
    /// Radius b of the clamped boundary (m).
    pub outer_radius: Option<f64>,
    /// Width of the clamped ring (m).
    pub clamp_width: Option<f64>,
    /// Side of the wall's pressure tiles (m).
    pub ray_spacing: Option<f64>,
    /// Pressure in the hole (Pa; > 0 pushes the wall out).
    pub pressure: f64,
    /// Material density of the spheres (kg/m³), for the wave speeds.
    pub density: f64,
    /// Also run the ramp-loaded cavity in time (undamped integrator, YADE's law).
    pub waves: bool,
    /// Waves: ramp duration (s); `None`: 20 R̄ / v, v the fastest in-plane Christoffel speed.
    pub ramp_time: Option<f64>,
    /// Waves: number of snapshots.
    pub snapshots: usize,
}

impl Default for CavityStudyOptions {
    fn default() -> Self {
        CavityStudyOptions {
            hole_radius: None,
            outer_radius: None,
            clamp_width: None,
            ray_spacing: None,
            pressure: 1.0e6,
            density: 2600.0,
            waves: false,
            ramp_time: None,
            snapshots: 8,
        }
    }
}

impl CavityStudyOptions {
    /// Refuse a density or a length that is not finite and positive, named as `names` does.
    pub fn check(&self, names: OptionNames) -> Result<()> {
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(Error::Invalid(format!(
                "{} must be finite and > 0 kg/m³, got {}",
                names.name("density"),
                self.density
            )));
        }
        for (name, v) in [
            ("hole_radius", self.hole_radius),
            ("outer_radius", self.outer_radius),
            ("clamp_width", self.clamp_width),
            ("ray_spacing", self.ray_spacing),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(Error::Invalid(format!(
                        "{} must be finite and > 0 m, got {v}",
                        names.name(name)
                    )));
                }
            }
        }
        Ok(())
    }
}

/// The continuum reference of cavity.json.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ContinuumSection {
    /// How it is solved.
    pub method: &'static str,
    /// Rings of the annulus mesh.
    pub mesh_rings: usize,
    /// Elements around.
    pub mesh_around: usize,
    /// Mean radial wall displacement (m).
    pub wall_displacement_m: f64,
    /// The DEM's over it.
    pub dem_over_continuum: f64,
    /// ±20° wall bins along ±x, ±y: DEM and continuum u_r, u_z (m).
    pub wall_bins_20deg: Vec<WallBin>,
}

/// The Christoffel speeds along one in-plane direction.
#[derive(Clone, Debug, serde::Serialize)]
pub struct InPlaneSpeed {
    /// Direction (degrees from x).
    pub angle_from_x_deg: f64,
    /// The three phase speeds (m/s).
    pub speeds_m_per_s: [f64; 3],
    /// The quasi-longitudinal one (m/s).
    pub quasi_longitudinal_m_per_s: f64,
}

/// A wave front along one direction.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Front {
    /// Direction (degrees from x).
    pub angle_from_x_deg: f64,
    /// Front speed between the probes (m/s).
    pub front_speed_m_per_s: f64,
    /// Quasi-longitudinal Christoffel speed along it (m/s).
    pub christoffel_m_per_s: f64,
    /// Arrival at every probe (s).
    pub arrival_s: Vec<f64>,
    /// Spheres in every probe.
    pub probe_spheres: Vec<usize>,
}

/// The wave run's section of cavity.json.
#[derive(Clone, Debug, serde::Serialize)]
pub struct WavesSection {
    /// Ramp duration (s).
    pub ramp_time_s: f64,
    /// Time step (s).
    pub time_step_s: f64,
    /// Steps run.
    pub steps: usize,
    /// Probe radii (m).
    pub probe_radii_m: [f64; 2],
    /// How a front is detected.
    pub detection: &'static str,
    /// One per direction.
    pub fronts: Vec<Front>,
    /// Snapshot times (s).
    pub snapshot_times_s: Vec<f64>,
}

/// The study's report: cavity.json ([`CavityReport::to_json`]); the slab, its solution and
/// the wave run for the files beside it.
#[derive(serde::Serialize)]
pub struct CavityReport {
    /// Units of the keys.
    pub units: &'static str,
    /// Pressure (Pa).
    pub pressure_pa: f64,
    /// Hole radius a (m).
    pub hole_radius_m: f64,
    /// Clamped radius b (m).
    pub clamped_radius_m: f64,
    /// Clamp width (m).
    pub clamp_width_m: f64,
    /// Slab thickness (m).
    pub slab_thickness_m: Option<f64>,
    /// Spheres of the slab.
    pub spheres: usize,
    /// Free spheres solved for.
    pub free_spheres: usize,
    /// Spheres on the wall.
    pub wall_spheres: usize,
    /// Unknowns of the solve.
    pub unknowns: usize,
    /// Relative residual of the solve.
    pub relative_residual: f64,
    /// Mean radial wall displacement (m).
    pub wall_displacement_m: f64,
    /// Mean axial wall displacement (m).
    pub wall_axial_displacement_m: f64,
    /// Lamé's wall displacement (m).
    pub lame_wall_displacement_m: f64,
    /// The DEM's over Lamé's.
    pub dem_over_lame: f64,
    /// Lamé λ of the relaxed tensor's isotropic projection (Pa).
    pub lame_lambda_pa: f64,
    /// Lamé μ (Pa).
    pub lame_mu_pa: f64,
    /// The anisotropic continuum of the full relaxed tensor.
    pub continuum: ContinuumSection,
    /// The relaxed tensor (Pa).
    pub relaxed_tensor_pa: [[f64; 6]; 6],
    /// Bulk density (kg/m³).
    pub bulk_density_kg_per_m3: f64,
    /// Christoffel speeds every 15° in the slab's plane.
    pub christoffel_in_plane: Vec<InPlaneSpeed>,
    /// The wave run, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waves: Option<WavesSection>,
    /// The slab.
    #[serde(skip)]
    pub cavity: Cavity,
    /// The static solution and its references.
    #[serde(skip)]
    pub comparison: StaticComparison,
    /// The wave run.
    #[serde(skip)]
    pub wave_run: Option<WaveRun>,
}

/// Christoffel speeds of `c` at density `rho` along `angle` degrees from x in the plane.
fn in_plane(c: &Stiffness6, rho: f64, angle: f64) -> Result<crate::tensor::PhaseVelocities> {
    let t = angle.to_radians();
    phase_velocities(c, rho, &Vec3::new(t.cos(), t.sin(), 0.0))
}

/// The wave run's options and the quasi-P speeds along its directions, refused (naming
/// the ramp time and snapshots) when [`Cavity::check_waves`] refuses them.
fn wave_options(
    o: &CavityStudyOptions,
    names: OptionNames,
    cavity: &Cavity,
    relaxed: &Stiffness6,
    rho: f64,
) -> Result<(WaveOptions, Vec<f64>)> {
    let g = cavity.geometry;
    let r = cavity.cut.packing.mean_radius();
    let dirs = [0.0f64, 45.0, 90.0];
    let speeds: Vec<f64> = dirs
        .iter()
        .map(|&d| in_plane(relaxed, rho, d).map(|w| w.quasi_longitudinal().speed))
        .collect::<Result<_>>()?;
    let vmax = speeds.iter().copied().fold(0.0, f64::max);
    let vmin = speeds.iter().copied().fold(f64::INFINITY, f64::min);
    let ramp = o.ramp_time.unwrap_or(20.0 * r / vmax);
    if !(ramp.is_finite() && ramp > 0.0) {
        return Err(Error::Invalid(format!(
            "{} must be finite and > 0 s, got {ramp}",
            names.name("ramp_time")
        )));
    }
    let (r1, r2) = (
        g.inner_radius + 0.3 * (g.outer_radius - g.inner_radius),
        g.inner_radius + 0.75 * (g.outer_radius - g.inner_radius),
    );
    let opts = WaveOptions {
        pressure: o.pressure,
        ramp_time: ramp,
        duration: 1.5 * ramp + (r2 - g.inner_radius + 2.0 * r) / vmin,
        material_density: o.density,
        law: crate::dem::LawKind::Yade,
        directions: dirs.iter().map(|d| d.to_radians()).collect(),
        probe_radii: vec![r1, r2],
        probe_half_angle: 15f64.to_radians(),
        snapshots: o.snapshots,
    };
    cavity.check_waves(&opts).map_err(|e| {
        e.in_context(format!(
            "{} with {} {ramp:e} s, {} {}",
            names.name("waves"),
            names.name("ramp_time"),
            names.name("snapshots"),
            o.snapshots
        ))
    })?;
    Ok((opts, speeds))
}

/// The wave run's section: fronts beside Christoffel's quasi-P `speeds`.
fn waves_section(opts: &WaveOptions, run: &WaveRun, speeds: &[f64]) -> WavesSection {
    let fronts = [0.0f64, 45.0, 90.0]
        .iter()
        .enumerate()
        .map(|(d, &angle)| Front {
            angle_from_x_deg: angle,
            front_speed_m_per_s: run.front_speed[d],
            christoffel_m_per_s: speeds[d],
            arrival_s: run.arrival[d].clone(),
            probe_spheres: run.probe_sizes[d].clone(),
        })
        .collect();
    WavesSection {
        ramp_time_s: opts.ramp_time,
        time_step_s: run.time_step,
        steps: run.times.len(),
        probe_radii_m: [opts.probe_radii[0], opts.probe_radii[1]],
        detection: "peak of the probes' mean velocity along the direction (±15°, ±R̄ in radius); speed = Δr/Δt between the two probes",
        fronts,
        snapshot_times_s: run.snapshots.iter().map(|s| s.0).collect(),
    }
}

/// The slab of `src` with the options' geometry, checked (sizes, memory) with the lengths
/// named as `names` does.
fn slab(src: &Assembly, o: &CavityStudyOptions, names: OptionNames) -> Result<Cavity> {
    let geometry = CavityGeometry::with_defaults(
        src,
        o.hole_radius,
        o.outer_radius,
        o.clamp_width,
        o.ray_spacing,
    );
    geometry.check(src).map_err(|e| {
        e.in_context(format!(
            "{} {:e} m, {} {:e} m, {} {:e} m, {} {:e} m",
            names.name("hole_radius"),
            geometry.inner_radius,
            names.name("outer_radius"),
            geometry.outer_radius,
            names.name("clamp_width"),
            geometry.clamp_width,
            names.name("ray_spacing"),
            geometry.ray_spacing
        ))
    })?;
    Cavity::new(src, geometry)
}

/// Run the study on the periodic assembly `src`: the slab, the static solve under the
/// pressure beside Lamé and the continuum of the relaxed tensor, the in-plane Christoffel
/// speeds and, with `waves`, the wave run (its options checked before the static solve).
pub fn run(src: &Assembly, o: &CavityStudyOptions, names: OptionNames) -> Result<CavityReport> {
    o.check(names)?;
    let cavity = slab(src, o, names)?;
    let relaxed = src.tensor(&Method::relaxed())?.report.tensor();
    let rho = bulk_density(&src.packing, o.density);
    let wave_setup = if o.waves {
        Some(wave_options(o, names, &cavity, &relaxed, rho)?)
    } else {
        None
    };
    let cmp = cavity.compare_static(&relaxed, o.pressure)?;
    let christoffel_in_plane = (0..12)
        .map(|k| {
            let angle = 15.0 * k as f64;
            let w = in_plane(&relaxed, rho, angle)?;
            Ok(InPlaneSpeed {
                angle_from_x_deg: angle,
                speeds_m_per_s: w.modes.map(|m| m.speed),
                quasi_longitudinal_m_per_s: w.quasi_longitudinal().speed,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let (wave_run, waves) = match wave_setup {
        Some((opts, speeds)) => {
            let run = cavity.run_waves(&opts)?;
            let section = waves_section(&opts, &run, &speeds);
            (Some(run), Some(section))
        }
        None => (None, None),
    };
    let report = report(
        o,
        cavity,
        cmp,
        &relaxed,
        rho,
        christoffel_in_plane,
        wave_run,
        waves,
    );
    report.to_json()?;
    Ok(report)
}

/// The report of the parts [`run`] computed.
#[allow(clippy::too_many_arguments)]
fn report(
    o: &CavityStudyOptions,
    cavity: Cavity,
    cmp: StaticComparison,
    relaxed: &Stiffness6,
    rho: f64,
    christoffel_in_plane: Vec<InPlaneSpeed>,
    wave_run: Option<WaveRun>,
    waves: Option<WavesSection>,
) -> CavityReport {
    let (s, fe, g) = (&cmp.solution, &cmp.continuum, cavity.geometry);
    let lame = cmp.lame_wall_displacement;
    CavityReport {
        units: "SI: m, Pa, kg/m³, m/s",
        pressure_pa: o.pressure,
        hole_radius_m: g.inner_radius,
        clamped_radius_m: g.outer_radius,
        clamp_width_m: g.clamp_width,
        slab_thickness_m: cavity.cut.packing.cell.map(|c| c.lengths.z),
        spheres: cavity.cut.packing.len(),
        free_spheres: s.free_spheres,
        wall_spheres: cavity.wall.len(),
        unknowns: s.unknowns,
        relative_residual: s.relative_residual,
        wall_displacement_m: s.wall_displacement,
        wall_axial_displacement_m: s.wall_axial_displacement,
        lame_wall_displacement_m: lame,
        dem_over_lame: s.wall_displacement / lame,
        lame_lambda_pa: cmp.lame_constants.0,
        lame_mu_pa: cmp.lame_constants.1,
        continuum: ContinuumSection {
            method: "generalized plane strain (u_x, u_y, u_z of x, y) with the relaxed tensor, \
                     linear triangles, clamped at b (cavity::continuum)",
            mesh_rings: AnnulusMesh::default().radial,
            mesh_around: fe.around,
            wall_displacement_m: fe.wall_displacement,
            dem_over_continuum: s.wall_displacement / fe.wall_displacement,
            wall_bins_20deg: cmp.bins.clone(),
        },
        relaxed_tensor_pa: crate::tensor::compare::rows(relaxed),
        bulk_density_kg_per_m3: rho,
        christoffel_in_plane,
        waves,
        cavity,
        comparison: cmp,
        wave_run,
    }
}

impl CavityReport {
    /// cavity.json: pretty JSON with a final newline; refuses a non-finite number.
    pub fn to_json(&self) -> Result<String> {
        let value =
            serde_json::to_value(self).map_err(|e| Error::Invalid(format!("cavity: {e}")))?;
        check_json_numbers(&value, "cavity")?;
        Ok(serde_json::to_string_pretty(&value).unwrap_or_default() + "\n")
    }

    /// Write cavity.json, particles.csv, cavity.vtu and, after a wave run, waves/ (VTK
    /// series and PNG snapshots) into `dir`.
    #[cfg(feature = "plot")]
    pub fn write(&self, dir: &std::path::Path) -> Result<()> {
        use crate::export::vtk::{write_particles_vtu, StrainedState};
        if let Some(run) = &self.wave_run {
            self.write_waves(run, &dir.join("waves"))?;
        }
        crate::io::write_string_atomic(&dir.join("cavity.json"), &self.to_json()?)?;
        let s = &self.comparison.solution;
        s.write_csv(&self.cavity, &dir.join("particles.csv"))?;
        let state = StrainedState {
            strain: crate::tensor::Voigt6::zeros(),
            displacement: s.displacement.clone(),
            rotation: s.rotation.clone(),
            force: Vec::new(),
        };
        write_particles_vtu(
            &dir.join("cavity.vtu"),
            &self.cavity.cut.packing,
            Some(&state),
        )
    }

    /// The wave run's VTK series and PNG maps of the radial displacement into `wdir`.
    #[cfg(feature = "plot")]
    fn write_waves(&self, run: &WaveRun, wdir: &std::path::Path) -> Result<()> {
        let cavity = &self.cavity;
        std::fs::create_dir_all(wdir).map_err(|e| Error::io(wdir, e))?;
        run.write_vtk_series(cavity, wdir)?;
        let points: Vec<(f64, f64)> = cavity
            .cut
            .packing
            .positions
            .iter()
            .map(|x| (x.x - cavity.cut.axis[0], x.y - cavity.cut.axis[1]))
            .collect();
        for (k, (t, u)) in run.snapshots.iter().enumerate() {
            let ur: Vec<f64> = (0..u.len())
                .map(|p| u[p].dot(&cavity.radial_unit(p)))
                .collect();
            crate::plot::plot_particle_map(
                &wdir.join(format!("snapshot_{k:04}.png")),
                &points,
                &ur,
                &format!("radial displacement (red out, blue in), t = {t:.3e} s"),
            )?;
        }
        Ok(())
    }
}
