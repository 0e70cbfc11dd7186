//! Command-line interface (README.md "Commands"). Every command reads its inputs, calls
//! the library, prints human-readable results with units, and writes files atomically.

mod buckle;
mod calibrate;
mod calibrate_strength;
mod cavity;
mod cell;
mod convert;
mod demo;
mod domain;
mod export;
mod export_lammps;
mod export_liggghts;
mod grips;
pub mod interrupt;
mod output;
mod pack;
mod plot;
mod polycrystal;
pub mod run;
mod specimen;
mod strength_test;
mod stress_test;
mod validate;
mod validate_lammps;
mod validate_liggghts;
mod validate_specimen;
mod validate_strength;

use anisobond::assembly::{Assembly, Detail, EqualSpheres, MethodKind, MethodOptions};
use anisobond::homogenize::LeverArm;
use anisobond::homogenize::TensorReport;
use anisobond::homogenize::{
    CgPreconditioner, RelaxedOptions, RelaxedSolver, DEFAULT_PARTICLES_PER_AGGREGATE,
};
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::names::Named;
use anisobond::{Error, Result};
use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};

/// Bonded-particle DEM models of anisotropic elastic solids.
///
/// Units: SI throughout (m, N, Pa; springs in N/m, rotational springs in N·m/rad).
/// Stiffness tensors are 6×6 Voigt matrices (order 11, 22, 33, 23, 13, 12, engineering
/// shear strain), printed in GPa and written to JSON in Pa.
#[derive(Parser)]
#[command(name = "anisobond", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    #[command(flatten)]
    cell: cell::CellArgs,
}

#[derive(Subcommand)]
enum Command {
    /// The main job on an embedded default: generate a periodic packing, bond it, assign the
    /// cubic Zener>1 stiffness of Truszkowska 2018 and print its stiffness tensor by every
    /// available method beside the paper's values; write the files into DIR.
    Demo(demo::DemoArgs),
    /// Generate a seeded periodic random packing (SPEC packing text: `x y z r` in m): random
    /// and relaxed (Truszkowska 2018), or Kumar 2016's unjammed / weakly jammed / jammed
    /// routes; presets for both papers' standard assemblies.
    Pack(pack::PackArgs),
    /// Bond a packing and write the bond-stiffness table (CSV: i,j,nx,ny,nz,length [m],
    /// radius [m],kn [N/m],ks [N/m],kr [N·m/rad],ktw [N·m/rad],ix,iy,iz).
    Bonds(BondsArgs),
    /// Stiffness tensor (Pa) of a model (the methods are listed by `command()`).
    Tensor(TensorArgs),
    /// Export a packing + model (the codes are listed by `command()`).
    #[command(subcommand)]
    Export(export::ExportTarget),
    /// The reference DEM integrator on a periodic packing: the six element tests (strain in
    /// one step, Cundall-damped relaxation), stress–strain history CSV and tensor JSON.
    Run(run::RunArgs),
    /// Element tests on a free block driven through grip particles (Truszkowska 2018 Sec. 4):
    /// measurement-sphere stress and strain, the Eq. 27 tensor and the Table 3 heterogeneity.
    Grips(grips::GripsArgs),
    /// Šmilauer's stress-controlled element tests (servo-controlled zero lateral stress):
    /// engineering constants, orthotropic and transversely isotropic stiffness.
    StressTest(stress_test::StressTestArgs),
    /// Scheme parameters that reproduce a target tensor, at the mean-field level or on a
    /// packing with the exact relaxed solver; writes the calibrated model file.
    Calibrate(calibrate::CalibrateArgs),
    /// The [strength] table's scale(s) that make the virtual laboratory reach a target
    /// tensile strength (one or two directions) or UCS on the packing, iterated on the lab's
    /// peaks and verified by a final run; writes the calibrated model file.
    CalibrateStrength(calibrate_strength::CalibrateStrengthArgs),
    /// A pressurised circular hole in a slab cut from a periodic packing (periodic along
    /// the hole, outer ring clamped): wall displacement (m) beside Lamé, in-plane Christoffel
    /// wave speeds (m/s) of the relaxed tensor; JSON, CSV and VTK.
    Cavity(cavity::CavityArgs),
    /// The accessible (C12/C11, C44/C11) domain of the cubic models, as CSV and PNG.
    Domain(domain::DomainArgs),
    /// A polycrystal ([grains]): its relaxed tensor beside the single crystal's bounds and
    /// estimates, and each grain's stress against its orientation.
    Polycrystal(polycrystal::PolycrystalArgs),
    /// A finite bonded specimen between two platens (bottom layer held, top layer moved along
    /// --axis): its exact static response — platen stiffness (N/m), apparent E (Pa) and ν,
    /// the displacement field (JSON, CSV, VTK).
    Specimen(specimen::SpecimenArgs),
    /// Kumar 2016 Sec. 5: clamped round bars cut from packings of the three preparation
    /// routes at several l/r; the bonded network's linearised critical stress beside Euler
    /// (Eq. 14) and Mazzilli (Eq. 15), E from the bar's own axial modulus (CSV, JSON, PNG).
    Buckle(buckle::BuckleArgs),
    /// The virtual laboratory: UCS, direct tension or the Brazilian disc on a specimen cut
    /// from a packing at a bedding angle, run to failure with the integrator; peak stress
    /// (Pa), E and ν from the initial slope, crack counts by mode (JSON, CSV, PNG, VTK).
    StrengthTest(strength_test::StrengthTestArgs),
    /// Pictures of a model (PNG).
    #[command(subcommand)]
    Plot(plot::PlotCommand),
    /// Validate anisobond against another DEM code (the codes are listed by `command()`).
    #[command(subcommand)]
    Validate(validate::ValidateTarget),
    /// Convert a packing file for another program's loader: YADE `SpherePack.load`
    /// (spherepack) or `ymport.text` (text), LIGGGHTS `read_data` (liggghts), or SPEC text,
    /// keeping the cell and (for LIGGGHTS) the particle ids.
    Convert(convert::ConvertArgs),
}

