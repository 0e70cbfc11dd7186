//! The linearised bond network shared by the static methods (relaxed, local adjustment
//! field): per-bond element matrices in the generalised displacements of the particles
//! (Kruyt 2014 Eqs. 10–14), after removing the particles that carry no load.
//!
//! For a bond from i to the image of j with unit normal n and contact arms r_i, r_j:
//! Δ = u_j − u_i + (r_i n)×ω_i + (r_j n)×ω_j + ε·l = B_i q_i + B_j q_j + L e,
//! f = SΔ with S = k_t I + (k_n − k_t) nn, and the relative rotation θ = ω_j − ω_i loads
//! k_r (part ⟂ n) and k_tw (part ∥ n). The energy ½[q; e]ᵀ[[K, G], [Gᵀ, H]][q; e] defines
//! the stiffness K (6N×6N), the load G (6N×6) and the affine stiffness H (6×6).

use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::{Error, Mat3, Result, Vec3};
use nalgebra::{Matrix3x6, Matrix6};
use rayon::prelude::*;

/// A 6×6 block (DOFs × DOFs, or DOFs × load cases).
pub type Block6 = Matrix6<f64>;

/// A block of `C` load cases: each particle's six DOFs × `C` right-hand sides, column-major
/// ([`Block6`] is `C` = 6). The relaxed tensor solves six load cases, a specimen one or two
/// (issue 35): the CG and its preconditioner run on as many columns as are live.
pub(crate) type Cols<const C: usize> = nalgebra::SMatrix<f64, 6, C>;

/// Where the contact point (lever arm) of a bond sits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LeverArm {
    /// Mid-gap, as YADE's ScGeom: r_i = R_i + gap/2, gap = |l| − R_i − R_j.
    #[default]
    MidGap,
    /// Proportional to the radii: r_i = |l|·R_i/(R_i + R_j).
    Proportional,
    /// Half the centre distance each, r_i = r_j = |l|/2: LAMMPS' `bpm/rotational`, whose
    /// shear displacement and torques act at the bond's midpoint.
    HalfLength,
}

impl LeverArm {
    /// Contact arms (r_i, r_j) of a bond of centre distance `l` between radii `ri`, `rj`.
    pub fn arms(self, ri: f64, rj: f64, l: f64) -> (f64, f64) {
        match self {
            LeverArm::MidGap => {
                let gap = l - ri - rj;
                (ri + 0.5 * gap, rj + 0.5 * gap)
            }
            LeverArm::Proportional => (l * ri / (ri + rj), l * rj / (ri + rj)),
            LeverArm::HalfLength => (0.5 * l, 0.5 * l),
        }
    }
}

/// What makes the stiffness matrix singular, as found and handled.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct NullSpaceReport {
    /// Particles removed because they had fewer than two bonds (after repeated pruning):
    /// they carry no load.
    pub removed_particles: usize,
    /// Bonds removed with them.
    pub removed_bonds: usize,
    /// Remaining particles with exactly two bonds: each has a free rotation about the line
    /// through its two contact points.
    pub two_bond_particles: usize,
    /// Rigid translations of the whole periodic assembly (3 when any bond remains).
    pub rigid_translations: usize,
    /// Remaining particles whose own 6×6 stiffness block is singular beyond the two-bond
    /// rotation (local mechanisms, e.g. collinear bonds without rotational springs).
    pub other_singular_particles: usize,
}

/// Element matrices of one bond: K blocks B_iᵀSB_i, B_jᵀSB_j, B_iᵀSB_j (plus rotational
/// springs), load rows B_iᵀSL, B_jᵀSL, and H = LᵀSL.
#[derive(Clone, Debug)]
pub struct Element {
    /// K_ii contribution.
    pub kii: Block6,
    /// K_jj contribution.
    pub kjj: Block6,
    /// K_ij contribution (K_ji is its transpose).
    pub kij: Block6,
    /// G row block of particle i.
    pub gi: Block6,
    /// G row block of particle j.
    pub gj: Block6,
    /// Affine stiffness LᵀSL.
    pub h: Block6,
}

/// One bond end's off-diagonal block of K, K_ro = B_rᵀ S B_o − R (+ the preload's
/// geometric stiffness), by its nine free numbers (N = [n]×, a and b the arms of r and o):
/// K_ro = [[−`shear` I − `axial` nn, −`other_arm_shear` N],
/// [−`own_arm_shear` N, `turn` I − `turn_axial` nn]] (derivation: bond_springs.rs).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub(crate) struct HalfBond {
    /// Unit normal from r to o.
    pub normal: [f64; 3],
    /// k_s + N_ax/l (N/m).
    pub shear: f64,
    /// k_n − k_s − N_ax/l (N/m).
    pub axial: f64,
    /// a k_s (N).
    pub own_arm_shear: f64,
    /// b k_s (N).
    pub other_arm_shear: f64,
    /// ab k_s − k_r (N·m/rad).
    pub turn: f64,
    /// ab k_s + k_tw − k_r (N·m/rad).
    pub turn_axial: f64,
}

