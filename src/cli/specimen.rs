//! `anisobond specimen`: the exact static response of a finite bonded specimen between two
//! platens ([`anisobond::specimen`]): platen stiffness, apparent E and ν, the field.

use super::cell;
use super::output::check_json_numbers;
use anisobond::export::vtk::{write_bonds_vtu_grains, write_particles_vtu_grains, StrainedState};
use anisobond::io::OutputSet;
use anisobond::specimen::{
    Lateral, Load, Platens, Selection, Shape, SolverChoice, SpecimenOptions, SpecimenReport,
};
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

/// Cross-section shape.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum ShapeArg {
    /// A prism: the bounding box of the spheres across the axis.
    Prism,
    /// A cylinder about the axis.
    Cylinder,
}

/// What lies across the axis.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum LateralArg {
    /// A free surface (a free packing).
    Free,
    /// The periodic cell's lateral faces (a periodic packing, cut at its faces normal to the
    /// axis).
    Periodic,
}

/// Linear solver.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum SolverArg {
    /// Sparse Cholesky up to 2,000 loaded particles, two-level CG above.
    Auto,
    /// Sparse Cholesky.
    Cholesky,
    /// Two-level preconditioned CG.
    Cg,
    /// CG with a smoothed-aggregation multigrid V-cycle (rigid-body modes), as `tensor
    /// --solver cg-amg`.
    CgAmg,
}

/// Options of `anisobond specimen`.
#[derive(clap::Args)]
pub struct SpecimenArgs {
    #[command(flatten)]
    input: cell::BondedInput,
    /// Bond table (CSV) whose bonds and springs replace the model's bonding rule and scheme
    /// (your own bond network, e.g. written by `anisobond_yade.bond_table` or `anisobond
    /// bonds`).
    #[arg(long)]
    bonds: Option<PathBuf>,
    /// Loading axis (default: a slab's one non-periodic axis, e.g. z of a `p p f` box; else z).
    #[arg(long, value_enum)]
    axis: Option<AxisArg>,
    /// Depth of each end layer (m): the particles whose centres lie within it of the lowest
    /// (held) and of the highest (moved) centre along the axis; default the mean radius.
    #[arg(long)]
    end_layer: Option<f64>,
    /// The held group instead of the lowest end layer: box:XLO,YLO,ZLO,XHI,YHI,ZHI |
    /// cylinder:DIM,C1,C2,RADIUS,LO,HI (LAMMPS's region cylinder) | ids:ID,ID,… | file:PATH
    /// (ids separated by spaces, commas or lines; the packing's own ids, else 0-based order).
    #[arg(long, value_name = "GROUP")]
    held: Option<String>,
    /// The moved group instead of the highest end layer (same forms as --held).
    #[arg(long, value_name = "GROUP")]
    moved: Option<String>,
    /// How the platens hold the groups.
    #[arg(long, value_enum, default_value_t = PlatensArg::Frictionless)]
    platens: PlatensArg,
    /// Axial compressive strain applied (default 1e-4; the response is linear).
    #[arg(long)]
    strain: Option<f64>,
    /// Shortening of the moved group towards the held one (m), instead of --strain.
    #[arg(long)]
    displacement: Option<f64>,
    /// Axial compressive force on the moved group (N), a rigid platen: the shortening is
    /// computed (force control).
    #[arg(long)]
    force: Option<f64>,
    /// Lateral confining pressure on the free lateral surface (Pa, compression positive).
    #[arg(long)]
    confining_pressure: Option<f64>,
    /// Cross-section shape: the area of E and the confining surface.
    #[arg(long, value_enum, default_value_t = ShapeArg::Prism)]
    shape: ShapeArg,
    /// Free or periodic across the axis (periodic: a periodic packing cut at its faces
    /// normal to the axis, or a slab as read, e.g. a `p p f` box loaded along z; the lateral
    /// periods free with frictionless platens). Default: periodic for a box of mixed
    /// periodicity, else free.
    #[arg(long, value_enum)]
    lateral: Option<LateralArg>,
    /// Linear solver.
    #[arg(long, value_enum, default_value_t = SolverArg::Auto)]
    solver: SolverArg,
    /// Output folder: specimen.json, particles.csv, particles.vtu, bonds.vtu.
    #[arg(short, long, default_value = "anisobond-specimen")]
    output: PathBuf,
}