#[derive(clap::Args)]
struct BondsArgs {
    #[command(flatten)]
    input: cell::BondedInput,
    /// Output bond table (CSV).
    #[arg(short, long)]
    output: PathBuf,
}

/// The parser of `--method`: the library's registry of method names, each value's help its
/// one-line description.
fn method_parser() -> impl clap::builder::TypedValueParser<Value = MethodKind> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        MethodKind::ALL
            .iter()
            .map(|m| PossibleValue::new(m.name()).help(m.description())),
    )
    .map(|name| MethodKind::from_name(&name).expect("a name of MethodKind::ALL"))
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum LeverArmArg {
    /// Contact point mid-gap, r_i = R_i + gap/2 (YADE's ScGeom).
    MidGap,
    /// r_i = |l|·R_i/(R_i + R_j).
    Proportional,
    /// r_i = r_j = |l|/2 (LAMMPS' bpm/rotational).
    HalfLength,
}

impl From<LeverArmArg> for LeverArm {
    fn from(a: LeverArmArg) -> Self {
        match a {
            LeverArmArg::MidGap => LeverArm::MidGap,
            LeverArmArg::Proportional => LeverArm::Proportional,
            LeverArmArg::HalfLength => LeverArm::HalfLength,
        }
    }
}

// --- relaxed linear solver option (feat-solver) ---
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum SolverArg {
    /// Conjugate gradients, two-level preconditioner (block-Jacobi + rigid cluster modes).
    Cg,
    /// Conjugate gradients with the block-Jacobi preconditioner only.
    CgJacobi,
    /// Conjugate gradients with a smoothed-aggregation multigrid V-cycle (rigid-body modes).
    CgAmg,
    /// Sparse Cholesky (faer, supernodal): direct, more memory.
    Cholesky,
}

impl From<SolverArg> for RelaxedSolver {
    fn from(a: SolverArg) -> Self {
        match a {
            SolverArg::Cg => RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::TwoLevel {
                    particles_per_aggregate: DEFAULT_PARTICLES_PER_AGGREGATE,
                },
            },
            SolverArg::CgJacobi => RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::BlockJacobi,
            },
            SolverArg::CgAmg => RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::Amg,
            },
            SolverArg::Cholesky => RelaxedSolver::Cholesky,
        }
    }
}
// --- end relaxed linear solver option ---