impl HalfBond {
    /// K_ro of this bond end as a block.
    pub(crate) fn block(&self) -> Block6 {
        let n = Vec3::from(self.normal);
        let (nn, cross) = (n * n.transpose(), skew(&n));
        let mut b = Block6::zeros();
        b.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-(Mat3::identity() * self.shear + nn * self.axial)));
        b.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-cross * self.other_arm_shear));
        b.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(-cross * self.own_arm_shear));
        b.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Mat3::identity() * self.turn - nn * self.turn_axial));
        b
    }
}

/// Skew matrix [a]× with [a]× v = a × v.
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// L: the affine relative displacement ε·l as a linear map of the Voigt engineering strain.
pub fn affine_map(l: &Vec3) -> Matrix3x6<f64> {
    let mut m = Matrix3x6::zeros();
    for (a, &(i, j)) in crate::tensor::VOIGT_PAIRS.iter().enumerate() {
        if i == j {
            m[(i, a)] = l[i];
        } else {
            // ε_ij = ε_ji = e_a/2.
            m[(i, a)] += 0.5 * l[j];
            m[(j, a)] += 0.5 * l[i];
        }
    }
    m
}

/// The springs and geometry of one bond, as the element needs them.
#[derive(Clone, Copy, Debug)]
pub struct BondLaw {
    /// Unit normal from i to j.
    pub normal: Vec3,
    /// Centre distance (m).
    pub length: f64,
    /// Contact arms r_i, r_j (m).
    pub arms: (f64, f64),
    /// Normal, shear (N/m), bending, twisting (N·m/rad) springs.
    pub kn: f64,
    /// Shear spring.
    pub ks: f64,
    /// Bending spring.
    pub kr: f64,
    /// Twisting spring.
    pub ktw: f64,
}

impl BondLaw {
    /// Bond `b` of a bonded packing: its normal, length, contact arms by `lever_arm` and
    /// springs.
    pub fn of(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        b: usize,
        lever_arm: LeverArm,
    ) -> BondLaw {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        BondLaw {
            normal: bonds.normal[b],
            length: bonds.length[b],
            arms: lever_arm.arms(packing.radii[i], packing.radii[j], bonds.length[b]),
            kn: k.kn[b],
            ks: k.ks[b],
            kr: k.kr[b],
            ktw: k.ktw[b],
        }
    }
}

/// Element matrices of a bond; `rotations = false` locks the particle rotations.
pub fn element(law: &BondLaw, rotations: bool) -> Element {
    let (s, bi, bj) = bond_maps(law, rotations);
    let blocks = stiffness_of(law, rotations, &s, &bi, &bj);
    with_load_terms(blocks, &s, &bi, &bj, &(law.normal * law.length))
}

/// The element of the stiffness `blocks` (K_ii, K_jj, K_ij) with its load terms: the
/// affine map of the branch vector `branch` through S, G_i = B_iᵀ S L, G_j = B_jᵀ S L,
/// H = Lᵀ S L.
fn with_load_terms(
    (kii, kjj, kij): (Block6, Block6, Block6),
    s: &Mat3,
    bi: &Matrix3x6<f64>,
    bj: &Matrix3x6<f64>,
    branch: &Vec3,
) -> Element {
    let LoadTerms { gi, gj, h } = load_terms_of(s, bi, bj, branch);
    Element {
        kii,
        kjj,
        kij,
        gi,
        gj,
        h,
    }
}

/// The load terms of an element: G_i = B_iᵀ S L, G_j = B_jᵀ S L and H = Lᵀ S L.
pub(crate) struct LoadTerms {
    /// G row block of particle i.
    pub gi: Block6,
    /// G row block of particle j.
    pub gj: Block6,
    /// Affine stiffness LᵀSL.
    pub h: Block6,
}

/// The load terms of [`with_load_terms`]: the affine map of the branch vector `branch`
/// through S between the ends' maps.
fn load_terms_of(s: &Mat3, bi: &Matrix3x6<f64>, bj: &Matrix3x6<f64>, branch: &Vec3) -> LoadTerms {
    let lmap = affine_map(branch);
    let sl = s * lmap;
    LoadTerms {
        gi: bi.transpose() * sl,
        gj: bj.transpose() * sl,
        h: lmap.transpose() * sl,
    }
}

/// The stiffness blocks (K_ii, K_jj, K_ij) of [`element`] alone, the same bits, without its
/// load terms G and H: all that K's assembly needs (half the element's arithmetic).
pub(crate) fn element_stiffness(law: &BondLaw, rotations: bool) -> (Block6, Block6, Block6) {
    let (s, bi, bj) = bond_maps(law, rotations);
    stiffness_of(law, rotations, &s, &bi, &bj)
}

/// The bond's translational spring matrix S = k_s I + (k_n − k_s) n⊗n and the maps B_i, B_j
/// of each end's (u, θ) to the relative displacement at the contact.
fn bond_maps(law: &BondLaw, rotations: bool) -> (Mat3, Matrix3x6<f64>, Matrix3x6<f64>) {
    let n = law.normal;
    let nn = n * n.transpose();
    let s = Mat3::identity() * law.ks + nn * (law.kn - law.ks);
    let mut bi = Matrix3x6::zeros();
    let mut bj = Matrix3x6::zeros();
    bi.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-Mat3::identity()));
    bj.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
    if rotations {
        bi.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&skew(&(n * law.arms.0)));
        bj.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&skew(&(n * law.arms.1)));
    }
    (s, bi, bj)
}