/// Run `anisobond specimen`.
pub fn run(a: SpecimenArgs) -> Result<()> {
    let held = a
        .held
        .as_deref()
        .map(|t| Selection::parse(t, "--held"))
        .transpose()?;
    let moved = a
        .moved
        .as_deref()
        .map(|t| Selection::parse(t, "--moved"))
        .transpose()?;
    if a.strain.is_some() as u8 + a.displacement.is_some() as u8 + a.force.is_some() as u8 > 1 {
        return Err(Error::Invalid(
            "give one of --strain, --displacement and --force".into(),
        ));
    }
    let mut inputs: Vec<&Path> = a.input.paths().to_vec();
    if let Some(b) = &a.bonds {
        inputs.push(b);
    }
    let mut out = OutputSet::new(&inputs);
    let dir = out.dir(&a.output)?;
    let asm = match &a.bonds {
        Some(table) => anisobond::assembly::Assembly::from_table_file(
            cell::read(&a.input.packing)?,
            anisobond::model::Model::from_path(&a.input.model)?,
            table,
        )?,
        None => a.input.assembly()?,
    };
    let axis = a.axis.map(|axis| axis as usize);
    let mut opts = SpecimenOptions::defaults_for(&asm.packing, axis, a.end_layer);
    opts.platens = match a.platens {
        PlatensArg::Frictionless => Platens::Frictionless,
        PlatensArg::Bonded => Platens::Bonded,
    };
    opts.load = match (a.strain, a.displacement, a.force) {
        (Some(s), None, None) => Load::Strain(s),
        (None, Some(d), None) => Load::Displacement(d),
        (None, None, Some(f)) => Load::Force(f),
        _ => Load::default(),
    };
    opts.held = held;
    opts.moved = moved;
    opts.confining_pressure = a.confining_pressure;
    opts.shape = match a.shape {
        ShapeArg::Prism => Shape::Prism,
        ShapeArg::Cylinder => Shape::Cylinder,
    };
    opts.lateral = match a.lateral {
        Some(LateralArg::Free) => Lateral::Free,
        Some(LateralArg::Periodic) => Lateral::Periodic,
        None => opts.lateral,
    };
    opts.solver = match a.solver {
        SolverArg::Auto => SolverChoice::Auto,
        SolverArg::Cholesky => SolverChoice::Cholesky,
        SolverArg::Cg => SolverChoice::Cg,
        SolverArg::CgAmg => SolverChoice::CgAmg,
    };
    let r = anisobond::specimen::solve(&asm, &opts).map_err(|e| match e {
        Error::Invalid(m) => Error::Invalid(format!(
            "{m} (options --axis, --end-layer {} m, --held, --moved, --strain, --displacement, \
             --force, --confining-pressure, --lateral)",
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
    let state = StrainedState {
        strain: Voigt6::zeros(),
        displacement: r.displacement_field.clone(),
        rotation: r.rotation_field.clone(),
        force: r.bond_force.clone(),
    };
    // A polycrystal's grain ids: `grain` per particle, `grain_i`, `grain_j` per bond.
    let grains = asm.grains().map(|g| g.grain.as_slice());
    let (p, b, k) = (&asm.packing, &asm.bonds, &asm.springs);
    // The three large files at once: each formats in parallel but writes serially, so one's
    // writing overlaps the others' formatting (a million-particle specimen writes 1.3 GB).
    let (csv, (points, bonds)) = rayon::join(
        || write_particles_csv(&dir.join("particles.csv"), p, &r),
        || {
            rayon::join(
                || write_particles_vtu_grains(&dir.join("particles.vtu"), p, Some(&state), grains),
                || write_bonds_vtu_grains(&dir.join("bonds.vtu"), p, b, k, Some(&state), grains),
            )
        },
    );
    csv?;
    points?;
    bonds?;
    out.commit()?;
    print_report(&r, &a.output);
    Ok(())
}

/// One row per particle: id (the packing's own, else the 0-based order), position, radius,
/// group, displacement, platen force, confining force.
fn write_particles_csv(
    path: &Path,
    packing: &anisobond::packing::Packing,
    r: &SpecimenReport,
) -> Result<()> {
    anisobond::io::write_atomic(path, |w| {
        let io = |e| Error::io(path, e);
        writeln!(
            w,
            "id,x [m],y [m],z [m],radius [m],group,ux [m],uy [m],uz [m],fx [N],fy [N],fz [N],\
             px [N],py [N],pz [N]"
        )
        .map_err(io)?;
        // Rows formatted by chunks in parallel, written in order (the same bytes on any
        // thread count).
        use std::fmt::Write as _;
        let rows: Vec<usize> = (0..packing.len()).collect();
        let chunks = anisobond::io::format_in_chunks(&rows, |s, &p| {
            let (x, rad) = (packing.positions[p], packing.radii[p]);
            let (u, f, c) = (r.displacement_field[p], r.reaction[p], r.confining_force[p]);
            let group = ["", "held", "moved"][r.layer[p] as usize];
            let id = packing.ids.as_ref().map_or(p as u64, |ids| ids[p]);
            // Writing to a String cannot fail.
            let _ = writeln!(
                s,
                "{id},{:e},{:e},{:e},{rad:e},{group},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
                x.x, x.y, x.z, u.x, u.y, u.z, f.x, f.y, f.z, c.x, c.y, c.z
            );
        });
        for chunk in &chunks {
            w.write_all(chunk.as_bytes()).map_err(io)?;
        }
        Ok(())
    })
}

fn print_report(r: &SpecimenReport, dir: &Path) {
    println!(
        "specimen along {}: {} of {} particles loaded ({} bonds), {:?} platens, {:?} laterally; \
         {} held ({}), {} moved ({})",
        r.axis,
        r.loaded_particles,
        r.n_particles,
        r.loaded_bonds,
        r.platens,
        r.lateral,
        r.held_particles,
        r.held_group,
        r.moved_particles,
        r.moved_group
    );
    println!(
        "  gauge length {:.6e} m, cross-section {:.6e} m², shortening {:.6e} m ({} control)",
        r.length, r.area, r.displacement, r.control
    );
    println!(
        "  platen force {:.6e} N (held group {:.6e} N), platen stiffness {:.6e} N/m",
        r.axial_force, r.held_force, r.platen_stiffness
    );
    let v = |f: [f64; 3]| format!("({:.6e}, {:.6e}, {:.6e})", f[0], f[1], f[2]);
    println!(
        "  reactions (N, x y z): held {}, moved {}",
        v(r.held_reaction),
        v(r.moved_reaction)
    );
    if let Some(c) = &r.confining {
        println!(
            "  confining pressure {:.6e} Pa on {} surface particles ({:.6e} m², {} of {} cells \
             empty, self-equilibration {:.1e}); lateral strains {:.6e} / {:.6e}",
            c.pressure,
            c.particles,
            c.area,
            c.empty_cells,
            c.cells,
            c.correction,
            r.lateral_strain[0],
            r.lateral_strain[1]
        );
    }
    println!(
        "  apparent Young's modulus E = {:.4} GPa, Poisson's ratios {:.4} / {:.4} (mean {:.4})",
        r.young / 1e9,
        r.poisson_lateral[0],
        r.poisson_lateral[1],
        r.poisson
    );
    println!(
        "  solve: {}, {} unknowns, relative residual {:.2e}",
        r.solver, r.unknowns, r.relative_residual
    );
    println!(
        "wrote {}/specimen.json, particles.csv, particles.vtu, bonds.vtu",
        dir.display()
    );
}
