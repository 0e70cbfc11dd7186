//! `anisobond cavity`: a pressurised circular hole in a slab cut from a periodic packing
//! (Šmilauer's cross-anisotropy report, last section; issue 22): the static wall
//! displacement beside Lamé's thick cylinder, and the Christoffel wave speeds of the
//! packing's relaxed tensor in the slab's plane. The study is the library's
//! ([`anisobond::study::cavity`]); this file parses, calls and prints.

use super::cell;
use anisobond::io::OutputSet;
use anisobond::study::cavity::{run as run_study, CavityReport, CavityStudyOptions};
use anisobond::study::OptionNames;
use anisobond::Result;
use std::path::PathBuf;

/// The study's defaults (the library's, once).
fn d() -> CavityStudyOptions {
    CavityStudyOptions::default()
}

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
    #[arg(long, default_value_t = d().pressure)]
    pressure: f64,
    /// Material density of the spheres (kg/m³), for the wave speeds.
    #[arg(long, default_value_t = d().density)]
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
    #[arg(long, default_value_t = d().snapshots)]
    snapshots: usize,
    /// Output folder: cavity.json, particles.csv, cavity.vtu (and waves/ with --waves).
    #[arg(short, long, default_value = "anisobond-cavity")]
    output: PathBuf,
}

/// Run `anisobond cavity`.
pub fn run(a: CavityArgs) -> Result<()> {
    let opts = CavityStudyOptions {
        hole_radius: a.hole_radius,
        outer_radius: a.outer_radius,
        clamp_width: a.clamp_width,
        ray_spacing: a.ray_spacing,
        pressure: a.pressure,
        density: a.density,
        waves: a.waves,
        ramp_time: a.ramp_time,
        snapshots: a.snapshots,
    };
    opts.check(OptionNames::Flags)?;
    let mut out = OutputSet::new(&a.input.paths());
    let dir = out.dir(&a.output)?;
    let src = a.input.assembly()?;
    let r = run_study(&src, &opts, OptionNames::Flags)?;
    r.write(&dir)?;
    out.commit()?;
    print_report(&r);
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

/// The report's lines: the slab, the wall displacement beside Lamé and the continuum, the
/// wall bins and the wave fronts.
fn print_report(r: &CavityReport) {
    let c = &r.continuum;
    println!(
        "cavity: a = {:.4e} m, b = {:.4e} m, slab {} spheres ({} free, {} on the wall), p = {:.4e} Pa",
        r.hole_radius_m, r.clamped_radius_m, r.spheres, r.free_spheres, r.wall_spheres, r.pressure_pa
    );
    println!(
        "  wall displacement {:.5e} m (DEM), {:.5e} m (Lamé, λ = {:.4e} Pa, μ = {:.4e} Pa from the relaxed tensor): ratio {:.4}",
        r.wall_displacement_m,
        r.lame_wall_displacement_m,
        r.lame_lambda_pa,
        r.lame_mu_pa,
        r.dem_over_lame
    );
    println!(
        "  continuum (generalized plane strain, full relaxed tensor, {} × {} triangles' mesh): \
         {:.5e} m: DEM/continuum {:.4}",
        c.mesh_rings, c.mesh_around, c.wall_displacement_m, c.dem_over_continuum
    );
    for b in &c.wall_bins_20deg {
        println!(
            "  wall at {:>3}° ± 20°: u_r {:.4e} m (DEM) {:.4e} m (continuum); u_z {:.4e} m (DEM) \
             {:.4e} m (continuum)",
            b.angle_from_x_deg,
            b.dem_radial_m,
            b.continuum_radial_m,
            b.dem_axial_m,
            b.continuum_axial_m
        );
    }
    println!(
        "  mean axial wall displacement {:.4e} m; residual {:.1e}",
        r.wall_axial_displacement_m, r.relative_residual
    );
    for f in r.waves.iter().flat_map(|w| &w.fronts) {
        println!(
            "  wave front at {:?}° from x: {:.1} m/s (DEM), {:.1} m/s (Christoffel, quasi-P)",
            f.angle_from_x_deg, f.front_speed_m_per_s, f.christoffel_m_per_s
        );
    }
}
