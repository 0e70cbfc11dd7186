//! The specimen solve: the exact static response of a finite bonded specimen loaded between
//! two platens, as a YADE, LIGGGHTS or LAMMPS load test measures it once it has come to rest.
//!
//! Two groups of particles are the platens' grip: the held group and the moved group, by
//! default the end layers (the particles whose centres lie within `end_layer` of the lowest
//! and of the highest centre along the loading axis), or any group chosen by region (box,
//! cylinder) or by the user's ids ([`Selection`]). The held group stays, the moved one is
//! moved by δ along the axis towards it (displacement control) or pushed by a force F (force
//! control: a rigid platen, δ is the answer). `Frictionless` platens prescribe only that axial
//! displacement of the groups' particles (every other degree of freedom free, as YADE's
//! `blockedDOFs = 'z'`); `Bonded` platens prescribe all six degrees of freedom. An optional
//! lateral confining pressure loads the outermost particles (`surface.rs`). The equilibrium
//! K u = f (Kruyt 2014 Eqs. 10–14, six DOFs per sphere) is solved for the free DOFs with the
//! prescribed DOFs eliminated symmetrically: faer's sparse Cholesky, or conjugate gradients
//! (two-level preconditioner) for large or semi-definite specimens, or on request CG with the
//! smoothed-aggregation multigrid V-cycle (`cg-amg`, issue 35).
//!
//! Frictionless platens leave the two lateral translations and the rotation about the axis
//! free; one held particle's lateral translations, and the lateral translation of a second,
//! far held particle across their offset, are held to remove them. Only self-equilibrated lateral loads act, so these supports carry no force
//! (by equilibrium); the solve checks that they carry none to 1e-9 of the platen force.
//!
//! A periodic packing can be solved as a prism periodic across the axis ([`Lateral::Periodic`]):
//! bonds crossing the cell's faces normal to the axis are cut, those crossing the lateral
//! faces are kept, and the two lateral periodicity vectors get unknown changes (the lateral
//! strains, free for frictionless platens, zero for bonded ones). A box of mixed periodicity
//! read as written (`p p f`: a slab, a settled bed) is the same problem with nothing to cut:
//! loaded along its one free axis ([`slab_axis`]), laterally periodic along the others.
//!
//! The solve runs in named steps: `network` (the specimen's bonds, the groups, the loaded
//! network and its stiffness, the gauge), `system` (the boundary conditions, the elimination
//! and the linear solve), `measure` (the residual, the platens' forces, the cross-section,
//! the lateral strains, the fields and the report).

mod measure;
mod network;
mod select;
pub(crate) mod surface;
mod system;

pub use select::{parse_ids, Cylinder, Selection};
pub use surface::Shape;

use crate::assembly::Assembly;
use crate::homogenize::network::LeverArm;
use crate::{Error, Result, Vec3};
use network::{Gauge, Groups, Network};
use serde::Serialize;
use system::Boundary;

/// How the platens hold the end layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Platens {
    /// Only the axial displacement of the layers' particles is prescribed.
    Frictionless,
    /// All six degrees of freedom of the layers' particles are prescribed (no slip, no spin).
    Bonded,
}

/// What lies across the loading axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Lateral {
    /// A free surface (a free packing).
    #[default]
    Free,
    /// The periodic cell's lateral faces (a periodic packing cut at its faces normal to the
    /// axis): an infinitely wide slab, or with frictionless platens a prism of free lateral
    /// strain.
    Periodic,
}

/// How the equilibrium is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SolverChoice {
    /// Sparse Cholesky up to [`DIRECT_LIMIT`] loaded particles, two-level CG above; CG where
    /// the Cholesky factorisation meets zero-energy modes.
    #[default]
    Auto,
    /// Sparse Cholesky (CG where it meets zero-energy modes).
    Cholesky,
    /// Conjugate gradients with the two-level preconditioner.
    Cg,
    /// Conjugate gradients with a smoothed-aggregation multigrid V-cycle (`cg-amg`, as the
    /// relaxed tensor's; `homogenize/amg.rs`), at any size.
    CgAmg,
}