/// Bᵢᵀ S Bⱼ for the three pairs of ends, plus the bending and twisting springs.
fn stiffness_of(
    law: &BondLaw,
    rotations: bool,
    s: &Mat3,
    bi: &Matrix3x6<f64>,
    bj: &Matrix3x6<f64>,
) -> (Block6, Block6, Block6) {
    let (mut kii, mut kjj, mut kij) = spring_blocks(s, bi, bj);
    if let Some(rm) = rotation_springs(law, rotations) {
        for (blk, sign) in [(&mut kii, 1.0), (&mut kjj, 1.0), (&mut kij, -1.0)] {
            let mut v = blk.fixed_view_mut::<3, 3>(3, 3);
            v += rm * sign;
        }
    }
    (kii, kjj, kij)
}

/// The bending and twisting springs on the relative rotation, k_r (I − nn) + k_tw nn, when
/// the particles rotate and the bond has either.
fn rotation_springs(law: &BondLaw, rotations: bool) -> Option<Mat3> {
    (rotations && (law.kr != 0.0 || law.ktw != 0.0)).then(|| {
        let nn = law.normal * law.normal.transpose();
        (Mat3::identity() - nn) * law.kr + nn * law.ktw
    })
}

/// G = (N/|l|)(I − n⊗n): the geometric stiffness (N/m) of one bond on the relative
/// translation u_j − u_i, for the bond force `force` (its axial part N = force·n counts; N > 0
/// is tension) and unit normal `normal` at centre distance `length` (m).
pub fn bond_geometric_stiffness(force: &Vec3, normal: &Vec3, length: f64) -> Mat3 {
    let axial = force.dot(normal);
    (Mat3::identity() - normal * normal.transpose()) * (axial / length)
}

/// The initial-stress (geometric) element of a bond carrying the axial force N (tension
/// positive, N): the second-order energy ½(N/l)|Δ_⊥|² of a preloaded central bond whose
/// centre-line relative displacement Δ = u_j − u_i + ε·l turns it (Δ_⊥ = (I − nn)Δ), so
/// S_g = (N/l)(I − nn) with no rotation coupling (the force acts along the centre line).
/// Geometric terms of preloaded shear forces and moments are not included.
pub fn geometric_element(normal: &Vec3, length: f64, axial_force: f64) -> Element {
    let (s, bi, bj) = geometric_maps(normal, length, axial_force);
    with_load_terms(
        spring_blocks(&s, &bi, &bj),
        &s,
        &bi,
        &bj,
        &(normal * length),
    )
}

/// The stiffness blocks of [`geometric_element`] alone (the same bits).
fn geometric_stiffness(normal: &Vec3, length: f64, axial_force: f64) -> (Block6, Block6, Block6) {
    let (s, bi, bj) = geometric_maps(normal, length, axial_force);
    spring_blocks(&s, &bi, &bj)
}

/// S_g and the translation-only maps B_i = −B_j of [`geometric_element`].
fn geometric_maps(
    normal: &Vec3,
    length: f64,
    axial_force: f64,
) -> (Mat3, Matrix3x6<f64>, Matrix3x6<f64>) {
    let s = bond_geometric_stiffness(&(normal * axial_force), normal, length);
    let mut bj = Matrix3x6::zeros();
    bj.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
    (s, -bj, bj)
}

/// Bᵢᵀ S Bᵢ, Bⱼᵀ S Bⱼ and Bᵢᵀ S Bⱼ: the blocks of a translational spring matrix S between
/// the ends' maps (the bond's springs, or a preload's geometric stiffness).
fn spring_blocks(s: &Mat3, bi: &Matrix3x6<f64>, bj: &Matrix3x6<f64>) -> (Block6, Block6, Block6) {
    let sbi = s * bi;
    let sbj = s * bj;
    (
        bi.transpose() * sbi,
        bj.transpose() * sbj,
        bi.transpose() * sbj,
    )
}

impl std::ops::AddAssign for Element {
    fn add_assign(&mut self, o: Element) {
        self.kii += o.kii;
        self.kjj += o.kjj;
        self.kij += o.kij;
        self.gi += o.gi;
        self.gj += o.gj;
        self.h += o.h;
    }
}

/// Refuse a packing without a periodic cell: the static tensor methods load the cell.
pub fn require_cell(packing: &Packing) -> Result<()> {
    if packing.cell.is_none() {
        return Err(Error::Invalid(
            "static stiffness methods need a periodic packing (a `# periodic Lx Ly Lz` header)"
                .into(),
        ));
    }
    Ok(())
}

/// Remove particles with fewer than two bonds, repeatedly. Returns the active flag of every
/// bond and the number of active bonds of every particle.
fn prune(n_particles: usize, bonds: &BondSet) -> (Vec<bool>, Vec<u32>) {
    prune_dangling(n_particles, bonds, vec![true; bonds.len()], |_| false)
}

