//! `anisobond export yade PACKING --model MODEL -o DIR`: a directory YADE runs as it is.

use anisobond::export::yade::{self, YadeRunOptions};
use anisobond::Result;
use clap::Subcommand;

/// The codes to export to (the subcommands of `export`).
#[derive(Subcommand)]
pub enum ExportTarget {
    /// YADE 2023.02a: DIR/packing.txt, bonds.csv, model.toml, anisobond_yade.py and run.py;
    /// `yade -n -x DIR/run.py` performs the six-path element test (periodic cell, velocity
    /// gradient) and writes DIR/yade-history.csv (stress history) and DIR/yade-tensor.json
    /// (6×6 C in Pa, SPEC tensor form).
    Yade(YadeArgs),
    /// LIGGGHTS 3.8: DIR/packing.data (atom_style granular), bonds.csv, the driver deck
    /// anisobond.in (per-bond anisotropic bonds through `pair_style anisobond`, built by
    /// `make -C cpp`), the stock deck harmonic.in (bond_style harmonic, normal springs only)
    /// and run.sh.
    Liggghts(super::export_liggghts::Args),
    /// LAMMPS (BPM package) data file, per-bond coefficients, element-test deck and run.sh.
    Lammps(super::export_lammps::Args),
    /// VTK XML files (DIR/particles.vtu, DIR/bonds.vtu) for ParaView, with displacements and
    /// bond forces under a macroscopic strain.
    Vtk(super::plot::ExportVtkArgs),
}

/// Arguments of `export yade`.
#[derive(clap::Args)]
pub struct YadeArgs {
    #[command(flatten)]
    pub to: super::cell::ExportPaths,
    /// Strain of each path, applied in one step (engineering strain).
    #[arg(long, default_value_t = 1e-5)]
    pub strain: f64,
    /// Relaxation steps after the strain step.
    #[arg(long, default_value_t = 200)]
    pub steps: usize,
    /// Cundall non-viscous damping of YADE's NewtonIntegrator (0 = undamped).
    #[arg(long, default_value_t = 0.4)]
    pub damping: f64,
    #[command(flatten)]
    pub step: YadeStepArgs,
    /// Strain paths to run, Voigt labels.
    #[arg(long, default_value = "11,22,33,23,13,12")]
    pub paths: String,
}

/// The masses and the time step of YADE's run, as `export yade` and `validate yade` take
/// them (YADE's time step is anisobond's critical estimate unless given).
#[derive(clap::Args)]
pub struct YadeStepArgs {
    /// Particle density (kg/m³).
    #[arg(long, default_value_t = 2600.0)]
    pub density: f64,
    /// Time step (s); default: --safety × anisobond's critical estimate from the bond
    /// stiffnesses.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Fraction of the critical time step used when --dt is not given.
    #[arg(long, default_value_t = 0.8)]
    pub safety: f64,
}

/// Run `export`.
pub fn run(target: ExportTarget) -> Result<()> {
    match target {
        ExportTarget::Yade(y) => export_yade(y),
        ExportTarget::Vtk(v) => super::plot::export_vtk(v),
        ExportTarget::Liggghts(l) => super::export_liggghts::run(l),
        ExportTarget::Lammps(l) => super::export_lammps::run(l),
    }
}

/// [`yade::export_yade`] on the packing read with the user's cell options.
fn export_yade_read(
    a: &YadeArgs,
    dir: &std::path::Path,
    opts: &YadeRunOptions,
) -> Result<yade::YadeExport> {
    opts.validate()?;
    let asm = a.to.input.assembly()?;
    if asm.packing.cell.is_none() {
        return Err(anisobond::Error::Invalid(format!(
            "{}: the packing is not periodic (no `# periodic Lx Ly Lz` header; give --cell \
             Lx,Ly,Lz for a file that states none); the YADE element tests deform a periodic \
             cell",
            a.to.input.packing.display()
        )));
    }
    yade::write_assembly_export(dir, &asm, opts)
}

fn export_yade(a: YadeArgs) -> Result<()> {
    let opts = YadeRunOptions {
        strain: a.strain,
        steps: a.steps,
        damping: a.damping,
        density: a.step.density,
        time_step: a.step.dt,
        safety: a.step.safety,
        paths: yade::parse_paths(&a.paths)?,
        stress_volume: None,
    };
    let (set, staged) = a.to.stage()?;
    let written = export_yade_read(&a, &staged, &opts)?;
    set.commit()?;
    let out = yade::YadeExport::in_dir(&a.to.output);
    if written.paths != opts.paths {
        let labels: Vec<&str> = written
            .paths
            .iter()
            .map(|&p| yade::PATH_LABELS[p])
            .collect();
        eprintln!(
            "note: the box is periodic along some axes only: run.py runs the paths {} (those of \
             the periodic axes; its header says how the free axes were extended)",
            labels.join(",")
        );
    }
    println!(
        "wrote {}: {} particles, {} bonds (packing.txt, bonds.csv, model.toml, anisobond_yade.py, run.py)",
        out.dir.display(),
        written.n_particles,
        written.n_bonds
    );
    println!(
        "run:   yade -n -x {}   → {} and {}",
        out.run_script.display(),
        out.history.display(),
        out.tensor.display()
    );
    Ok(())
}