/// Loaded particles above which [`SolverChoice::Auto`] uses CG: the Cholesky factor of a 3D
/// bond network grows faster than linearly (a periodic prism of 10,000 spheres: 13.5 s by
/// Cholesky, 1.5 s by two-level CG, `benches/regenerate.py --only specimen --quick`).
pub const DIRECT_LIMIT: usize = 2_000;

/// How the moved group is driven along the axis (compression positive); the response is
/// linear, so a strain or shortening sets only the scale of the field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    /// Axial engineering strain δ/L, in (0, 1).
    Strain(f64),
    /// Shortening δ (m) of the moved group towards the held one, finite and non-zero.
    Displacement(f64),
    /// Axial force (N) on the moved group, a rigid platen: δ is computed (force control).
    Force(f64),
}

impl Default for Load {
    /// A compressive strain of 1e-4.
    fn default() -> Load {
        Load::Strain(1e-4)
    }
}

impl Load {
    fn check(self) -> Result<()> {
        let bad = |what: &str, v: f64| Err(Error::Invalid(format!("specimen: {what}, got {v}")));
        match self {
            Load::Strain(s) if !(s.is_finite() && s > 0.0 && s < 1.0) => {
                bad("strain must be in (0, 1)", s)
            }
            Load::Displacement(d) if !(d.is_finite() && d != 0.0) => {
                bad("displacement must be a finite non-zero length (m)", d)
            }
            Load::Force(f) if !(f.is_finite() && f != 0.0) => {
                bad("force must be a finite non-zero force (N)", f)
            }
            _ => Ok(()),
        }
    }

    /// The shortening δ₀ (m) of the first load case over the gauge `length`: the one asked
    /// for, or under force control a strain of 1e-4, scaled afterwards to the force.
    fn trial_shortening(self, length: f64) -> f64 {
        match self {
            Load::Strain(s) => s * length,
            Load::Displacement(d) => d,
            Load::Force(_) => 1e-4 * length,
        }
    }
}

/// What the specimen solve is asked for.
#[derive(Clone, Debug)]
pub struct SpecimenOptions {
    /// Loading axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Depth of each end layer (m): centres within it of the lowest / highest centre (the
    /// default held and moved groups).
    pub end_layer: f64,
    /// How the platens hold the groups.
    pub platens: Platens,
    /// How the moved group is driven: a strain, a shortening or a force.
    pub load: Load,
    /// Where the bond's contact point sits (YADE's mid-gap by default).
    pub lever_arm: LeverArm,
    /// The held group (default: the lowest end layer).
    pub held: Option<Selection>,
    /// The moved group (default: the highest end layer).
    pub moved: Option<Selection>,
    /// Lateral confining pressure (Pa, compression positive) on the free lateral surface.
    pub confining_pressure: Option<f64>,
    /// Cross-section shape: the area of `young` and the confining surface.
    pub shape: Shape,
    /// Free or periodic across the axis.
    pub lateral: Lateral,
    /// Linear solver.
    pub solver: SolverChoice,
}

impl SpecimenOptions {
    /// The options for `axis` and `end_layer` (m), with frictionless platens, a compressive
    /// strain of 1e-4, the end layers as groups, no confining pressure, a free prism and
    /// YADE's mid-gap contact point.
    pub fn new(axis: usize, end_layer: f64) -> SpecimenOptions {
        SpecimenOptions {
            axis,
            end_layer,
            platens: Platens::Frictionless,
            load: Load::default(),
            lever_arm: LeverArm::MidGap,
            held: None,
            moved: None,
            confining_pressure: None,
            shape: Shape::Prism,
            lateral: Lateral::Free,
            solver: SolverChoice::Auto,
        }
    }