/// [`prune`] starting from the bonds flagged in `active`, never removing a particle for
/// which `held(p)` is true (a specimen's platen layers: a held particle with one bond
/// carries load). Returns the active flags and every particle's number of active bonds.
pub(crate) fn prune_dangling(
    n_particles: usize,
    bonds: &BondSet,
    mut active: Vec<bool>,
    held: impl Fn(usize) -> bool,
) -> (Vec<bool>, Vec<u32>) {
    let mut degree = vec![0u32; n_particles];
    for b in (0..bonds.len()).filter(|&b| active[b]) {
        degree[bonds.i[b] as usize] += 1;
        degree[bonds.j[b] as usize] += 1;
    }
    // Adjacency: bonds of each particle.
    let ends = bonds.i.iter().zip(&bonds.j);
    let (start, adj) = csr(
        n_particles,
        ends.map(|(&i, &j)| (i as usize, j as usize)),
        |b, _| b,
    );
    let mut stack: Vec<usize> = (0..n_particles)
        .filter(|&p| degree[p] == 1 && !held(p))
        .collect();
    while let Some(p) = stack.pop() {
        if degree[p] != 1 {
            continue;
        }
        for &b in &adj[start[p]..start[p + 1]] {
            if active[b] {
                active[b] = false;
                let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
                degree[i] -= 1;
                degree[j] -= 1;
                let other = if i == p { j } else { i };
                if degree[other] == 1 && !held(other) {
                    stack.push(other);
                }
            }
        }
    }
    (active, degree)
}

/// The active (load-carrying) network of a periodic bonded packing with its element
/// matrices.
pub struct Network {
    /// Number of active particles.
    pub n_active: usize,
    /// Active index of every original particle (`u32::MAX` if removed).
    pub index: Vec<u32>,
    /// Original index of every active particle.
    pub original: Vec<u32>,
    /// Active end indices of every active bond.
    pub ends: Vec<(u32, u32)>,
    /// Original bond index of every active bond.
    pub bond: Vec<usize>,
    /// Springs and geometry of every active bond: its element matrices are recomputed on
    /// demand ([`Network::element`]) rather than stored (1.7 kB a bond, most of the memory
    /// at a million particles; issue 35).
    laws: Vec<BondLaw>,
    /// Axial preload N of every active bond (N; tension positive), when the network is
    /// linearised about a loaded state.
    axial: Option<Vec<f64>>,
    /// Whether the particle rotations are unknowns.
    rotations: bool,
    /// Number of active bonds of every active particle.
    pub degree: Vec<u32>,
    /// Load G per active particle (6 DOFs × 6 strains).
    pub g: Vec<Block6>,
    /// Affine stiffness H = Σ LᵀSL (N·m, i.e. Pa·m³).
    pub h: Block6,
    /// Cell volume (m³).
    pub volume: f64,
    /// Singular modes found so far.
    pub null_space: NullSpaceReport,
    /// Σ over the active bonds of ‖G_i‖² + ‖G_j‖² per load case (column): the scale of each
    /// load before the bond contributions cancel at the particles.
    pub load_norms2: [f64; 6],
}

/// Every particle's index among the active ones (those with at least `min_degree` bonds
/// after pruning; `u32::MAX` for the others) and the original index of every active particle.
fn active_numbering(degree: &[u32], min_degree: u32) -> (Vec<u32>, Vec<u32>) {
    let mut index = vec![u32::MAX; degree.len()];
    let mut original = Vec::new();
    for (p, &d) in degree.iter().enumerate() {
        if d >= min_degree {
            index[p] = original.len() as u32;
            original.push(p as u32);
        }
    }
    (index, original)
}

/// Bonds whose elements are formed at once when summing over all of them: bounded memory,
/// the sums still in bond order.
const ELEMENT_CHUNK: usize = 8192;

/// The affine stiffness H = Σ LᵀSL, the load G of the `m` active particles and Σ ‖G_i‖² +
/// ‖G_j‖² per load case, summed over the elements in bond order (Kruyt 2014 Eqs. 10–14); the
/// elements are formed a chunk at a time in parallel.
fn affine_sums(net: &Network, m: usize) -> (Block6, Vec<Block6>, [f64; 6]) {
    let mut h = Block6::zeros();
    let mut g = vec![Block6::zeros(); m];
    let mut norms2 = [0.0f64; 6];
    for start in (0..net.ends.len()).step_by(ELEMENT_CHUNK) {
        let end = (start + ELEMENT_CHUNK).min(net.ends.len());
        // Each bond's load terms and its share of the norms, in parallel; then the sums.
        let terms: Vec<(LoadTerms, [f64; 6])> = (start..end)
            .into_par_iter()
            .map(|e| {
                let t = net.load_terms(e);
                let norms = std::array::from_fn(|c| {
                    t.gi.column(c).norm_squared() + t.gj.column(c).norm_squared()
                });
                (t, norms)
            })
            .collect();
        for ((t, norms), &(pi, pj)) in terms.iter().zip(&net.ends[start..end]) {
            h += t.h;
            g[pi as usize] += t.gi;
            g[pj as usize] += t.gj;
            for (n2, v) in norms2.iter_mut().zip(norms) {
                *n2 += v;
            }
        }
    }
    (h, g, norms2)
}