/// Options of the static methods (relaxed, laf).
#[derive(clap::Args, Clone, Copy)]
struct StaticArgs {
    /// Contact point (lever arm) of the bonds.
    #[arg(long, value_enum, default_value_t = LeverArmArg::MidGap)]
    lever_arm: LeverArmArg,
    /// Relaxed: CG tolerance on the relative residual (the tensor's error is ~its square).
    #[arg(long, default_value_t = MethodOptions::default().relaxed.tolerance)]
    cg_tolerance: f64,
    /// Relaxed: linear solver of the equilibrium system.
    #[arg(long, value_enum, default_value_t = SolverArg::Cg)]
    solver: SolverArg,
    /// Prestressed: mean compressive stress of the preload (Pa).
    #[arg(long, default_value_t = MethodOptions::default().prestress)]
    prestress: f64,
    /// LAF: shell order m (1–6).
    #[arg(long, default_value_t = MethodOptions::default().shell)]
    shell: usize,
    /// LAF: report the energy-based (upper bound) estimate instead of the stress-based one.
    #[arg(long)]
    energy: bool,
}

#[derive(clap::Args)]
struct TensorArgs {
    /// Packing file; optional for mean-field (then --coordination, --solid-fraction and
    /// --radius describe an equal-sphere assembly).
    packing: Option<PathBuf>,
    /// Model file (TOML or JSON).
    #[arg(long)]
    model: PathBuf,
    /// Bond table (CSV) whose bonds and springs replace the model's bonding rule and scheme,
    /// e.g. your YADE scene's bond network written by `anisobond_yade.bond_table`.
    #[arg(long)]
    bonds: Option<PathBuf>,
    /// Homogenisation method.
    #[arg(long, value_parser = method_parser())]
    method: MethodKind,
    /// Print the SPEC tensor report as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also write the JSON report to this file.
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    spheres: EqualSphereArgs,
    #[command(flatten)]
    statics: StaticArgs,
    /// Integrator settings of --method dynamic.
    #[command(flatten)]
    integrator: run::IntegratorArgs,
}

/// The names a subcommand's own subcommands or a value enum accept, joined by ", ".
fn names<I: IntoIterator<Item = String>>(names: I) -> String {
    names.into_iter().collect::<Vec<_>>().join(", ")
}

/// The subcommands of `name` (without `help`), as the parser accepts them.
fn subcommand_names(cmd: &clap::Command, name: &str) -> String {
    names(
        cmd.find_subcommand(name)
            .into_iter()
            .flat_map(|c| c.get_subcommands())
            .map(|s| s.get_name().to_string())
            .filter(|n| n != "help"),
    )
}

/// The command line parser, with the lists in the one-line help of `tensor`, `export` and
/// `validate` taken from the names the parser itself accepts (so they cannot go stale).
fn command() -> clap::Command {
    use clap::CommandFactory;
    let cmd = Cli::command();
    let methods = names(MethodKind::ALL.iter().map(|m| m.name().to_string()));
    let exports = subcommand_names(&cmd, "export");
    let engines = subcommand_names(&cmd, "validate");
    cmd.mut_subcommand("tensor", |c| {
        c.about(format!(
            "Stiffness tensor (Pa) of a model by --method: {methods}"
        ))
    })
    .mut_subcommand("export", |c| {
        c.about(format!(
            "Export a packing + model, ready to run or view: {exports}"
        ))
    })
    .mut_subcommand("validate", |c| {
        c.about(format!(
            "Validate anisobond against another DEM code ({engines}): the same problem in \
             both, the differences as a table and files; non-zero exit status when out of \
             tolerance"
        ))
    })
}

/// Parse the command line and run it.
pub fn run() -> Result<()> {
    use clap::FromArgMatches;
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    cell::set(&cli.cell)?;
    match cli.command {
        Command::Demo(a) => demo::run(a),
        Command::Pack(a) => pack::run(a),
        Command::Bonds(a) => bonds_cmd(a),
        Command::Tensor(a) => tensor_cmd(a),
        Command::Export(a) => export::run(a),
        Command::Run(a) => run::run(a),
        Command::Grips(a) => grips::grips(a),
        Command::StressTest(a) => stress_test::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::CalibrateStrength(a) => calibrate_strength::run(a),
        Command::Domain(a) => domain::run(a),
        Command::Polycrystal(a) => polycrystal::run(a),
        Command::Specimen(a) => specimen::run(a),
        Command::Buckle(a) => buckle::run(a),
        Command::StrengthTest(a) => strength_test::run(a),
        Command::Cavity(a) => cavity::run(a),
        Command::Plot(c) => plot::run(c),
        Command::Validate(a) => validate::run(a),
        Command::Convert(a) => convert::run(a),
    }
}