    /// The defaults of `anisobond specimen` (and Python's `Assembly.specimen`) for `packing`:
    /// along `axis` if given, else the free axis of a slab as read ([`slab_axis`]), else z;
    /// end layers `end_layer` deep if given, else one mean radius; laterally periodic for a
    /// box of mixed periodicity (the slab as read), else free; the rest as [`Self::new`].
    pub fn defaults_for(
        packing: &crate::packing::Packing,
        axis: Option<usize>,
        end_layer: Option<f64>,
    ) -> SpecimenOptions {
        let cell = packing.cell.as_ref();
        let axis = axis.unwrap_or_else(|| slab_axis(cell).unwrap_or(2));
        let mean_radius = packing.radii.iter().sum::<f64>() / packing.len().max(1) as f64;
        let mut opts = SpecimenOptions::new(axis, end_layer.unwrap_or(mean_radius));
        if cell.is_some_and(|c| c.is_mixed()) {
            opts.lateral = Lateral::Periodic;
        }
        opts
    }

    fn check(&self) -> Result<()> {
        if self.axis > 2 {
            return Err(Error::Invalid(format!(
                "specimen: axis {} is not x, y or z",
                self.axis
            )));
        }
        if !(self.end_layer.is_finite() && self.end_layer >= 0.0) {
            return Err(Error::Invalid(format!(
                "specimen: end layer depth must be a finite length >= 0 m, got {}",
                self.end_layer
            )));
        }
        self.load.check()?;
        if let Some(p) = self.confining_pressure {
            if !(p.is_finite() && p != 0.0) {
                return Err(Error::Invalid(format!(
                    "specimen: confining pressure must be finite and non-zero (Pa), got {p}"
                )));
            }
            if self.lateral == Lateral::Periodic {
                return Err(Error::Invalid(
                    "specimen: a confining pressure needs a free lateral surface; a prism \
                     periodic across the axis has none"
                        .into(),
                ));
            }
        }
        for g in [&self.held, &self.moved].into_iter().flatten() {
            g.check()?;
        }
        Ok(())
    }
}

/// The confining pressure as applied.
#[derive(Clone, Debug, Serialize)]
pub struct ConfiningReport {
    /// Pressure (Pa, compression positive).
    pub pressure: f64,
    /// Lateral surface area (m²).
    pub area: f64,
    /// Surface particles that carry a share.
    pub particles: usize,
    /// Grid cells of the surface (about one mean diameter on a side).
    pub cells: usize,
    /// Cells holding no centre, whose area went to the nearest occupied cell.
    pub empty_cells: usize,
    /// ‖correction‖/‖forces‖ of the self-equilibration (net force and axial moment removed).
    pub correction: f64,
    /// How the surface particles and their areas were chosen.
    pub rule: &'static str,
}

/// What the confining rule is, written into the report.
const CONFINING_RULE: &str = "the lateral surface (prism faces of the bounding box, or the \
    cylinder's mantle) cut into cells of about one mean diameter; in each cell the particle \
    reaching farthest out carries pressure × cell area along the inward normal through its \
    centre (an empty cell's area goes to the nearest occupied cell); the forces are then made \
    self-equilibrated by the least-squares removal of their net lateral force and axial moment";