impl Network {
    /// Prune the packing's bonds to the load-carrying network and build the elements; with
    /// every bond's axial preload N (N, tension positive; one per bond) each element gains its
    /// `geometric_element` (the network linearised about a loaded state). A free assembly
    /// (e.g. a bar cut by [`crate::packing::cut()`]) is accepted: its boundary conditions are
    /// the caller's and `volume` is then the spheres' bounding box; the periodic methods
    /// check the cell first (`require_cell`).
    pub fn build(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        lever_arm: LeverArm,
        rotations: bool,
        axial_force: Option<&[f64]>,
    ) -> Result<Network> {
        Network::build_with(packing, bonds, k, lever_arm, rotations, axial_force, false)
    }

    /// [`Network::build`], with `keep_dangling` keeping every particle with at least one bond
    /// (dangling ones too): a many-body term couples a dangling particle to its neighbour's
    /// fitted strain, so it is no longer free of load (docs/manybody.md, "Relaxed solve").
    pub(crate) fn build_with(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        lever_arm: LeverArm,
        rotations: bool,
        axial_force: Option<&[f64]>,
        keep_dangling: bool,
    ) -> Result<Network> {
        // One entry per bond in every per-bond input.
        let per_bond = |len: usize, what: &str| {
            if len == bonds.len() {
                return Ok(());
            }
            Err(Error::Invalid(format!(
                "{} bonds but {len} {what}",
                bonds.len()
            )))
        };
        per_bond(k.len(), "stiffness entries")?;
        if let Some(f) = axial_force {
            per_bond(f.len(), "axial preloads")?;
        }
        let n = packing.len();
        let (bond_active, degree_all) = if keep_dangling {
            prune_dangling(n, bonds, vec![true; bonds.len()], |_| true)
        } else {
            prune(n, bonds)
        };
        let (index, original) = active_numbering(&degree_all, if keep_dangling { 1 } else { 2 });
        let m = original.len();
        let bond: Vec<usize> = (0..bonds.len()).filter(|&b| bond_active[b]).collect();
        let ends: Vec<(u32, u32)> = bond
            .iter()
            .map(|&b| (index[bonds.i[b] as usize], index[bonds.j[b] as usize]))
            .collect();
        let laws: Vec<BondLaw> = bond
            .par_iter()
            .map(|&b| BondLaw::of(packing, bonds, k, b, lever_arm))
            .collect();
        let axial = axial_force.map(|f| bond.iter().map(|&b| f[b]).collect());
        let degree: Vec<u32> = original.iter().map(|&p| degree_all[p as usize]).collect();
        let null_space = NullSpaceReport {
            removed_particles: n - m,
            removed_bonds: bonds.len() - bond.len(),
            two_bond_particles: degree.iter().filter(|&&d| d == 2).count(),
            rigid_translations: if bond.is_empty() { 0 } else { 3 },
            other_singular_particles: 0,
        };
        let mut net = Network {
            n_active: m,
            index,
            original,
            ends,
            bond,
            laws,
            axial,
            rotations,
            degree,
            g: Vec::new(),
            h: Block6::zeros(),
            volume: packing.volume(),
            null_space,
            load_norms2: [0.0; 6],
        };
        (net.h, net.g, net.load_norms2) = affine_sums(&net, m);
        Ok(net)
    }

    /// The axial preload N (N, tension positive) of active bond `e`, when it has one that is
    /// not zero: what adds the geometric terms to its element.
    fn preload(&self, e: usize) -> Option<f64> {
        self.axial.as_ref().map(|f| f[e]).filter(|&f| f != 0.0)
    }

    /// The element matrices of active bond `e` (`element()`, plus its
    /// `geometric_element` under an axial preload), formed from its stored springs and
    /// geometry: the same numbers every time.
    pub fn element(&self, e: usize) -> Element {
        let law = &self.laws[e];
        let mut el = element(law, self.rotations);
        if let Some(f) = self.preload(e) {
            el += geometric_element(&law.normal, law.length, f);
        }
        el
    }

    /// The load terms (G_i, G_j, H) of [`Network::element`] alone, the same bits: what the
    /// sums over the bonds need (half the element's arithmetic).
    pub(crate) fn load_terms(&self, e: usize) -> LoadTerms {
        let law = &self.laws[e];
        let (s, bi, bj) = bond_maps(law, self.rotations);
        let mut t = load_terms_of(&s, &bi, &bj, &(law.normal * law.length));
        if let Some(f) = self.preload(e) {
            let (s, bi, bj) = geometric_maps(&law.normal, law.length, f);
            let g = load_terms_of(&s, &bi, &bj, &(law.normal * law.length));
            t.gi += g.gi;
            t.gj += g.gj;
            t.h += g.h;
        }
        t
    }

