//! `anisobond plot stiffness` (polar sections of k_n(n), k_s(n), Truszkowska 2018 Fig. 3)
//! and `anisobond export vtk` (ParaView files of particles and bonds).

use anisobond::assembly::Assembly;
use anisobond::export::vtk::{strained_state, write_bonds_vtu_grains, write_particles_vtu_grains};
use anisobond::homogenize::RelaxedOptions;
use anisobond::io::OutputSet;
use anisobond::model::{Model, SchemeSpec};
use anisobond::plot::{plot_stiffness_sections, Section};
use anisobond::schemes::Convention;
use anisobond::tensor::Voigt6;
use anisobond::{Error, Result};
use clap::Subcommand;
use std::path::PathBuf;

/// What to plot.
#[derive(Subcommand)]
pub enum PlotCommand {
    /// Polar plots of a model's normal and shear stiffness magnitudes in the (100) and (1-10)
    /// crystal planes (cubic) or in planes containing / normal to the axis (cross-anisotropic).
    Stiffness(StiffnessArgs),
}

/// Options of `anisobond plot stiffness`.
#[derive(clap::Args)]
pub struct StiffnessArgs {
    /// Model file.
    #[arg(long)]
    model: PathBuf,
    /// Packing (needed by the cross-anisotropic scheme for its lattice scaling μ).
    packing: Option<PathBuf>,
    /// Output folder: stiffness.png.
    #[arg(short, long, default_value = ".")]
    output: PathBuf,
}

/// Run `anisobond plot …`.
pub fn run(cmd: PlotCommand) -> Result<()> {
    match cmd {
        PlotCommand::Stiffness(a) => stiffness(a),
    }
}

fn unit(c: Convention) -> &'static str {
    match c {
        Convention::Area => "Pa/m",
        Convention::Modulus | Convention::Kumar => "Pa",
        Convention::Spring => "N/m",
    }
}

fn stiffness(a: StiffnessArgs) -> Result<()> {
    let inputs = super::output::inputs(a.packing.as_deref(), &a.model);
    let mut out = OutputSet::new(&inputs);
    let dir = out.dir(&a.output)?;
    let model = Model::from_path(&a.model)?;
    let bonded = match &a.packing {
        Some(p) => Some(Assembly::new(super::cell::read(p)?, model.clone())?),
        None => None,
    };
    let scheme = model.build_scheme(bonded.as_ref().map(|b| (&b.packing, &b.bonds)))?;
    let sections = match &model.scheme {
        SchemeSpec::Cubic(c) => Section::cubic_planes(&c.rotation),
        SchemeSpec::CrossAnisotropic(t) => Section::axis_planes(&t.axis),
        SchemeSpec::Isotropic { .. } => Section::cubic_planes(&anisobond::Mat3::identity()),
    };
    plot_stiffness_sections(
        &dir.join("stiffness.png"),
        scheme.as_ref(),
        &sections,
        &format!(
            "{}: normal (blue) and shear (gold) magnitudes",
            scheme.name()
        ),
        unit(model.geometry.convention),
    )?;
    out.commit()?;
    println!("wrote {}", a.output.join("stiffness.png").display());
    Ok(())
}

/// Options of `anisobond export vtk`.
#[derive(clap::Args)]
pub struct ExportVtkArgs {
    #[command(flatten)]
    input: super::cell::BondedInput,
    /// Macroscopic engineering strain applied for displacements and bond forces (Voigt
    /// order 11,22,33,23,13,12; periodic packings only). `0` writes the unloaded state.
    #[arg(long, default_value = "1e-3,0,0,0,0,0")]
    strain: String,
    /// Output folder: particles.vtu and bonds.vtu.
    #[arg(short, long)]
    output: PathBuf,
}

fn parse_strain(s: &str) -> Result<Option<Voigt6>> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() == 1 && parts[0].parse::<f64>().ok() == Some(0.0) {
        return Ok(None);
    }
    if parts.len() != 6 {
        return Err(Error::Invalid(format!(
            "--strain `{s}`: expected 6 comma-separated numbers (Voigt 11,22,33,23,13,12) or 0"
        )));
    }
    let mut e = Voigt6::zeros();
    for (k, p) in parts.iter().enumerate() {
        e[k] = p
            .parse()
            .map_err(|_| Error::Invalid(format!("--strain: `{p}` is not a number")))?;
        let small = e[k].abs() <= 0.1;
        if !small {
            return Err(Error::Invalid(format!(
                "--strain: `{p}` is not a small strain: the state is linear (small-strain), \
                 expected |ε| ≤ 0.1"
            )));
        }
    }
    Ok(if e.iter().all(|&x| x == 0.0) {
        None
    } else {
        Some(e)
    })
}

/// Run `anisobond export vtk`.
pub fn export_vtk(a: ExportVtkArgs) -> Result<()> {
    let model = Model::from_path(&a.input.model)?;
    let strain = parse_strain(&a.strain)?;
    let mut out = OutputSet::new(&a.input.paths());
    let dir = out.dir(&a.output)?;
    let b = Assembly::new(super::cell::read(&a.input.packing)?, model.clone())?;
    let state = match (strain, b.packing.cell.is_some()) {
        (Some(e), true) => Some(strained_state(
            &b.packing,
            &b.bonds,
            &b.springs,
            &e,
            &RelaxedOptions::default(),
        )?),
        (Some(_), false) => {
            eprintln!("note: the packing is not periodic; writing the unloaded state (no displacements, no forces)");
            None
        }
        (None, _) => None,
    };
    // A polycrystal's grain ids: the point field `grain`, the cell fields `grain_i`, `grain_j`.
    let grains = b.grains().map(|g| g.grain.as_slice());
    write_particles_vtu_grains(
        &dir.join("particles.vtu"),
        &b.packing,
        state.as_ref(),
        grains,
    )?;
    write_bonds_vtu_grains(
        &dir.join("bonds.vtu"),
        &b.packing,
        &b.bonds,
        &b.springs,
        state.as_ref(),
        grains,
    )?;
    out.commit()?;
    let (particles, bonds) = (a.output.join("particles.vtu"), a.output.join("bonds.vtu"));
    if let Some(s) = &state {
        println!(
            "state at quasi-static equilibrium under strain {:?} (relaxed fluctuations)",
            s.strain.as_slice()
        );
    }
    println!(
        "wrote {} ({} particles) and {} ({} bonds); open them in ParaView",
        particles.display(),
        b.packing.len(),
        bonds.display(),
        b.bonds.len()
    );
    Ok(())
}