/// The specimen solve's answer: what the load test measures, and the field.
#[derive(Clone, Debug, Serialize)]
pub struct SpecimenReport {
    /// Loading axis (`x`, `y` or `z`).
    pub axis: &'static str,
    /// How the platens held the groups.
    pub platens: Platens,
    /// Free or periodic across the axis.
    pub lateral: Lateral,
    /// Cross-section shape used for `area` (and the confining surface).
    pub shape: Shape,
    /// `displacement` or `force`: what was prescribed on the moved group.
    pub control: &'static str,
    /// Particles of the packing.
    pub n_particles: usize,
    /// Particles that take part (joined by bonds to both groups).
    pub loaded_particles: usize,
    /// Particles left out: not joined to both groups, so they carry no load.
    pub unloaded_particles: usize,
    /// Bonds that take part.
    pub loaded_bonds: usize,
    /// How the held group was chosen.
    pub held_group: String,
    /// How the moved group was chosen.
    pub moved_group: String,
    /// Loaded particles of the held group.
    pub held_particles: usize,
    /// Loaded particles of the moved group.
    pub moved_particles: usize,
    /// Distance between the groups' mean centres along the axis (m): the gauge length.
    pub length: f64,
    /// Cross-section (m²): a prism's lateral extent of the loaded spheres' surfaces (one
    /// lateral axis times the other), a cylinder's πR², or the periodic cell's face.
    pub area: f64,
    /// Shortening δ of the moved group towards the held one (m).
    pub displacement: f64,
    /// δ / length.
    pub strain: f64,
    /// Axial force on the moved group (N, compression positive), confinement included.
    pub axial_force: f64,
    /// Axial force on the held group (N, compression positive): equal to `axial_force` by
    /// equilibrium.
    pub held_force: f64,
    /// Total force the platen exerts on the held group's particles (N, x y z).
    pub held_reaction: [f64; 3],
    /// Total force the platen exerts on the moved group's particles (N, x y z).
    pub moved_reaction: [f64; 3],
    /// Platen stiffness dF/dδ (N/m): the axial force per unit shortening without confinement.
    pub platen_stiffness: f64,
    /// Apparent Young's modulus (F/A)/(δ/L) of the unconfined response (Pa).
    pub young: f64,
    /// Apparent Poisson's ratios −ε_lat/ε_axial of the unconfined response along the two
    /// lateral axes (in x, y, z order without the loading axis).
    pub poisson_lateral: [f64; 2],
    /// Their mean.
    pub poisson: f64,
    /// Lateral strains (extension positive) along the two lateral axes under the whole load
    /// (confinement included), measured as `poisson_lateral`.
    pub lateral_strain: [f64; 2],
    /// The confining pressure as applied, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confining: Option<ConfiningReport>,
    /// How `young` and `poisson` were computed, in words.
    pub how: &'static str,
    /// Relative residual ‖K u − f‖/‖f‖ of the solve at the free DOFs.
    pub relative_residual: f64,
    /// Unknowns after removing local mechanisms (Cholesky), or 6 per node (CG).
    pub unknowns: usize,
    /// How the equilibrium was solved.
    pub solver: SpecimenSolver,
    /// Displacement of every particle (m; zero for the unloaded ones).
    #[serde(skip)]
    pub displacement_field: Vec<Vec3>,
    /// Rotation of every particle (rad).
    #[serde(skip)]
    pub rotation_field: Vec<Vec3>,
    /// Force the platens exert on every particle (N; zero off the groups).
    #[serde(skip)]
    pub reaction: Vec<Vec3>,
    /// Confining force on every particle (N; zero off the surface).
    #[serde(skip)]
    pub confining_force: Vec<Vec3>,
    /// Group of every particle: 0 none, 1 held, 2 moved.
    #[serde(skip)]
    pub layer: Vec<u8>,
    /// Force on i from j of every bond of the packing (N; zero for unloaded bonds):
    /// f = SΔ with Δ = (u_j + ω_j × (−r_j n)) − (u_i + ω_i × (r_i n)).
    #[serde(skip)]
    pub bond_force: Vec<Vec3>,
    /// Whether each bond of the packing takes part (false: it hangs off the loaded network,
    /// belongs to a part not joined to both groups, or is cut at a periodic face).
    #[serde(skip)]
    pub bond_loaded: Vec<bool>,
}

/// What `young` and `poisson` mean, written into the report.
const HOW: &str = "young = (F / area) / (displacement / length) of the unconfined response, \
    F the axial force on the moved group, area = the cross-section (prism: lateral extent of \
    the loaded spheres' surfaces; cylinder: pi R^2 with R reaching the farthest sphere surface; \
    periodic: the cell's face), length = distance between the groups' mean centres; \
    poisson_lateral = -(lateral strain) / (displacement / length), the lateral strain being the \
    least-squares slope of the lateral displacement over the lateral coordinate on the \
    particles of the middle third whose bonds hold their centre (not the spheres that swing \
    about one or two contacts at no energy; periodic: the change of the cell's lateral \
    period)";