    /// The stiffness blocks (K_ii, K_jj, K_ij) of [`Network::element`] alone, the same bits:
    /// what K's assembly forms at both rows of every bond.
    pub(crate) fn stiffness_blocks(&self, e: usize) -> (Block6, Block6, Block6) {
        let law = &self.laws[e];
        let (mut kii, mut kjj, mut kij) = element_stiffness(law, self.rotations);
        if let Some(f) = self.preload(e) {
            let (gii, gjj, gij) = geometric_stiffness(&law.normal, law.length, f);
            kii += gii;
            kjj += gjj;
            kij += gij;
        }
        (kii, kjj, kij)
    }

    /// The coefficients of K_ij (`at_i`) or K_ji of active bond `e`, seen from that end
    /// ([`HalfBond`]; bond_springs.rs).
    pub(crate) fn half_bond(&self, e: usize, at_i: bool) -> HalfBond {
        let law = &self.laws[e];
        let preload = self.preload(e).unwrap_or(0.0) / law.length;
        let (ai, aj) = if self.rotations { law.arms } else { (0.0, 0.0) };
        let (kr, ktw) = if self.rotations {
            (law.kr, law.ktw)
        } else {
            (0.0, 0.0)
        };
        let (normal, own, other) = if at_i {
            (law.normal, ai, aj)
        } else {
            (-law.normal, aj, ai)
        };
        HalfBond {
            normal: normal.into(),
            shear: law.ks + preload,
            axial: (law.kn - law.ks) - preload,
            own_arm_shear: own * law.ks,
            other_arm_shear: other * law.ks,
            turn: own * other * law.ks - kr,
            turn_axial: own * other * law.ks + (ktw - kr),
        }
    }

    /// K_ii (`at_i`) or K_jj of [`Network::stiffness_blocks`] alone, the same bits: what
    /// the diagonal of K needs of a bond.
    pub(crate) fn own_block(&self, e: usize, at_i: bool) -> Block6 {
        let law = &self.laws[e];
        let (s, bi, bj) = bond_maps(law, self.rotations);
        let b = if at_i { bi } else { bj };
        let mut own = b.transpose() * (s * b);
        if let Some(rm) = rotation_springs(law, self.rotations) {
            let mut v = own.fixed_view_mut::<3, 3>(3, 3);
            v += rm;
        }
        if let Some(f) = self.preload(e) {
            let (s, bi, bj) = geometric_maps(&law.normal, law.length, f);
            let b = if at_i { bi } else { bj };
            own += b.transpose() * (s * b);
        }
        own
    }

    /// Free every bond's springs, geometry and preload once K is assembled (80 bytes a bond:
    /// 0.3 GB at a million particles, issue 35); [`Network::element`] then panics.
    pub(crate) fn release_springs(&mut self) {
        self.laws = Vec::new();
        self.axial = None;
    }

    /// Active neighbours of every active particle (CSR: start offsets, neighbour list).
    pub fn adjacency(&self) -> (Vec<usize>, Vec<u32>) {
        csr(self.n_active, self.end_pairs(), |_, other| other as u32)
    }

    /// The two ends of every element, in element order.
    pub(crate) fn end_pairs(&self) -> impl Iterator<Item = (usize, usize)> + Clone + '_ {
        self.ends.iter().map(|&(a, b)| (a as usize, b as usize))
    }
}

/// Compressed rows over `n` items of the pairs (i, j): row i lists `entry(k, j)` and row j
/// lists `entry(k, i)` for the k-th pair, in pair order. Returns the row offsets (n + 1)
/// and the entries.
pub(crate) fn csr<T: Copy + Default>(
    n: usize,
    pairs: impl Iterator<Item = (usize, usize)> + Clone,
    entry: impl Fn(usize, usize) -> T,
) -> (Vec<usize>, Vec<T>) {
    let mut start = vec![0usize; n + 1];
    for (i, j) in pairs.clone() {
        start[i + 1] += 1;
        start[j + 1] += 1;
    }
    for p in 0..n {
        start[p + 1] += start[p];
    }
    let mut fill = start.clone();
    let mut list = vec![T::default(); start[n]];
    for (k, (i, j)) in pairs.enumerate() {
        list[fill[i]] = entry(k, j);
        fill[i] += 1;
        list[fill[j]] = entry(k, i);
        fill[j] += 1;
    }
    (start, list)
}

/// Eigenvalues and orthonormal eigenvectors (columns) of a symmetric 6×6 block by cyclic
/// Jacobi rotations, stopped when every off-diagonal entry is below ε·√|a_pp a_qq|
/// (Demmel & Veselić 1992): accurate for the graded blocks of K, whose rotational entries
/// (N·m/rad) are ~1e-6 of the translational ones (N/m). nalgebra's `SymmetricEigen`
/// reconstructed such a block only to 3e-7 of its largest entry (nalgebra issue #1109),
/// the size of its rotational eigenvalues.
pub fn symmetric_eigen6(m: &Block6) -> (nalgebra::Vector6<f64>, Block6) {
    let mut a = (m + m.transpose()) * 0.5;
    let mut v = Block6::identity();
    for _sweep in 0..60 {
        let mut rotated = false;
        for p in 0..5 {
            for q in p + 1..6 {
                let apq = a[(p, q)];
                let (app, aqq) = (a[(p, p)], a[(q, q)]);
                if apq.abs() <= f64::EPSILON * (app * aqq).abs().sqrt() {
                    a[(p, q)] = 0.0;
                    a[(q, p)] = 0.0;
                    continue;
                }
                rotated = true;
                // The rotation that zeroes a_pq (Golub & Van Loan, Algorithm 8.5.1).
                let theta = (aqq - app) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..6 {
                    let (akp, akq) = (a[(k, p)], a[(k, q)]);
                    a[(k, p)] = c * akp - s * akq;
                    a[(k, q)] = s * akp + c * akq;
                }
                for k in 0..6 {
                    let (apk, aqk) = (a[(p, k)], a[(q, k)]);
                    a[(p, k)] = c * apk - s * aqk;
                    a[(q, k)] = s * apk + c * aqk;
                }
                a[(p, q)] = 0.0;
                a[(q, p)] = 0.0;
                for k in 0..6 {
                    let (vkp, vkq) = (v[(k, p)], v[(k, q)]);
                    v[(k, p)] = c * vkp - s * vkq;
                    v[(k, q)] = s * vkp + c * vkq;
                }
            }
        }
        if !rotated {
            break;
        }
    }
    (a.diagonal(), v)
}

