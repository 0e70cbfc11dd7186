//! `anisobond specimen`: the exact static response of a finite bonded specimen between two
//! platens ([`anisobond::specimen`]): platen stiffness, apparent E and ν, the field.

use super::cell;
use super::output::check_json_numbers;
use anisobond::export::vtk::{write_bonds_vtu, write_particles_vtu, StrainedState};
use anisobond::io::OutputSet;
use anisobond::specimen::{self, Platens, SpecimenOptions, SpecimenReport};
use anisobond::tensor::Voigt6;
use anisobond::{Error, Result};
use clap::ValueEnum;
use std::path::{Path, PathBuf};

/// Loading axis.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum AxisArg {
    /// Along x.
    X,
    /// Along y.
    Y,
    /// Along z.
    Z,
}

/// How the platens hold the end layers.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum PlatensArg {
    /// Only the axial displacement of the layers' particles is prescribed (YADE
    /// `blockedDOFs = 'z'`); the other degrees of freedom are free.
    Frictionless,
    /// All six degrees of freedom of the layers' particles are prescribed (no slip).
    Bonded,
}

/// Options of `anisobond specimen`.
#[derive(clap::Args)]
pub struct SpecimenArgs {
    #[command(flatten)]
    input: cell::BondedInput,
    /// Loading axis.
    #[arg(long, value_enum, default_value_t = AxisArg::Z)]
    axis: AxisArg,
    /// Depth of each end layer (m): the particles whose centres lie within it of the lowest
    /// (held) and of the highest (moved) centre along the axis; default the mean radius.
    #[arg(long)]
    end_layer: Option<f64>,
    /// How the platens hold the end layers.
    #[arg(long, value_enum, default_value_t = PlatensArg::Frictionless)]
    platens: PlatensArg,
    /// Axial compressive strain applied (the response is linear: it scales the field only).
    #[arg(long, default_value_t = 1e-4)]
    strain: f64,
    /// Output folder: specimen.json, particles.csv, particles.vtu, bonds.vtu.
    #[arg(short, long, default_value = "anisobond-specimen")]
    output: PathBuf,
}

/// Run `anisobond specimen`.
pub fn run(a: SpecimenArgs) -> Result<()> {
    let mut out = OutputSet::new(&a.input.paths());
    let dir = out.dir(&a.output)?;
    let asm = a.input.assembly()?;
    let mean_radius = asm.packing.radii.iter().sum::<f64>() / asm.packing.len() as f64;
    let mut opts = SpecimenOptions::new(a.axis as usize, a.end_layer.unwrap_or(mean_radius));
    opts.platens = match a.platens {
        PlatensArg::Frictionless => Platens::Frictionless,
        PlatensArg::Bonded => Platens::Bonded,
    };
    opts.strain = a.strain;
    let r = specimen::solve(&asm, &opts).map_err(|e| match e {
        Error::Invalid(m) => Error::Invalid(format!(
            "{m} (options --axis, --end-layer {} m, --strain)",
            opts.end_layer
        )),
        other => other,
    })?;
    let json =
        serde_json::to_value(&r).map_err(|e| Error::Invalid(format!("specimen report: {e}")))?;
    check_json_numbers(&json, "specimen")?;
    let text = serde_json::to_string_pretty(&json)
        .map_err(|e| Error::Invalid(format!("specimen report: {e}")))?;
    anisobond::io::write_string_atomic(&dir.join("specimen.json"), &(text + "\n"))?;
    write_particles_csv(
        &dir.join("particles.csv"),
        &asm.packing.positions,
        &asm.packing.radii,
        &r,
    )?;
    let state = StrainedState {
        strain: Voigt6::zeros(),
        displacement: r.displacement_field.clone(),
        rotation: r.rotation_field.clone(),
        force: r.bond_force.clone(),
    };
    write_particles_vtu(&dir.join("particles.vtu"), &asm.packing, Some(&state))?;
    write_bonds_vtu(
        &dir.join("bonds.vtu"),
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        Some(&state),
    )?;
    out.commit()?;
    print_report(&r, &a.output);
    Ok(())
}

/// One row per particle: id, position, radius, layer, displacement, platen force.
fn write_particles_csv(
    path: &Path,
    positions: &[anisobond::Vec3],
    radii: &[f64],
    r: &SpecimenReport,
) -> Result<()> {
    anisobond::io::write_atomic(path, |w| {
        let io = |e| Error::io(path, e);
        writeln!(
            w,
            "id,x [m],y [m],z [m],radius [m],layer,ux [m],uy [m],uz [m],fx [N],fy [N],fz [N]"
        )
        .map_err(io)?;
        for (p, (x, rad)) in positions.iter().zip(radii).enumerate() {
            let (u, f) = (r.displacement_field[p], r.reaction[p]);
            let layer = ["", "bottom", "top"][r.layer[p] as usize];
            writeln!(
                w,
                "{p},{:e},{:e},{:e},{rad:e},{layer},{:e},{:e},{:e},{:e},{:e},{:e}",
                x.x, x.y, x.z, u.x, u.y, u.z, f.x, f.y, f.z
            )
            .map_err(io)?;
        }
        Ok(())
    })
}

fn print_report(r: &SpecimenReport, dir: &Path) {
    println!(
        "specimen along {}: {} of {} particles loaded ({} bonds), {:?} platens; layers {} (held) and {} (moved)",
        r.axis, r.loaded_particles, r.n_particles, r.loaded_bonds, r.platens, r.bottom_layer, r.top_layer
    );
    println!(
        "  gauge length {:.6e} m, cross-section {:.6e} m², shortening {:.3e} m",
        r.length, r.area, r.displacement
    );
    println!(
        "  platen force {:.6e} N (bottom {:.6e} N), platen stiffness {:.6e} N/m",
        r.axial_force, r.bottom_force, r.platen_stiffness
    );
    println!(
        "  apparent Young's modulus E = {:.4} GPa, Poisson's ratios {:.4} / {:.4} (mean {:.4})",
        r.young / 1e9,
        r.poisson_lateral[0],
        r.poisson_lateral[1],
        r.poisson
    );
    println!(
        "  solve: {} unknowns, relative residual {:.2e}",
        r.unknowns, r.relative_residual
    );
    println!(
        "wrote {}/specimen.json, particles.csv, particles.vtu, bonds.vtu",
        dir.display()
    );
}
