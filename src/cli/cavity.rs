//! `anisobond cavity`: a pressurised circular hole in a slab cut from a periodic packing
//! (Šmilauer's cross-anisotropy report, last section; issue 22): the static wall
//! displacement beside Lamé's thick cylinder, and the Christoffel wave speeds of the
//! packing's relaxed tensor in the slab's plane.

use super::cell;
use super::output::check_json_numbers;
use anisobond::cavity::{bulk_density, continuum::AnnulusMesh, Cavity, CavityGeometry};
use anisobond::export::vtk::{write_particles_vtu, StrainedState};
use anisobond::io::OutputSet;
use anisobond::prelude::*;
use anisobond::tensor::phase_velocities;
use anisobond::Result;
use std::path::PathBuf;

/// Options of `anisobond cavity`.
#[derive(clap::Args)]
pub struct CavityArgs {
    #[command(flatten)]
    input: cell::BondedInput,
    /// Hole radius a (m); default 10 R̄. Sphere centres with ρ ≥ a are kept.
    #[arg(long)]
    hole_radius: Option<f64>,
    /// Radius b of the clamped boundary (m); default 24 R̄. Spheres beyond b are held. A slab
    /// (out to b + the clamp width) whose estimated memory exceeds what the machine has
    /// available is refused up front, with the estimate.
    #[arg(long)]
    outer_radius: Option<f64>,
    /// Width of the clamped ring (m); default the longest bond.
    #[arg(long)]
    clamp_width: Option<f64>,
    /// Side of the wall's pressure tiles (m), in (0, R̄]; default R̄/4. Refused when the
    /// wall loads would take more than 1e10 ray–sphere tests (about a minute).
    #[arg(long)]
    ray_spacing: Option<f64>,
    /// Pressure in the hole (Pa; > 0 pushes the wall out).
    #[arg(long, default_value_t = 1.0e6)]
    pressure: f64,
    /// Material density of the spheres (kg/m³), for the wave speeds.
    #[arg(long, default_value_t = 2600.0)]
    density: f64,
    /// Also run the ramp-loaded cavity in time (undamped integrator, YADE's law): wave
    /// fronts along 0°, 45° and 90° beside Christoffel, a VTK time series and PNG snapshots
    /// in OUTPUT/waves/.
    #[arg(long)]
    waves: bool,
    /// Waves: ramp duration (s); default 20 R̄ / v (v the fastest in-plane Christoffel speed).
    /// The run lasts 1.5 × this plus the front's travel; beyond 1e12 spheres × time steps
    /// it is refused up front.
    #[arg(long)]
    ramp_time: Option<f64>,
    /// Waves: number of snapshots (VTK and PNG), exactly this many, evenly spaced; at most
    /// one per time step (more is refused, as are more than the memory holds).
    #[arg(long, default_value_t = 8)]
    snapshots: usize,
    /// Output folder: cavity.json, particles.csv, cavity.vtu (and waves/ with --waves).
    #[arg(short, long, default_value = "anisobond-cavity")]
    output: PathBuf,
}