/// Pseudo-inverse of a symmetric positive semi-definite 6×6 block, and its numerical rank
/// (eigenvalues above 1e-10 of the largest are kept; [`symmetric_eigen6`]). A block whose
/// Cholesky factor proves it well inside that rank, tr(M)·tr(M⁻¹) < 1e9 (≥ λmax/λmin), is
/// inverted through the factor instead (every eigenvalue would be kept; a tenth of the
/// eigensolver's work, and as accurate on graded blocks, Cholesky being insensitive to the
/// diagonal scaling), symmetrised.
pub fn pinv_psd(m: &Block6) -> (Block6, usize) {
    if let Some(inv) = nalgebra::Cholesky::new(*m).map(|c| c.inverse()) {
        let trace = m.trace() * inv.trace();
        if trace.is_finite() && trace > 0.0 && trace < 1e9 {
            return ((inv + inv.transpose()) * 0.5, 6);
        }
    }
    pinv_eigen(m)
}

/// [`pinv_psd`] by the eigendecomposition.
fn pinv_eigen(m: &Block6) -> (Block6, usize) {
    let (values, vectors) = symmetric_eigen6(m);
    let max = values.iter().cloned().fold(0.0_f64, f64::max);
    let mut inv = Block6::zeros();
    let mut rank = 0;
    for k in 0..6 {
        let lam = values[k];
        if max > 0.0 && lam > 1e-10 * max {
            let v = vectors.column(k);
            inv += v * v.transpose() / lam;
            rank += 1;
        }
    }
    (inv, rank)
}

/// The relaxed network of a generated 1,500-sphere packing with Truszkowska's MRV model (a
/// fixture of the solvers' unit tests).
#[cfg(test)]
pub(crate) fn mrv_test_network() -> Network {
    mrv_test_network_with(true, false)
}