fn bonds_cmd(a: BondsArgs) -> Result<()> {
    let mut out = OutputSet::new(&a.input.paths());
    let staged = out.file(&a.output)?;
    let asm = a.input.assembly()?;
    asm.write_bonds(&staged)?;
    out.commit()?;
    println!(
        "wrote {}: {} bonds between {} particles (coordination Z = {:.3})",
        a.output.display(),
        asm.bonds.len(),
        asm.packing.len(),
        asm.coordination()
    );
    Ok(())
}

/// The relaxed solver's settings from the command line.
fn relaxed_options(st: &StaticArgs) -> RelaxedOptions {
    RelaxedOptions {
        lever_arm: st.lever_arm.into(),
        tolerance: st.cg_tolerance,
        solver: st.solver.into(),
        ..Default::default()
    }
}

/// The options of every method from the command line (the integrator's checked when `m` is
/// the dynamic method).
fn method_options(
    m: MethodKind,
    st: &StaticArgs,
    integrator: &run::IntegratorArgs,
) -> Result<MethodOptions> {
    if m == MethodKind::Dynamic {
        integrator.validate()?;
    }
    Ok(MethodOptions {
        relaxed: relaxed_options(st),
        prestress: st.prestress,
        shell: st.shell,
        energy: st.energy,
        law: integrator.law.into(),
        element: run::element_options(integrator, false),
    })
}