/// Run `anisobond cavity`.
pub fn run(a: CavityArgs) -> Result<()> {
    if !(a.density.is_finite() && a.density > 0.0) {
        return Err(anisobond::Error::Invalid(format!(
            "--density must be finite and > 0 kg/m³, got {}",
            a.density
        )));
    }
    for (name, v) in [
        ("--hole-radius", a.hole_radius),
        ("--outer-radius", a.outer_radius),
        ("--clamp-width", a.clamp_width),
        ("--ray-spacing", a.ray_spacing),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(anisobond::Error::Invalid(format!(
                    "{name} must be finite and > 0 m, got {v}"
                )));
            }
        }
    }
    let mut out = OutputSet::new(&a.input.paths());
    let dir = out.dir(&a.output)?;
    let src = a.input.assembly()?;
    let geometry = CavityGeometry::with_defaults(
        &src,
        a.hole_radius,
        a.outer_radius,
        a.clamp_width,
        a.ray_spacing,
    );
    geometry.check(&src).map_err(|e| {
        e.in_context(format!(
            "--hole-radius {:e} m, --outer-radius {:e} m, --clamp-width {:e} m, --ray-spacing \
             {:e} m",
            geometry.inner_radius,
            geometry.outer_radius,
            geometry.clamp_width,
            geometry.ray_spacing
        ))
    })?;
    let relaxed = src.tensor(&Method::relaxed())?.report.tensor();
    let cavity = Cavity::new(&src, geometry)?;
    let rho = bulk_density(&src.packing, a.density);
    // The wave run's options are checked (steps, snapshots, memory) before the static solve.
    let wave_setup = if a.waves {
        Some(wave_options(&a, &cavity, &relaxed, rho)?)
    } else {
        None
    };
    let cmp = cavity.compare_static(&relaxed, a.pressure)?;
    let (s, fe) = (&cmp.solution, &cmp.continuum);
    let ((lambda, mu), lame) = (cmp.lame_constants, cmp.lame_wall_displacement);
    let (ga, gb) = (geometry.inner_radius, geometry.outer_radius);
    let mut speeds = Vec::new();
    for k in 0..12 {
        let angle = 15.0 * k as f64;
        let t = angle.to_radians();
        let w = phase_velocities(&relaxed, rho, &Vec3::new(t.cos(), t.sin(), 0.0))?;
        speeds.push(serde_json::json!({
            "angle_from_x_deg": angle,
            "speeds_m_per_s": w.modes.map(|m| m.speed),
            "quasi_longitudinal_m_per_s": w.quasi_longitudinal().speed,
        }));
    }
    let waves = match wave_setup {
        Some(setup) => Some(run_waves(&cavity, &setup, &dir)?),
        None => None,
    };
    let mut json = serde_json::json!({
        "units": "SI: m, Pa, kg/m³, m/s",
        "pressure_pa": a.pressure,
        "hole_radius_m": ga,
        "clamped_radius_m": gb,
        "clamp_width_m": geometry.clamp_width,
        "slab_thickness_m": cavity.cut.packing.cell.map(|c| c.lengths.z),
        "spheres": cavity.cut.packing.len(),
        "free_spheres": s.free_spheres,
        "wall_spheres": cavity.wall.len(),
        "unknowns": s.unknowns,
        "relative_residual": s.relative_residual,
        "wall_displacement_m": s.wall_displacement,
        "wall_axial_displacement_m": s.wall_axial_displacement,
        "lame_wall_displacement_m": lame,
        "dem_over_lame": s.wall_displacement / lame,
        "lame_lambda_pa": lambda,
        "lame_mu_pa": mu,
        "continuum": {
            "method": "generalized plane strain (u_x, u_y, u_z of x, y) with the relaxed tensor, \
                       linear triangles, clamped at b (cavity::continuum)",
            "mesh_rings": AnnulusMesh::default().radial,
            "mesh_around": fe.around,
            "wall_displacement_m": fe.wall_displacement,
            "dem_over_continuum": s.wall_displacement / fe.wall_displacement,
            "wall_bins_20deg": cmp.bins,
        },
        "relaxed_tensor_pa": anisobond::tensor::compare::rows(&relaxed),
        "bulk_density_kg_per_m3": rho,
        "christoffel_in_plane": speeds,
    });
    if let Some(w) = waves {
        json["waves"] = w;
    }
    check_json_numbers(&json, "cavity")?;
    anisobond::io::write_string_atomic(
        &dir.join("cavity.json"),
        &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
    )?;
    s.write_csv(&cavity, &dir.join("particles.csv"))?;
    let state = StrainedState {
        strain: Voigt6::zeros(),
        displacement: s.displacement.clone(),
        rotation: s.rotation.clone(),
        force: Vec::new(),
    };
    write_particles_vtu(&dir.join("cavity.vtu"), &cavity.cut.packing, Some(&state))?;
    out.commit()?;
    println!(
        "cavity: a = {:.4e} m, b = {:.4e} m, slab {} spheres ({} free, {} on the wall), p = {:.4e} Pa",
        ga,
        gb,
        cavity.cut.packing.len(),
        s.free_spheres,
        cavity.wall.len(),
        a.pressure
    );
    println!(
        "  wall displacement {:.5e} m (DEM), {:.5e} m (Lamé, λ = {:.4e} Pa, μ = {:.4e} Pa from the relaxed tensor): ratio {:.4}",
        s.wall_displacement,
        lame,
        lambda,
        mu,
        s.wall_displacement / lame
    );
    println!(
        "  continuum (generalized plane strain, full relaxed tensor, {} × {} triangles' mesh): \
         {:.5e} m: DEM/continuum {:.4}",
        AnnulusMesh::default().radial,
        fe.around,
        fe.wall_displacement,
        s.wall_displacement / fe.wall_displacement
    );
    for b in json["continuum"]["wall_bins_20deg"]
        .as_array()
        .into_iter()
        .flatten()
    {
        let g = |k: &str| b[k].as_f64().unwrap_or(f64::NAN);
        println!(
            "  wall at {:>3}° ± 20°: u_r {:.4e} m (DEM) {:.4e} m (continuum); u_z {:.4e} m (DEM) \
             {:.4e} m (continuum)",
            g("angle_from_x_deg"),
            g("dem_radial_m"),
            g("continuum_radial_m"),
            g("dem_axial_m"),
            g("continuum_axial_m")
        );
    }
    println!(
        "  mean axial wall displacement {:.4e} m; residual {:.1e}",
        s.wall_axial_displacement, s.relative_residual
    );
    if let Some(fronts) = json["waves"]["fronts"].as_array() {
        for f in fronts {
            println!(
                "  wave front at {}° from x: {:.1} m/s (DEM), {:.1} m/s (Christoffel, quasi-P)",
                f["angle_from_x_deg"],
                f["front_speed_m_per_s"].as_f64().unwrap_or(f64::NAN),
                f["christoffel_m_per_s"].as_f64().unwrap_or(f64::NAN)
            );
        }
    }
    println!(
        "wrote {}/cavity.json, particles.csv, cavity.vtu{}",
        a.output.display(),
        if a.waves {
            ", waves/ (cavity.pvd, cavity_NNNN.vtu, snapshot_NNNN.png)"
        } else {
            ""
        }
    );
    Ok(())
}