/// How the specimen's equilibrium was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "method")]
pub enum SpecimenSolver {
    /// Sparse Cholesky (the held specimen is positive definite).
    Cholesky,
    /// Preconditioned CG (block-Jacobi, or two-level for large specimens): a field in
    /// equilibrium; zero-energy modes the load does not excite (counter-rotating "gear"
    /// spins, a loosely held particle's swing) keep what CG leaves in them: they carry no
    /// force and change neither the forces nor E, but a free specimen's ν, a slope of the
    /// displacements, can take up their displacements (block-Jacobi vs multigrid CG: 2e-4 on
    /// 1,200 spheres, 1.7e-5 on 30,000; a known defect, docs/specimens.md).
    Cg {
        /// Iterations to the tolerance.
        iterations: usize,
        /// Whether the two-level preconditioner was used.
        two_level: bool,
    },
    /// CG preconditioned by one smoothed-aggregation multigrid V-cycle per iteration
    /// ([`SolverChoice::CgAmg`]); the same field to the CG tolerance.
    CgAmg {
        /// Iterations to the tolerance.
        iterations: usize,
        /// Levels of the hierarchy (the finest included).
        levels: usize,
    },
}

/// In words, as the CLI prints it ("two-level CG, 223 iterations").
impl std::fmt::Display for SpecimenSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            SpecimenSolver::Cholesky => write!(f, "sparse Cholesky"),
            SpecimenSolver::Cg {
                iterations,
                two_level,
            } => {
                let pre = if two_level {
                    "two-level"
                } else {
                    "block-Jacobi"
                };
                write!(f, "{pre} CG, {iterations} iterations")
            }
            SpecimenSolver::CgAmg { iterations, levels } => {
                write!(f, "multigrid CG ({levels} levels), {iterations} iterations")
            }
        }
    }
}

/// Relative residual the CG solve is taken to.
pub const CG_TOLERANCE: f64 = 1e-12;

/// Relative residual of the two-level CG of large specimens (round-off in K·u of a large
/// network stalls CG near 1e-12); the residual check of [`RESIDUAL_LIMIT`], relative to the
/// reactions, then reads about 3e-10.
pub const CG_TOLERANCE_LARGE: f64 = 1e-11;

/// Largest relative residual accepted from the direct solve.
pub const RESIDUAL_LIMIT: f64 = 1e-8;

/// Largest force the lateral supports of frictionless platens may carry, relative to the
/// platen force (they carry none by equilibrium).
pub const SUPPORT_LIMIT: f64 = 1e-9;

/// The lateral periods of the specimen (`None`: free across the axis), checked against the
/// packing's box. A fully periodic cell is cut at its faces normal to the axis; a box of mixed
/// periodicity is a slab as read only when both lateral axes are periodic (`p p f` loaded
/// along z): a strip, free along one lateral axis, or a load along a periodic axis is refused.
fn lateral_cell(assembly: &Assembly, opts: &SpecimenOptions) -> Result<Option<Vec3>> {
    let (packing, bonds) = (&assembly.packing, &assembly.bonds);
    let boundary = packing
        .cell
        .filter(|c| c.is_mixed())
        .map(|c| format!(" (boundary {})", c.boundary()));
    match opts.lateral {
        Lateral::Free => {
            if let Some(b) = bonds.image.iter().position(|im| *im != [0, 0, 0]) {
                return Err(Error::Invalid(format!(
                    "specimen: bond {b} ({} – {}) crosses a periodic face of the box{}; a free \
                     specimen has none (solve it periodic across the axis, read it with \
                     --free, or cut one from the cell)",
                    bonds.i[b],
                    bonds.j[b],
                    boundary.unwrap_or_default()
                )));
            }
            Ok(None)
        }
        Lateral::Periodic => {
            let cell = packing.cell.ok_or_else(|| {
                Error::Invalid(
                    "specimen: periodic across the axis needs a periodic packing (a cell)".into(),
                )
            })?;
            let ax = opts.axis;
            if cell.is_mixed()
                && (cell.periodic[ax]
                    || !cell.periodic[(ax + 1) % 3]
                    || !cell.periodic[(ax + 2) % 3])
            {
                return Err(Error::Invalid(format!(
                    "specimen: periodic across the axis {} of a box periodic along some axes \
                     only (boundary {}): a slab is loaded along its one non-periodic axis with \
                     both lateral axes periodic (p p f along z); a strip free along a lateral \
                     axis, or a load along a periodic axis of the box, is not solved",
                    axis_name(ax),
                    cell.boundary()
                )));
            }
            Ok(Some(cell.lengths))
        }
    }
}