/// The checked tensor report of `asm` by `m` (a progress bar for the dynamic method), with
/// what the method says about its solution on standard error.
fn report_of(
    asm: &Assembly,
    m: MethodKind,
    st: &StaticArgs,
    integrator: &run::IntegratorArgs,
) -> Result<TensorReport> {
    let method = method_options(m, st, integrator)?.method(m);
    let bar = if m == MethodKind::Dynamic {
        output::progress_bar("element tests")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let result = asm.tensor_with_progress(&method, &|f: f64| {
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
    });
    bar.finish_and_clear();
    let result = result?;
    print_detail(&result.detail, st);
    Ok(result.report)
}

/// What a method says about its solution, on standard error (`st`: the static options it
/// ran with, for the solver's and LAF estimate's names).
fn print_detail(detail: &Detail, st: &StaticArgs) {
    match detail {
        Detail::Relaxed(r) => {
            let ns = &r.null_space;
            eprintln!(
                "relaxed ({}): residual {:.1e}; {} active particles, {} active bonds; removed {} particles with < 2 bonds ({} bonds); {} two-bond particles (one free rotation each); {} rigid translations; {} other locally singular particles",
                match st.solver {
                    SolverArg::Cholesky => "sparse Cholesky".to_string(),
                    SolverArg::Cg => format!("two-level CG, {} iterations", r.iterations),
                    SolverArg::CgJacobi => format!("block-Jacobi CG, {} iterations", r.iterations),
                    SolverArg::CgAmg => format!("multigrid CG, {} iterations", r.iterations),
                },
                r.relative_residual, r.active_particles, r.active_bonds,
                ns.removed_particles, ns.removed_bonds, ns.two_bond_particles, ns.rigid_translations, ns.other_singular_particles
            );
        }
        Detail::Prestressed(t) => {
            let s = &t.stress;
            eprintln!(
                "prestressed: preload stress diag ({:.4e}, {:.4e}, {:.4e}) Pa; energy tangent C11 {:.4e} Pa; residual {:.1e}, {} active particles",
                s[(0, 0)], s[(1, 1)], s[(2, 2)], t.c_energy[(0, 0)], t.relaxed.relative_residual, t.relaxed.active_particles
            );
        }
        Detail::Laf(r) => {
            eprintln!(
                "laf: shell order {}, {:.1} free particles per shell; reporting the {} estimate",
                r.shell,
                r.mean_free_particles,
                if st.energy {
                    "energy-based (upper bound)"
                } else {
                    "stress-based"
                }
            );
            if !st.energy {
                eprintln!(
                    "note: the stress-based LAF estimate is not major-symmetric (Kruyt 2014 \
                     Sec. 4): max|C - C^T| / max|C| = {:.2e}, reported as `asymmetry`; it is \
                     given as computed, not symmetrised",
                    r.stress_asymmetry
                );
            }
        }
        Detail::Dynamic(d) => run::print_stability(d),
        Detail::None => {}
    }
}

/// Name the input files in a refusal whose cause lies in them: a computed tensor that is not
/// a result (overflow, no load, mechanism) or a run that blows up ([`Error::Degenerate`]).
fn blame_inputs(e: Error, inputs: &[&Path]) -> Error {
    match e {
        Error::Degenerate(_) => e.in_context(input_names(inputs)),
        other => other,
    }
}

/// The input files, comma-separated.
fn input_names(inputs: &[&Path]) -> String {
    let names: Vec<String> = inputs.iter().map(|p| p.display().to_string()).collect();
    names.join(", ")
}

/// The equal spheres of a mean field without a packing (`tensor`, `calibrate`).
#[derive(clap::Args, Clone, Copy, Debug)]
pub(crate) struct EqualSphereArgs {
    /// Mean field without a packing: mean bonds per particle Z.
    #[arg(long, default_value_t = 7.7)]
    coordination: f64,
    /// Mean field without a packing: solid fraction φ.
    #[arg(long, default_value_t = 0.6)]
    solid_fraction: f64,
    /// Mean field without a packing: sphere radius R (m).
    #[arg(long, default_value_t = 1e-3)]
    radius: f64,
}

impl EqualSphereArgs {
    /// The equal-sphere bond density of these options, refused by option name when out of
    /// range or overflowing.
    pub(crate) fn equal_spheres(
        &self,
        geometry: &anisobond::schemes::Geometry,
    ) -> Result<EqualSpheres> {
        let EqualSphereArgs {
            coordination,
            solid_fraction,
            radius,
        } = *self;
        for (name, v) in [
            ("--coordination", coordination),
            ("--solid-fraction", solid_fraction),
            ("--radius", radius),
        ] {
            if !v.is_finite() || v <= 0.0 {
                return Err(Error::Invalid(format!("{name} must be > 0, got {v}")));
            }
        }
        if !(0.01..1.0).contains(&solid_fraction) {
            return Err(Error::Invalid(format!(
                "--solid-fraction must be in [0.01, 1) (a bonded sphere assembly), got {solid_fraction}"
            )));
        }
        let spheres = EqualSpheres {
            coordination,
            solid_fraction,
            radius,
        };
        spheres.prefactor(geometry).map_err(|_| {
            Error::Invalid(format!(
                "--coordination {coordination:e}, --solid-fraction {solid_fraction}, --radius \
                 {radius:e} m give a bond-density prefactor out of the range of double precision \
                 (radius in metres, e.g. 1e-3)"
            ))
        })?;
        Ok(spheres)
    }
}

fn tensor_cmd(a: TensorArgs) -> Result<()> {
    if a.method == MethodKind::Dynamic {
        a.integrator.validate()?;
    }
    let mut inputs = output::inputs(a.packing.as_deref(), &a.model);
    if let Some(b) = &a.bonds {
        inputs.push(b);
    }
    let mut out = OutputSet::new(&inputs);
    let staged = out.optional_file(a.output.as_deref())?;
    let model = Model::from_path(&a.model)?;
    let report = match (&a.packing, a.method) {
        (Some(p), m) => {
            let asm = match &a.bonds {
                Some(table) => cell::assembly_with_table(p, model.clone(), table)?,
                None => cell::assembly_with(p, model.clone(), &a.model)?,
            };
            report_of(&asm, m, &a.statics, &a.integrator).map_err(|e| blame_inputs(e, &inputs))?
        }
        (None, MethodKind::MeanField) => {
            a.spheres
                .equal_spheres(&model.geometry)?
                .mean_field(&model)
                // The options are checked by now: an invalid input here is a model that
                // needs a packing (the cross-anisotropic scheme), named by its file.
                .map_err(|e| match e {
                    Error::Invalid(_) => e.in_context(input_names(&inputs)),
                    other => blame_inputs(other, &inputs),
                })?
        }
        (None, m) => {
            return Err(Error::Invalid(format!(
                "--method {} works on the actual bonds: give a PACKING",
                m.name()
            )))
        }
    };
    if let Some(path) = &staged {
        output::write_json(path, &report)?;
    }
    out.commit()?;
    if a.json {
        println!("{}", report.to_json());
    } else {
        output::print_report(&report);
    }
    Ok(())
}