/// The wave run of `--waves`: its options, the Christoffel speeds along its directions.
struct WaveSetup {
    opts: anisobond::cavity::dynamics::WaveOptions,
    /// Directions (degrees from x).
    dirs: [f64; 3],
    /// Quasi-longitudinal Christoffel speed along each (m/s).
    speeds: Vec<f64>,
}

/// The options of `--waves` (ramp, duration, probes), refused (naming `--ramp-time` and
/// `--snapshots`) when the library's [`Cavity::check_waves`] refuses them.
fn wave_options(
    a: &CavityArgs,
    cavity: &Cavity,
    relaxed: &Stiffness6,
    rho: f64,
) -> Result<WaveSetup> {
    use anisobond::cavity::dynamics::WaveOptions;
    let g = cavity.geometry;
    let r = cavity.cut.packing.mean_radius();
    let dirs = [0.0f64, 45.0, 90.0];
    let speeds: Vec<f64> = dirs
        .iter()
        .map(|d| {
            let t = d.to_radians();
            phase_velocities(relaxed, rho, &Vec3::new(t.cos(), t.sin(), 0.0))
                .map(|w| w.quasi_longitudinal().speed)
        })
        .collect::<Result<_>>()?;
    let vmax = speeds.iter().copied().fold(0.0, f64::max);
    let vmin = speeds.iter().copied().fold(f64::INFINITY, f64::min);
    let ramp = a.ramp_time.unwrap_or(20.0 * r / vmax);
    if !(ramp.is_finite() && ramp > 0.0) {
        return Err(anisobond::Error::Invalid(format!(
            "--ramp-time must be finite and > 0 s, got {ramp}"
        )));
    }
    let (r1, r2) = (
        g.inner_radius + 0.3 * (g.outer_radius - g.inner_radius),
        g.inner_radius + 0.75 * (g.outer_radius - g.inner_radius),
    );
    let opts = WaveOptions {
        pressure: a.pressure,
        ramp_time: ramp,
        duration: 1.5 * ramp + (r2 - g.inner_radius + 2.0 * r) / vmin,
        material_density: a.density,
        law: anisobond::dem::LawKind::Yade,
        directions: dirs.iter().map(|d| d.to_radians()).collect(),
        probe_radii: vec![r1, r2],
        probe_half_angle: 15f64.to_radians(),
        snapshots: a.snapshots,
    };
    cavity.check_waves(&opts).map_err(|e| {
        e.in_context(format!(
            "--waves with --ramp-time {ramp:e} s, --snapshots {}",
            a.snapshots
        ))
    })?;
    Ok(WaveSetup { opts, dirs, speeds })
}

/// The wave run of `--waves`: fronts (JSON), VTK series and PNG snapshots into `dir/waves`.
fn run_waves(
    cavity: &Cavity,
    setup: &WaveSetup,
    dir: &std::path::Path,
) -> Result<serde_json::Value> {
    let (dirs, speeds) = (&setup.dirs, &setup.speeds);
    let (ramp, r1, r2) = (
        setup.opts.ramp_time,
        setup.opts.probe_radii[0],
        setup.opts.probe_radii[1],
    );
    let run = cavity.run_waves(&setup.opts)?;
    let wdir = dir.join("waves");
    std::fs::create_dir_all(&wdir).map_err(|e| anisobond::Error::io(&wdir, e))?;
    run.write_vtk_series(cavity, &wdir)?;
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
        anisobond::plot::plot_particle_map(
            &wdir.join(format!("snapshot_{k:04}.png")),
            &points,
            &ur,
            &format!("radial displacement (red out, blue in), t = {t:.3e} s"),
        )?;
    }
    let fronts: Vec<serde_json::Value> = dirs
        .iter()
        .enumerate()
        .map(|(d, angle)| {
            serde_json::json!({
                "angle_from_x_deg": angle,
                "front_speed_m_per_s": run.front_speed[d],
                "christoffel_m_per_s": speeds[d],
                "arrival_s": run.arrival[d],
                "probe_spheres": run.probe_sizes[d],
            })
        })
        .collect();
    Ok(serde_json::json!({
        "ramp_time_s": ramp,
        "time_step_s": run.time_step,
        "steps": run.times.len(),
        "probe_radii_m": [r1, r2],
        "detection": "peak of the probes' mean velocity along the direction (±15°, ±R̄ in radius); speed = Δr/Δt between the two probes",
        "fronts": fronts,
        "snapshot_times_s": run.snapshots.iter().map(|s| s.0).collect::<Vec<_>>(),
    }))
}