/// The loading axis of a slab as read: the one non-periodic axis of a box of mixed
/// periodicity (`p p f`: z); `None` for a fully periodic cell, a free packing, or a box with
/// two non-periodic axes.
pub fn slab_axis(cell: Option<&crate::packing::PeriodicCell>) -> Option<usize> {
    let c = cell?;
    let free: Vec<usize> = (0..3).filter(|&d| !c.periodic[d]).collect();
    (free.len() == 1).then(|| free[0])
}

/// The exact static response of `assembly`'s bonded specimen (see the module doc).
///
/// A 3 × 3 × 7 simple-cubic column of touching 1 mm spheres with normal springs k_n between
/// bonded platens: the platen stiffness is n_x n_y k_n/(n_z − 1) = 1.5 k_n exactly.
/// ```
/// use anisobond::{assembly::Assembly, model::Model, packing::Packing, Vec3};
/// use anisobond::specimen::{solve, Platens, SpecimenOptions};
/// let r = 1e-3;
/// let mut centres = Vec::new();
/// for (i, j, k) in (0..3).flat_map(|i| (0..3).flat_map(move |j| (0..7).map(move |k| (i, j, k)))) {
///     centres.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * r);
/// }
/// let n = centres.len();
/// let packing = Packing::new(centres, vec![r; n], None)?;
/// let model = Model::from_toml_str(
///     "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
///      normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n",
///     "springs.toml",
/// )?;
/// let column = Assembly::new(packing, model)?;
/// let mut opts = SpecimenOptions::new(2, 0.5 * r); // axis z, end layers half a radius deep
/// opts.platens = Platens::Bonded;
/// let report = solve(&column, &opts)?;
/// assert!((report.platen_stiffness / (1.5 * 2e6) - 1.0).abs() < 1e-10);
/// # Ok::<(), anisobond::Error>(())
/// ```
pub fn solve(assembly: &Assembly, opts: &SpecimenOptions) -> Result<SpecimenReport> {
    assembly.refuse_manybody("the specimen solve")?;
    opts.check()?;
    let packing = &assembly.packing;
    let cell = lateral_cell(assembly, opts)?;
    let in_specimen = network::specimen_bonds(assembly, opts.axis)?;
    let groups = Groups::select(packing, opts)?;
    let net = Network::of(assembly, opts.axis, &groups, &in_specimen, cell)?;
    let kfull = net.stiffness(assembly, opts);
    let mean_radius = packing.radii.iter().sum::<f64>() / packing.len() as f64;
    let gauge = Gauge::of(packing, opts.axis, &groups.layer, &net)?;
    let bc = Boundary::of(packing, opts, &groups, &net, &gauge, mean_radius)?;
    let field = system::solve_field(kfull, &bc, &net, packing, opts, mean_radius)?;
    let solved = measure::Solved {
        assembly,
        opts,
        groups,
        net,
        gauge,
        bc,
        field,
    };
    solved.measure()
}

/// `x`, `y` or `z`.
fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"][axis.min(2)]
}

/// Least-squares coefficients of `y ≈ Σ c_k x_k` (normal equations, 4 unknowns); `None` when
/// the fit is singular or has fewer than 8 rows (twice the unknowns).
fn least_squares(rows: &[([f64; 4], f64)]) -> Option<[f64; 4]> {
    if rows.len() < 8 {
        return None;
    }
    // Centre the columns (except the constant) for conditioning.
    let mean: [f64; 4] =
        std::array::from_fn(|k| rows.iter().map(|(x, _)| x[k]).sum::<f64>() / rows.len() as f64);
    let mut ata = nalgebra::Matrix4::<f64>::zeros();
    let mut aty = nalgebra::Vector4::<f64>::zeros();
    for (x, y) in rows {
        let v = nalgebra::Vector4::from_fn(|k, _| if k == 0 { 1.0 } else { x[k] - mean[k] });
        ata += v * v.transpose();
        aty += v * *y;
    }
    let c = ata.cholesky()?.solve(&aty);
    Some([c[0], c[1], c[2], c[3]])
}
