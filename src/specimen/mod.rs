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
//! (two-level preconditioner) for large or semi-definite specimens.
//!
//! Frictionless platens leave the two lateral translations and the rotation about the axis
//! free; one held particle's lateral translations, and the lateral translation of a second,
//! far held particle across their offset, are held to remove them. Only self-equilibrated lateral loads act, so these supports carry no force
//! (by equilibrium); the solve checks that they carry none to 1e-9 of the platen force.
//!
//! A periodic packing can be solved as a prism periodic across the axis ([`Lateral::Periodic`]):
//! bonds crossing the cell's faces normal to the axis are cut, those crossing the lateral
//! faces are kept, and the two lateral periodicity vectors get unknown changes (the lateral
//! strains, free for frictionless platens, zero for bonded ones): the packing's file format
//! cannot say "periodic in x and y, free in z", so the cell is read periodic and cut here.

mod select;
pub(crate) mod surface;

pub use select::{parse_ids, Selection};
pub use surface::Shape;

use crate::assembly::Assembly;
use crate::homogenize::cholesky::BlockCholesky;
use crate::homogenize::network::{element, prune_dangling, Block6, BondLaw, LeverArm};
use crate::homogenize::relaxed::{block_jacobi_cg, two_level_cg};
use crate::homogenize::sparse::BlockSparse;
use crate::{Error, Result, Vec3};
use serde::Serialize;

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
    particles of the middle third (periodic: the change of the cell's lateral period)";

/// How the specimen's equilibrium was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "method")]
pub enum SpecimenSolver {
    /// Sparse Cholesky (the held specimen is positive definite).
    Cholesky,
    /// Preconditioned CG (block-Jacobi, or two-level for large specimens): a field in
    /// equilibrium; zero-energy modes the load does not excite (counter-rotating "gear"
    /// spins) keep what CG leaves in them: they carry no force and change no reported number.
    Cg {
        /// Iterations to the tolerance.
        iterations: usize,
        /// Whether the two-level preconditioner was used.
        two_level: bool,
    },
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

/// Union–find root with path halving.
fn root(parent: &mut [u32], mut p: u32) -> u32 {
    while parent[p as usize] != p {
        parent[p as usize] = parent[parent[p as usize] as usize];
        p = parent[p as usize];
    }
    p
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
    opts.check()?;
    let packing = &assembly.packing;
    crate::packing::PeriodicCell::require_fully_periodic(packing.cell.as_ref(), "specimen")?;
    let bonds = &assembly.bonds;
    let k = &assembly.springs;
    let n = packing.len();
    let ax = opts.axis;
    let lateral = [(ax + 1) % 3, (ax + 2) % 3];
    // Bonds of the specimen: all of a free packing; a periodic one is cut at its faces
    // normal to the axis.
    let cell = match opts.lateral {
        Lateral::Free => {
            if let Some(b) = bonds.image.iter().position(|im| *im != [0, 0, 0]) {
                return Err(Error::Invalid(format!(
                    "specimen: bond {b} ({} – {}) crosses the periodic cell; a specimen is a \
                     finite packing (read it with --free, cut one from the cell, or solve it \
                     periodic across the axis)",
                    bonds.i[b], bonds.j[b]
                )));
            }
            None
        }
        Lateral::Periodic => Some(packing.cell.map(|c| c.lengths).ok_or_else(|| {
            Error::Invalid(
                "specimen: periodic across the axis needs a periodic packing (a cell)".into(),
            )
        })?),
    };
    let in_specimen: Vec<bool> = bonds.image.iter().map(|im| im[ax] == 0).collect();
    if bonds.is_empty() || !in_specimen.iter().any(|&b| b) {
        return Err(Error::Degenerate(
            "specimen: the packing has no bonds (check the model's bonding rule)".into(),
        ));
    }
    // Groups.
    let coord = |p: usize| packing.positions[p][ax];
    let held_sel = opts.held.clone().unwrap_or(Selection::EndLayer {
        top: false,
        depth: opts.end_layer,
    });
    let moved_sel = opts.moved.clone().unwrap_or(Selection::EndLayer {
        top: true,
        depth: opts.end_layer,
    });
    if opts.held.is_none() && opts.moved.is_none() {
        let lo = (0..n).map(coord).fold(f64::INFINITY, f64::min);
        let hi = (0..n).map(coord).fold(f64::NEG_INFINITY, f64::max);
        if hi - lo <= 2.0 * opts.end_layer {
            return Err(Error::Invalid(format!(
                "specimen: the end layers ({} m deep each) overlap: the specimen is {:.6e} m \
                 long along {}",
                opts.end_layer,
                hi - lo,
                axis_name(ax)
            )));
        }
    }
    let held_flag = held_sel.select(packing, ax)?;
    let moved_flag = moved_sel.select(packing, ax)?;
    let mut layer = vec![0u8; n];
    let mut both = 0usize;
    for p in 0..n {
        match (held_flag[p], moved_flag[p]) {
            (true, true) => both += 1,
            (true, false) => layer[p] = 1,
            (false, true) => layer[p] = 2,
            _ => {}
        }
    }
    if both > 0 {
        return Err(Error::Invalid(format!(
            "specimen: the held group ({}) and the moved group ({}) overlap: {both} particles \
             are in both",
            held_sel.describe(),
            moved_sel.describe()
        )));
    }
    for (which, name, sel) in [(1u8, "held", &held_sel), (2, "moved", &moved_sel)] {
        if !layer.contains(&which) {
            return Err(Error::Invalid(format!(
                "specimen: the {name} group ({}) holds no particle",
                sel.describe()
            )));
        }
    }
    // Connected components joined to both groups carry the load; the rest is left out.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for b in (0..bonds.len()).filter(|&b| in_specimen[b]) {
        let (a, c) = (root(&mut parent, bonds.i[b]), root(&mut parent, bonds.j[b]));
        if a != c {
            parent[a.max(c) as usize] = a.min(c);
        }
    }
    let roots: Vec<u32> = (0..n as u32).map(|p| root(&mut parent, p)).collect();
    let mut touches = vec![0u8; n];
    for p in 0..n {
        if layer[p] != 0 {
            touches[roots[p] as usize] |= layer[p];
        }
    }
    // Dangling chains (particles off the groups left with one bond, repeatedly) carry no
    // load and would swing freely: prune them, as the periodic network does.
    let in_loaded_component = |p: usize| touches[roots[p] as usize] == 3;
    let (active, degree) = prune_dangling(
        n,
        bonds,
        (0..bonds.len())
            .map(|b| in_specimen[b] && in_loaded_component(bonds.i[b] as usize))
            .collect(),
        |p| layer[p] != 0,
    );
    let loaded: Vec<bool> = (0..n)
        .map(|p| in_loaded_component(p) && degree[p] > 0)
        .collect();
    let mut index = vec![u32::MAX; n];
    let mut original: Vec<usize> = Vec::new();
    for p in 0..n {
        if loaded[p] {
            index[p] = original.len() as u32;
            original.push(p);
        }
    }
    if original.is_empty() {
        return Err(Error::Degenerate(format!(
            "specimen: no bonded path joins the held group ({}) and the moved group ({}) along \
             {}; the specimen falls apart under load",
            held_sel.describe(),
            moved_sel.describe(),
            axis_name(ax)
        )));
    }
    let m = original.len();
    // Elements of the loaded bonds; with lateral periodicity, node m holds the changes a₀, a₁
    // of the two lateral periods (DOFs 0–2 and 3–5): the image of j is displaced by
    // n₀a₀ + n₁a₁ for a bond to the image (n₀, n₁) across the lateral faces.
    let loaded_bonds: Vec<usize> = (0..bonds.len()).filter(|&b| active[b]).collect();
    let crosses = |b: usize| lateral.iter().any(|&d| bonds.image[b][d] != 0);
    let jump = cell.is_some() && loaded_bonds.iter().any(|&b| crosses(b));
    if cell.is_some() && !jump {
        // Laterally periodic by option but joined across no lateral face: its lateral strain
        // would be read as 0 from period changes that nothing resists.
        return Err(Error::Degenerate(
            "specimen: periodic across the axis (--lateral periodic) but no loaded bond \
             crosses a lateral face of the cell; the specimen is free laterally: use \
             --lateral free"
                .into(),
        ));
    }
    let nodes = m + usize::from(jump);
    let elements: Vec<_> = loaded_bonds
        .iter()
        .map(|&b| element(&BondLaw::of(packing, bonds, k, b, opts.lever_arm), true))
        .collect();
    let mut ends: Vec<(u32, u32)> = loaded_bonds
        .iter()
        .map(|&b| (index[bonds.i[b] as usize], index[bonds.j[b] as usize]))
        .collect();
    let mut blocks: Vec<(Block6, Block6, Block6)> =
        elements.iter().map(|el| (el.kii, el.kjj, el.kij)).collect();
    if jump {
        let a = m as u32;
        for (e, &b) in loaded_bonds.iter().enumerate() {
            if !crosses(b) {
                continue;
            }
            // T (3×6) = [n₀ I | n₁ I] maps the period changes to j's extra translation.
            let mut t = nalgebra::Matrix3x6::<f64>::zeros();
            for (c, &d) in lateral.iter().enumerate() {
                let nd = f64::from(bonds.image[b][d]);
                for r in 0..3 {
                    t[(r, 3 * c + r)] = nd;
                }
            }
            let el = &elements[e];
            let kj_t = el.kjj.fixed_view::<6, 3>(0, 0) * t;
            let ki_t = el.kij.fixed_view::<6, 3>(0, 0) * t;
            let kaa = t.transpose() * el.kjj.fixed_view::<3, 3>(0, 0) * t;
            ends.push((ends[e].0, a));
            blocks.push((Block6::zeros(), kaa, ki_t));
            ends.push((ends[e].1, a));
            blocks.push((Block6::zeros(), Block6::zeros(), kj_t));
        }
    }
    let kfull = BlockSparse::assemble_blocks(nodes, &ends, |e| blocks[e]);
    drop(blocks);
    let mean_radius_all = packing.radii.iter().sum::<f64>() / n as f64;
    // Gauge length and direction: the moved group is pushed towards the held one.
    let mean_of = |which: u8| {
        let (s, c) = original
            .iter()
            .filter(|&&p| layer[p] == which)
            .fold((0.0, 0usize), |(s, c), &p| (s + coord(p), c + 1));
        (s / c.max(1) as f64, c)
    };
    let ((held_mean, n_held), (moved_mean, n_moved)) = (mean_of(1), mean_of(2));
    let sign = if moved_mean >= held_mean { 1.0 } else { -1.0 };
    let length = (moved_mean - held_mean).abs();
    if n_held == 0 || n_moved == 0 || length.is_nan() || length <= 0.0 {
        return Err(Error::Degenerate(format!(
            "specimen: the loaded part holds {n_held} held and {n_moved} moved particles, \
             {length:e} m apart along {}: no gauge length",
            axis_name(ax)
        )));
    }
    // Load case 0: the moved group shortened by δ₀; case 1: the confining pressure with the
    // groups held in place.
    let delta0 = opts.load.trial_shortening(length);
    let mut prescribed: Vec<[Option<f64>; 6]> = vec![[None; 6]; nodes];
    for (a, &p) in original.iter().enumerate() {
        let value = if layer[p] == 2 { -sign * delta0 } else { 0.0 };
        match (layer[p], opts.platens) {
            (0, _) => {}
            (_, Platens::Frictionless) => prescribed[a][ax] = Some(value),
            (_, Platens::Bonded) => {
                prescribed[a] = [Some(0.0); 6];
                prescribed[a][ax] = Some(value);
            }
        }
    }
    if jump {
        match opts.platens {
            Platens::Frictionless => {
                prescribed[m][ax] = Some(0.0);
                prescribed[m][3 + ax] = Some(0.0);
            }
            Platens::Bonded => prescribed[m] = [Some(0.0); 6],
        }
    }
    let mut supports: Vec<(usize, usize)> = Vec::new();
    let length_scale = length.max(mean_radius_all);
    if opts.platens == Platens::Frictionless {
        // Per loaded component: one held particle's lateral translations, and the rotation
        // about the axis by the lateral translation of the held particle farthest from it
        // across that offset (a particle's own spin would not do: without bending springs a
        // counter-rotating "gear" pattern of spins lets the whole specimen turn at no cost).
        let mut first: Vec<(u32, usize)> = Vec::new();
        for (a, &p) in original.iter().enumerate() {
            if layer[p] == 1 && !first.iter().any(|(r, _)| *r == roots[p]) {
                first.push((roots[p], a));
            }
        }
        for &(rt, a0) in &first {
            let x0 = packing.positions[original[a0]];
            for d in [lateral[0], lateral[1]] {
                prescribed[a0][d] = Some(0.0);
                supports.push((a0, d));
            }
            // Farthest held particle of the component along either lateral axis.
            let far = (0..m)
                .filter(|&a| layer[original[a]] == 1 && roots[original[a]] == rt)
                .flat_map(|a| {
                    let x = packing.positions[original[a]];
                    [(a, 0usize), (a, 1)]
                        .map(|(a, k)| (a, k, (x[lateral[k]] - x0[lateral[k]]).abs()))
                })
                .max_by(|p, q| p.2.total_cmp(&q.2));
            match far {
                Some((a, k, off)) if off > 1e-9 * length_scale => {
                    let d = lateral[1 - k];
                    prescribed[a][d] = Some(0.0);
                    supports.push((a, d));
                }
                _ => {
                    prescribed[a0][3 + ax] = Some(0.0);
                    supports.push((a0, 3 + ax));
                }
            }
        }
    }
    // Confining loads on the loaded particles.
    let confining = match opts.confining_pressure {
        Some(p) => {
            let centres: Vec<Vec3> = original.iter().map(|&q| packing.positions[q]).collect();
            let radii: Vec<f64> = original.iter().map(|&q| packing.radii[q]).collect();
            Some(surface::lateral_loads(&centres, &radii, ax, opts.shape, p)?)
        }
        None => None,
    };
    let cases = if confining.is_some() { 2 } else { 1 };
    let external = |a: usize, d: usize, case: usize| -> f64 {
        match (&confining, case) {
            (Some(c), 1) if a < m && d < 3 => c.force[a][d],
            _ => 0.0,
        }
    };
    let value_block = |a: usize| {
        let mut v = Block6::zeros();
        for d in 0..6 {
            v[(d, 0)] = prescribed[a][d].unwrap_or(0.0);
        }
        v
    };
    // Symmetric elimination: prescribed rows and columns keep only their diagonal; the
    // right-hand side moves the prescribed values' coupling to the free rows.
    let mut rhs = vec![Block6::zeros(); nodes];
    for (a, r) in rhs.iter_mut().enumerate() {
        let mut acc = Block6::zeros();
        for (c, blk) in kfull.row(a) {
            acc -= blk * value_block(c);
        }
        let diag = kfull.diagonal(a);
        for d in 0..6 {
            for case in 0..cases {
                r[(d, case)] = match (prescribed[a][d], case) {
                    (Some(v), 0) => diag[(d, d)] * v,
                    (Some(_), _) => 0.0,
                    (None, 0) => acc[(d, 0)],
                    (None, _) => external(a, d, case),
                };
            }
        }
    }
    // Rotations in units of the mean radius (R̄·ω, m) so that translational (N/m) and
    // rotational (N·m/rad) stiffnesses are of one size: the null directions of each diagonal
    // block are then told from soft ones well above rounding (with ω in rad and spheres of
    // 1 mm the two differ by R̄² = 1e-6, and rounding of the translational part polluted the
    // rotational one). The period changes (node m) are lengths already.
    let mean_radius = packing.radii.iter().sum::<f64>() / n as f64;
    let dof_scale = |a: usize, d: usize| {
        if d < 3 || a >= m {
            1.0
        } else {
            1.0 / mean_radius
        }
    };
    let rows: Vec<Vec<(u32, Block6)>> = (0..nodes)
        .map(|a| {
            kfull
                .row(a)
                .map(|(c, blk)| {
                    let mut b = *blk;
                    for r in 0..6 {
                        for s in 0..6 {
                            let fixed = prescribed[a][r].is_some() || prescribed[c][s].is_some();
                            let v = if fixed && !(a == c && r == s) {
                                0.0
                            } else {
                                blk[(r, s)]
                            };
                            b[(r, s)] = v * dof_scale(a, r) * dof_scale(c, s);
                        }
                    }
                    (c as u32, b)
                })
                .collect()
        })
        .collect();
    for (a, r) in rhs.iter_mut().enumerate() {
        for d in 0..6 {
            for case in 0..cases {
                r[(d, case)] *= dof_scale(a, d);
            }
        }
    }
    let kmod = BlockSparse::from_rows(rows);
    let x = solve_system(&kmod, &rhs, opts.solver, packing, &original, nodes)?;
    let (x, unknowns, solver) = x;
    // Back to radians; prescribed DOFs take their values exactly.
    let mut u = x;
    for (a, ua) in u.iter_mut().enumerate() {
        for d in 0..6 {
            for case in 0..cases {
                ua[(d, case)] *= dof_scale(a, d);
            }
            if let Some(v) = prescribed[a][d] {
                ua[(d, 0)] = v;
                if cases > 1 {
                    ua[(d, 1)] = 0.0;
                }
            }
        }
    }
    if let Some(&(_, a0)) = supports.first() {
        // Frictionless platens leave the turn about the axis free (a zero-energy mode); the
        // supports only fix it somehow. Report the field without its least-squares rigid
        // turn about the axis through the first support (no force changes).
        let xa = packing.positions[original[a0]];
        let turn = |a: usize| -> Vec3 {
            let d = packing.positions[original[a]] - xa;
            let mut t = Vec3::zeros();
            t[lateral[0]] = -d[lateral[1]];
            t[lateral[1]] = d[lateral[0]];
            t
        };
        let den: f64 = (0..m).map(|a| turn(a).norm_squared()).sum();
        for case in 0..cases {
            let num: f64 = (0..m)
                .map(|a| {
                    let t = turn(a);
                    (0..3).map(|d| t[d] * u[a][(d, case)]).sum::<f64>()
                })
                .sum();
            let w = if den > 0.0 { num / den } else { 0.0 };
            for (a, ua) in u.iter_mut().enumerate().take(m) {
                let t = turn(a);
                for d in 0..3 {
                    ua[(d, case)] -= w * t[d];
                }
                ua[(3 + ax, case)] -= w;
            }
            if jump {
                if let Some(l) = cell {
                    // The image across lateral face k moves by w e_axis × (L_k e_k).
                    for (kk, &d) in lateral.iter().enumerate() {
                        let mut t = Vec3::zeros();
                        t[lateral[(kk + 1) % 2]] = if kk == 0 { l[d] } else { -l[d] };
                        for c in 0..3 {
                            u[m][(3 * kk + c, case)] -= w * t[c];
                        }
                    }
                }
            }
        }
    }
    let mut ku = vec![Block6::zeros(); nodes];
    kfull.apply(&u, &mut ku);
    // Residual at the free DOFs relative to the load (reactions and external forces).
    let mut relative_residual: f64 = 0.0;
    for case in 0..cases {
        let (mut rr, mut ff) = (0.0, 0.0);
        for a in 0..nodes {
            for d in 0..6 {
                let f = ku[a][(d, case)] - external(a, d, case);
                if prescribed[a][d].is_none() {
                    rr += f * f;
                    ff += external(a, d, case).powi(2);
                } else {
                    ff += f * f;
                }
            }
        }
        relative_residual = relative_residual.max((rr / ff).sqrt());
    }
    if relative_residual.is_nan() || relative_residual > RESIDUAL_LIMIT {
        return Err(Error::NotConverged(format!(
            "specimen: static solve residual {relative_residual:.3e} > {RESIDUAL_LIMIT:e}: the \
             bonded specimen is too ill-conditioned or has a mechanism"
        )));
    }
    // Reaction of the platens on group `which` in `case`: K u − f_ext summed.
    let reaction_of = |which: u8, case: usize| -> Vec3 {
        let mut r = Vec3::zeros();
        for (a, &p) in original.iter().enumerate() {
            if layer[p] == which {
                for d in 0..3 {
                    r[d] += ku[a][(d, case)] - external(a, d, case);
                }
            }
        }
        r
    };
    // K u is the force the platens exert; compression pushes the moved group towards the
    // held one (−sign along the axis).
    let force_a = -sign * reaction_of(2, 0)[ax];
    let force_b = if cases > 1 {
        -sign * reaction_of(2, 1)[ax]
    } else {
        0.0
    };
    if !(force_a.is_finite() && force_a > 0.0) {
        return Err(Error::Degenerate(format!(
            "specimen: platen force {force_a:.3e} N for a shortening {delta0:.3e} m: not a \
             positive finite response"
        )));
    }
    // The load factor of case 0: 1 under displacement control; under force control the
    // shortening that makes the moved group's axial force F.
    let (alpha, control) = match opts.load {
        Load::Force(f) => ((f - force_b) / force_a, "force"),
        Load::Strain(_) | Load::Displacement(_) => (1.0, "displacement"),
    };
    let delta = alpha * delta0;
    let combine =
        |blk: &Block6, d: usize| alpha * blk[(d, 0)] + if cases > 1 { blk[(d, 1)] } else { 0.0 };
    let reaction_total = |which: u8| -> Vec3 {
        let r0 = reaction_of(which, 0) * alpha;
        if cases > 1 {
            r0 + reaction_of(which, 1)
        } else {
            r0
        }
    };
    let held_reaction = reaction_total(1);
    let moved_reaction = reaction_total(2);
    let axial_force = -sign * moved_reaction[ax];
    let held_force = sign * held_reaction[ax];
    let confining_total: f64 = confining
        .as_ref()
        .map(|c| c.force.iter().map(|f| f.norm()).sum())
        .unwrap_or(0.0);
    for &(a, d) in &supports {
        let scale = if d >= 3 { length } else { 1.0 };
        let allowed = SUPPORT_LIMIT * axial_force.abs().max(force_a).max(confining_total);
        let worst = (0..cases)
            .map(|c| ((ku[a][(d, c)] - external(a, d, c)) / scale).abs())
            .fold(0.0, f64::max);
        if worst.is_nan() || worst > allowed {
            return Err(Error::Degenerate(format!(
                "specimen: the lateral support of a frictionless platen carries {worst:.3e} (N \
                 or N·m/m) against an axial force {axial_force:.3e} N; the specimen is not \
                 held by axial forces alone"
            )));
        }
    }
    // Cross-section.
    let centres: Vec<Vec3> = original.iter().map(|&q| packing.positions[q]).collect();
    let radii: Vec<f64> = original.iter().map(|&q| packing.radii[q]).collect();
    let area = match cell {
        Some(l) => l[lateral[0]] * l[lateral[1]],
        None => surface::Section::of(&centres, &radii, ax).area(opts.shape),
    };
    let strain0 = delta0 / length;
    let young = force_a / area / strain0;
    let platen_stiffness = force_a / delta0;
    // Lateral strains of a field (closure giving DOF d of node a): the period change, or the
    // least-squares slope over the middle third.
    let middle: Vec<usize> = (0..m)
        .filter(|&a| {
            let c = sign * (coord(original[a]) - held_mean);
            layer[original[a]] == 0 && c >= length / 3.0 && c <= 2.0 * length / 3.0
        })
        .collect();
    let lateral_strains = |field: &dyn Fn(usize, usize) -> f64| -> [f64; 2] {
        let mut out = [f64::NAN; 2];
        for (kk, &d) in lateral.iter().enumerate() {
            if let Some(l) = cell {
                out[kk] = if jump {
                    field(m, 3 * kk + d) / l[d]
                } else {
                    0.0
                };
                continue;
            }
            let rows: Vec<([f64; 4], f64)> = middle
                .iter()
                .map(|&a| {
                    let x = packing.positions[original[a]];
                    ([1.0, x[d], x[lateral[1 - kk]], x[ax]], field(a, d))
                })
                .collect();
            if let Some(c) = least_squares(&rows) {
                out[kk] = c[1];
            }
        }
        out
    };
    let eps0 = lateral_strains(&|a, d| u[a][(d, 0)]);
    let eps = lateral_strains(&|a, d| combine(&u[a], d));
    // ν = −ε_lat/ε_axial with the axial strain −δ/L (compression) and the lateral ones
    // signed (extension positive).
    let poisson_lateral = [eps0[0] / strain0, eps0[1] / strain0];
    if !poisson_lateral.iter().chain(&eps).all(|v| v.is_finite()) {
        return Err(Error::Degenerate(format!(
            "specimen: the middle third holds {} loaded particles, too few to measure the \
             lateral strain",
            middle.len()
        )));
    }
    let mut displacement_field = vec![Vec3::zeros(); n];
    let mut rotation_field = vec![Vec3::zeros(); n];
    let mut reaction = vec![Vec3::zeros(); n];
    let mut confining_force = vec![Vec3::zeros(); n];
    for (a, &p) in original.iter().enumerate() {
        displacement_field[p] = Vec3::new(combine(&u[a], 0), combine(&u[a], 1), combine(&u[a], 2));
        rotation_field[p] = Vec3::new(combine(&u[a], 3), combine(&u[a], 4), combine(&u[a], 5));
        if let Some(c) = &confining {
            confining_force[p] = c.force[a];
        }
        if layer[p] != 0 {
            let mut r = Vec3::zeros();
            for d in 0..3 {
                r[d] = alpha * ku[a][(d, 0)]
                    + if cases > 1 {
                        ku[a][(d, 1)] - external(a, d, 1)
                    } else {
                        0.0
                    };
            }
            reaction[p] = r;
        }
    }
    let period_change: Option<[Vec3; 2]> = (jump).then(|| {
        [
            Vec3::new(combine(&u[m], 0), combine(&u[m], 1), combine(&u[m], 2)),
            Vec3::new(combine(&u[m], 3), combine(&u[m], 4), combine(&u[m], 5)),
        ]
    });
    let mut bond_force = vec![Vec3::zeros(); bonds.len()];
    for &b in &loaded_bonds {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let nrm = bonds.normal[b];
        let (ri, rj) = opts
            .lever_arm
            .arms(packing.radii[i], packing.radii[j], bonds.length[b]);
        let mut uj = displacement_field[j];
        if let Some(pc) = &period_change {
            for (c, &d) in lateral.iter().enumerate() {
                uj += pc[c] * f64::from(bonds.image[b][d]);
            }
        }
        let delta = (uj + rotation_field[j].cross(&(-nrm * rj)))
            - (displacement_field[i] + rotation_field[i].cross(&(nrm * ri)));
        bond_force[b] = delta * k.ks[b] + nrm * ((k.kn[b] - k.ks[b]) * nrm.dot(&delta));
    }
    let report = SpecimenReport {
        axis: axis_name(ax),
        platens: opts.platens,
        lateral: opts.lateral,
        shape: opts.shape,
        control,
        n_particles: n,
        loaded_particles: m,
        unloaded_particles: n - m,
        loaded_bonds: loaded_bonds.len(),
        held_group: held_sel.describe(),
        moved_group: moved_sel.describe(),
        held_particles: n_held,
        moved_particles: n_moved,
        length,
        area,
        displacement: delta,
        strain: delta / length,
        axial_force,
        held_force,
        held_reaction: [held_reaction.x, held_reaction.y, held_reaction.z],
        moved_reaction: [moved_reaction.x, moved_reaction.y, moved_reaction.z],
        platen_stiffness,
        young,
        poisson_lateral,
        poisson: 0.5 * (poisson_lateral[0] + poisson_lateral[1]),
        lateral_strain: eps,
        confining: confining.as_ref().map(|c| ConfiningReport {
            pressure: opts.confining_pressure.unwrap_or(0.0),
            area: c.area,
            particles: c.particles,
            cells: c.cells,
            empty_cells: c.empty_cells,
            correction: c.correction,
            rule: CONFINING_RULE,
        }),
        how: HOW,
        relative_residual,
        unknowns,
        solver,
        displacement_field,
        rotation_field,
        reaction,
        confining_force,
        layer,
        bond_force,
        bond_loaded: active,
    };
    let finite = [
        report.young,
        report.poisson,
        report.platen_stiffness,
        report.axial_force,
        report.displacement,
    ];
    if !finite.iter().all(|v| v.is_finite()) || report.platen_stiffness <= 0.0 {
        return Err(Error::Degenerate(format!(
            "specimen: platen stiffness {:.3e} N/m, Young's modulus {:.3e} Pa: not a positive \
             finite response",
            report.platen_stiffness, report.young
        )));
    }
    Ok(report)
}

/// Solve the eliminated system `k x = b` by `choice` (see [`SolverChoice`]); returns x, the
/// unknowns and the method.
fn solve_system(
    k: &BlockSparse,
    b: &[Block6],
    choice: SolverChoice,
    packing: &crate::packing::Packing,
    original: &[usize],
    nodes: usize,
) -> Result<(Vec<Block6>, usize, SpecimenSolver)> {
    let m = original.len();
    let context = "specimen: the bonded specimen held by its platens has a mechanism that the \
                   load excites, or the solve did not converge";
    let large = m > DIRECT_LIMIT;
    let direct = match choice {
        SolverChoice::Cholesky => true,
        SolverChoice::Cg => false,
        SolverChoice::Auto => !large,
    };
    if direct {
        if let Ok(chol) = BlockCholesky::factor_definite(k) {
            return Ok((chol.solve(b)?, chol.unknowns(), SpecimenSolver::Cholesky));
        }
    }
    if !large && choice != SolverChoice::Cg {
        // Small and semi-definite: block-Jacobi CG to the tight tolerance.
        let (x, iterations, _) = block_jacobi_cg(k, b, CG_TOLERANCE, 2 * nodes + 1000)
            .map_err(|e| e.in_context(context))?;
        return Ok((
            x,
            6 * nodes,
            SpecimenSolver::Cg {
                iterations,
                two_level: false,
            },
        ));
    }
    // Two-level CG: aggregates on a grid over the loaded particles' bounding box (the
    // period-change node sits at its centre).
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for &p in original {
        lo = lo.inf(&packing.positions[p]);
        hi = hi.sup(&packing.positions[p]);
    }
    let extent = hi - lo;
    let pad = 1e-9 * extent.max().max(f64::MIN_POSITIVE);
    let lengths = extent.map(|e| e * (1.0 + 1e-9) + pad);
    let mut positions: Vec<Vec3> = original
        .iter()
        .map(|&p| packing.positions[p] - lo)
        .collect();
    positions.resize(nodes, extent * 0.5);
    let tolerance = if large {
        CG_TOLERANCE_LARGE
    } else {
        CG_TOLERANCE
    };
    let (x, iterations, _) = two_level_cg(k, b, &positions, lengths, tolerance, 20_000)
        .map_err(|e| e.in_context(context))?;
    Ok((
        x,
        6 * nodes,
        SpecimenSolver::Cg {
            iterations,
            two_level: true,
        },
    ))
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