/// [`mrv_test_network`] with or without rotations, and with an axial preload of alternating
/// sign on every bond when `preloaded`.
#[cfg(test)]
pub(crate) fn mrv_test_network_with(rotations: bool, preloaded: bool) -> Network {
    use crate::packing::{generate, GenerateOptions};
    let opts = GenerateOptions {
        n_particles: 1500,
        ..Default::default()
    };
    let packing = generate(&opts, &|_| {}).unwrap();
    let asm =
        crate::assembly::Assembly::new(packing, crate::model::Model::truszkowska_mrv()).unwrap();
    Network::build(
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        LeverArm::MidGap,
        rotations,
        preloaded
            .then(|| {
                (0..asm.bonds.len())
                    .map(|b| if b % 2 == 0 { 3.7 } else { -2.9 })
                    .collect::<Vec<f64>>()
            })
            .as_deref(),
    )
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagonal block of K from the 3,000-particle standard packing with the demo's MRV
    /// springs (translations N/m, rotations N·m/rad): graded by 1e6.
    fn graded_block() -> Block6 {
        Block6::from_row_slice(&[
            1.087003e8,
            1.672688e7,
            -1.268614e7,
            0.0,
            -2.778013e4,
            4.522595e3, //
            1.672688e7,
            1.300342e8,
            -9.041728e6,
            2.778013e4,
            0.0,
            7.068170e2, //
            -1.268614e7,
            -9.041728e6,
            1.074894e8,
            -4.522595e3,
            -7.068170e2,
            0.0, //
            0.0,
            2.778013e4,
            -4.522595e3,
            7.558937e1,
            -1.483020e0,
            5.242083e0, //
            -2.778013e4,
            0.0,
            -7.068170e2,
            -1.483020e0,
            4.155068e1,
            9.618931e-1, //
            4.522595e3,
            7.068170e2,
            0.0,
            5.242083e0,
            9.618931e-1,
            4.943751e1,
        ])
    }

    /// |X_ij| relative to √(B_ii B_jj), the scale of entry ij of a graded PSD block.
    fn graded_error(x: &Block6, b: &Block6) -> f64 {
        let mut e = 0.0_f64;
        for i in 0..6 {
            for j in 0..6 {
                e = e.max(x[(i, j)].abs() / (b[(i, i)] * b[(j, j)]).sqrt());
            }
        }
        e
    }

    #[test]
    fn jacobi_eigen_reconstructs_a_graded_block_entry_by_entry() {
        let b = graded_block();
        let (values, v) = symmetric_eigen6(&b);
        let recon = v * Block6::from_diagonal(&values) * v.transpose();
        assert!(graded_error(&(recon - b), &b) < 1e-14, "{recon:e}");
        assert!((v.transpose() * v - Block6::identity()).abs().max() < 1e-14);
        // The inverse is exact on every entry's own scale: B·B⁺ = I.
        let (inv, rank) = pinv_psd(&b);
        assert_eq!(rank, 6);
        assert!((b * inv - Block6::identity()).abs().max() < 1e-12);
    }

    /// K's assembly forms the stiffness blocks alone: the element's, bit for bit, with and
    /// without rotations, bending and twisting springs, and a preload.
    #[test]
    fn stiffness_blocks_are_the_elements_bit_for_bit() {
        let n = Vec3::new(0.48, -0.6, 0.64);
        for (rotations, kr, ktw) in [(true, 3.1e2, 1.7e2), (true, 0.0, 0.0), (false, 3.1e2, 0.0)] {
            let law = BondLaw {
                normal: n,
                length: 2.1e-3,
                arms: (1.0e-3, 1.1e-3),
                kn: 2e8,
                ks: 7e7,
                kr,
                ktw,
            };
            let el = element(&law, rotations);
            assert_eq!(element_stiffness(&law, rotations), (el.kii, el.kjj, el.kij));
            let g = geometric_element(&n, law.length, -3.7);
            assert_eq!(
                geometric_stiffness(&n, law.length, -3.7),
                (g.kii, g.kjj, g.kij)
            );
        }
        for net in [
            mrv_test_network(),
            mrv_test_network_with(false, false),
            mrv_test_network_with(true, true),
        ] {
            for e in 0..net.ends.len() {
                let (kii, kjj, _) = net.stiffness_blocks(e);
                assert_eq!(
                    (net.own_block(e, true), net.own_block(e, false)),
                    (kii, kjj)
                );
                let (el, t) = (net.element(e), net.load_terms(e));
                assert_eq!((t.gi, t.gj, t.h), (el.gi, el.gj, el.h), "bond {e}");
            }
        }
        let net = mrv_test_network();
        for e in 0..net.ends.len() {
            let el = net.element(e);
            assert_eq!(
                net.stiffness_blocks(e),
                (el.kii, el.kjj, el.kij),
                "bond {e}"
            );
        }
    }

    /// The Cholesky route of `pinv_psd` gives the eigendecomposition's pseudo-inverse and
    /// rank on every diagonal block of K (graded: N/m and N·m/rad), to rounding on each
    /// entry's own scale; blocks it leaves to the eigensolver get the eigensolver's answer.
    #[test]
    fn cholesky_inverse_agrees_with_the_eigen_pseudo_inverse() {
        let k = super::super::sparse::BlockSparse::assemble(&mrv_test_network());
        let mut by_factor = 0;
        for p in 0..k.rows() {
            let b = k.diagonal(p);
            let (fast, rank) = pinv_psd(&b);
            let (slow, slow_rank) = pinv_eigen(&b);
            assert_eq!(rank, slow_rank, "block {p}");
            let scale = |x: &Block6| {
                let mut e = 0.0_f64;
                for i in 0..6 {
                    for j in 0..6 {
                        e = e.max(x[(i, j)].abs() * (b[(i, i)] * b[(j, j)]).sqrt());
                    }
                }
                e
            };
            assert!(
                scale(&(fast - slow)) < 1e-12,
                "block {p}: {fast:e} vs {slow:e}"
            );
            by_factor += usize::from(fast != slow);
        }
        assert!(
            by_factor > k.rows() / 2,
            "{by_factor} of {} by the factor",
            k.rows()
        );
    }

    #[test]
    fn pinv_keeps_the_exact_null_space_of_a_two_bond_particle() {
        // A particle with two bonds has one free rigid motion (the rotation about the line
        // through its two contact points): rank 5, and B⁺ annihilates that motion.
        let law = |n: Vec3| BondLaw {
            normal: n,
            length: 2.1e-3,
            arms: (1.05e-3, 1.05e-3),
            kn: 2e8,
            ks: 7e7,
            kr: 0.0,
            ktw: 0.0,
        };
        let b = element(&law(Vec3::new(0.6, 0.8, 0.0)), true).kii
            + element(&law(Vec3::new(0.0, -0.6, 0.8)), true).kii;
        let (inv, rank) = pinv_psd(&b);
        assert_eq!(rank, 5);
        let (values, v) = symmetric_eigen6(&b);
        let k = (0..6)
            .min_by(|&x, &y| values[x].total_cmp(&values[y]))
            .unwrap();
        let free = v.column(k);
        assert!((b * free).norm() < 1e-14 * b.abs().max());
        assert!((inv * free).norm() < 1e-10 * inv.abs().max());
        assert!(graded_error(&(b * inv * b - b), &b) < 1e-12);
    }
}
