//! `anisobond cavity`: a pressurised circular hole in a slab cut from a periodic packing
//! (Šmilauer's cross-anisotropy report, last section; issue 22): the static wall
//! displacement beside Lamé's thick cylinder, and the Christoffel wave speeds of the
//! packing's relaxed tensor in the slab's plane.

use super::cell;
use super::output::check_json_numbers;
use anisobond::cavity::{
    bulk_density, isotropic_lame_constants, lame_wall_displacement, Cavity, CavityGeometry,
};
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
    /// Radius b of the clamped boundary (m); default 24 R̄. Spheres beyond b are held.
    #[arg(long)]
    outer_radius: Option<f64>,
    /// Width of the clamped ring (m); default the longest bond.
    #[arg(long)]
    clamp_width: Option<f64>,
    /// Side of the wall's pressure tiles (m); default R̄/4.
    #[arg(long)]
    ray_spacing: Option<f64>,
    /// Pressure in the hole (Pa; > 0 pushes the wall out).
    #[arg(long, default_value_t = 1.0e6)]
    pressure: f64,
    /// Material density of the spheres (kg/m³), for the wave speeds.
    #[arg(long, default_value_t = 2600.0)]
    density: f64,
    /// Output folder: cavity.json, particles.csv, cavity.vtu.
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
    let r = src.packing.mean_radius();
    let geometry = CavityGeometry {
        inner_radius: a.hole_radius.unwrap_or(10.0 * r),
        outer_radius: a.outer_radius.unwrap_or(24.0 * r),
        clamp_width: a
            .clamp_width
            .unwrap_or_else(|| src.bonds.length.iter().copied().fold(0.0, f64::max)),
        ray_spacing: a.ray_spacing.unwrap_or(0.25 * r),
    };
    let relaxed = src.tensor(&Method::relaxed())?.report.tensor();
    let cavity = Cavity::new(&src, geometry)?;
    let s = cavity.solve_static(a.pressure)?;
    let (lambda, mu) = isotropic_lame_constants(&relaxed);
    let (ga, gb) = (geometry.inner_radius, geometry.outer_radius);
    let lame = lame_wall_displacement(a.pressure, ga, gb, lambda, mu);
    let rho = bulk_density(&src.packing, a.density);
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
    let json = serde_json::json!({
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
        "relaxed_tensor_pa": anisobond::tensor::compare::rows(&relaxed),
        "bulk_density_kg_per_m3": rho,
        "christoffel_in_plane": speeds,
    });
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
        "  mean axial wall displacement {:.4e} m; residual {:.1e}",
        s.wall_axial_displacement, s.relative_residual
    );
    println!(
        "wrote {}/cavity.json, particles.csv, cavity.vtu",
        a.output.display()
    );
    Ok(())
}
