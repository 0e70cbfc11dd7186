//! The relaxed CG's two-level coarse space when a many-body term is present.
//!
//! A term whose D is stiff in one strain direction (the calibrated metals: copper's D has
//! C11 + 2C12 ≈ 44 (C11 − C12)) makes the smooth, nearly volume-preserving fluctuations the
//! slow modes of the CG: a rigid motion per aggregate approximates them with jumps between
//! aggregates whose fitted strains the term's stiff direction penalises. Adding the six
//! uniform-strain modes of every aggregate (u = ε·d, ω = 0; the piecewise-affine coarse
//! space of smoothed/strain aggregation) leaves jumps of second order in the aggregate's size.
//! The coarse operator is PᵀKP with K the springs' assembled blocks plus the term's Hessian
//! applied in factored form ([`TermOperator::times_prolongation`]), built once per solve.
//! Also dense block-Jacobi blocks: over the term's stiff stencils ([`StiffGroups::new`]),
//! and over a held specimen's loosely bonded particles with their neighbours, the springs
//! alone ([`StiffGroups::loose`]).

use super::network::Block6;
use super::sparse::{BlockSparse, Cols};
use super::term_operator::{strain_map, TermOperator};
use super::two_level::{CoarseLayer, TwoLevel};
use crate::tensor::Stiffness6;
use crate::{Result, Vec3};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Fewest nodes an aggregate needs to keep its strain modes: with fewer, the six modes on
/// 3 translations per node are (nearly) dependent on the rigid ones; they are dropped there
/// (zero prolongation, a null coarse node the factorisation removes).
const MIN_STRAIN_MEMBERS: usize = 12;

/// The uniform-strain modes at arm `d` (in units of the cells' edge): u = E d with E the
/// symmetric strain of the engineering Voigt vector (ε11, ε22, ε33, γ23, γ13, γ12); ω = 0.
pub(crate) fn strain_modes(d: &Vec3, members: usize) -> Block6 {
    let mut p = Block6::zeros();
    if members < MIN_STRAIN_MEMBERS {
        return p;
    }
    let h = 0.5;
    // u_x = ε11 dx + γ12/2 dy + γ13/2 dz
    p[(0, 0)] = d.x;
    p[(0, 5)] = h * d.y;
    p[(0, 4)] = h * d.z;
    // u_y = γ12/2 dx + ε22 dy + γ23/2 dz
    p[(1, 5)] = h * d.x;
    p[(1, 1)] = d.y;
    p[(1, 3)] = h * d.z;
    // u_z = γ13/2 dx + γ23/2 dy + ε33 dz
    p[(2, 4)] = h * d.x;
    p[(2, 3)] = h * d.y;
    p[(2, 2)] = d.z;
    p
}

/// Kelvin-form contrast of the term's D at and above which the strain modes are added.
/// Measured (docs/manybody.md, "Cost of the relaxed solve"): an isotropic D of contrast 5
/// (K' = 10, G' = 3 GPa, 30,700 particles) converges in 54 instead of 86 iterations with
/// them but takes 1.8× the time; nickel's D (contrast 14, 8,000 particles) 240 instead of
/// 584 iterations for 28 % less CPU time on one thread. The threshold lies between the two.
pub(crate) const STRAIN_MODES_CONTRAST: f64 = 10.0;

/// The ratio of the largest to the smallest eigenvalue of D in Kelvin (Mandel) form, where
/// the shear rows and columns of the engineering Voigt matrix are scaled by √2 so that the
/// eigenvalues are the stiffnesses of the eigen-strains (cubic: C11 + 2C12, C11 − C12 and
/// 2C44). Infinite for a D that is not positive definite.
pub(crate) fn kelvin_contrast(d: &Stiffness6) -> f64 {
    let s = [1.0, 1.0, 1.0, 2f64.sqrt(), 2f64.sqrt(), 2f64.sqrt()];
    let kelvin = Stiffness6::from_fn(|i, j| s[i] * d[(i, j)] * s[j]);
    let eig = kelvin.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if lo > 0.0 {
        hi / lo
    } else {
        f64::INFINITY
    }
}

/// The two-level coarse space of K = springs + term. Where a D is stiff in one strain
/// direction ([`kelvin_contrast`] ≥ [`STRAIN_MODES_CONTRAST`]): rigid and uniform-strain
/// modes on aggregates of about a quarter of `per_aggregate` nodes (at least
/// `per_aggregate` or 12, whichever is fewer); otherwise the rigid modes alone on
/// aggregates of `per_aggregate`, with the term's K'P (`positions` inside the periodic box
/// `box_lengths`).
pub(crate) fn coarse_space(
    springs: &BlockSparse,
    term: &TermOperator,
    positions: &[Vec3],
    box_lengths: Vec3,
    rotations: bool,
    per_aggregate: usize,
) -> Result<TwoLevel> {
    // Smaller aggregates than the springs' (a quarter: 32 by default) with the strain modes:
    // measured on 8,000 particles with nickel's D, 240 iterations against 584 of the rigid
    // modes on aggregates of 128, for 28 % less CPU time (docs/manybody.md).
    let contrast = term
        .tensors()
        .iter()
        .map(kelvin_contrast)
        .fold(0.0, f64::max);
    if contrast < STRAIN_MODES_CONTRAST {
        return TwoLevel::with_extra(
            springs,
            positions,
            box_lengths,
            rotations,
            per_aggregate,
            |aggregate, prolongation| Some(term.times_prolongation(aggregate, prolongation)),
        );
    }
    let per_aggregate = (per_aggregate / 4).max(per_aggregate.min(MIN_STRAIN_MEMBERS));
    let strain_layer: CoarseLayer = &strain_modes;
    TwoLevel::with_layers(
        springs,
        positions,
        box_lengths,
        (rotations, per_aggregate),
        &[strain_layer],
        |aggregate, prolongation| Some(term.times_prolongation(aggregate, prolongation)),
    )
}

/// An owner is stiff when its share (its largest, over its stencil's nodes, of its part of
/// the term's diagonal block at a node against the springs' there, translation traces) is at
/// least this multiple of the median owner's: the nearly degenerate particles, whose fit
/// amplifies the strain (A_p with λ_min/λ_max just above `ManyBodyOptions::conditioning`),
/// so that the term couples their stencil's nodes far more stiffly than anything else does.
/// Measured (bench `manybody`, isotropic K' = 10, G' = 3 GPa, 1 thread; the median share
/// 0.024; the largest 280 at 8,000 particles, 2,200 on the CLI's packing of 30,700): CG
/// iterations at 8,000 particles 115 without groups; with groups for the owners of share
/// above 4,000, 400, 40, 30 and 10 times the median 48, 42, 38, 38, 37; at 30,700 (seed 2018)
/// 86 without, 49 (400×), 44 (40×), 39 (10×).
pub(crate) const STIFF_OWNER_RATIO: f64 = 10.0;

/// At most one owner in this many is given a group.
const MAX_STIFF_SHARE: usize = 50;

/// Most nodes in one group of [`StiffGroups`] (6 DOFs each: a dense block of at most 288).
const MAX_GROUP_NODES: usize = 48;

/// Block-Jacobi blocks over the stencils of the term's stiff owners ([`STIFF_OWNER_RATIO`]):
/// each group (the union of overlapping stiff stencils, at most [`MAX_GROUP_NODES`] nodes)
/// is one diagonal block of the preconditioner, the exact principal submatrix of K (springs
/// and term) on the group's nodes, inverted densely; every other node keeps its 6×6 block.
/// A 6×6 block-Jacobi sees only the diagonal of such an owner's stiff coupling, so that its
/// stiffness, spread over the nodes one by one, makes the preconditioned operator nearly
/// singular in the directions that the coupling ties together (docs/manybody.md, "Cost of the
/// relaxed solve": 354 CG iterations on the CLI's standard packing). Still a block-diagonal
/// symmetric preconditioner: the CG's answer is unchanged up to its tolerance.
pub(crate) struct StiffGroups {
    groups: Vec<Group>,
}

/// One group: its nodes (ascending) and the (pseudo-)inverse of K on their DOFs.
struct Group {
    nodes: Vec<u32>,
    inverse: DMatrix<f64>,
}

impl StiffGroups {
    /// The groups of K = `springs` + `term`, `None` when no owner is stiff.
    pub(crate) fn new(springs: &BlockSparse, term: &TermOperator) -> Option<StiffGroups> {
        let m = springs.rows();
        let spring_trace: Vec<f64> = (0..m)
            .into_par_iter()
            .map(|n| {
                let d = springs.diagonal(n);
                d[(0, 0)] + d[(1, 1)] + d[(2, 2)]
            })
            .collect();
        // Each owner's largest share of a node's diagonal against the springs' there; the
        // stiff owners are the outliers: at least STIFF_OWNER_RATIO times the median owner's,
        // stiffest first, at most one owner in MAX_STIFF_SHARE.
        let share: Vec<f64> = (0..term.owners())
            .into_par_iter()
            .map(|o| {
                let (v, d, nodes, coefs) = term.owner(o);
                nodes
                    .iter()
                    .zip(coefs)
                    .map(|(&n, c)| {
                        let nm = strain_map(c);
                        (nm.transpose() * d * nm).trace() * v / spring_trace[n as usize]
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let mut sorted = share.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let mut stiff: Vec<usize> = (0..share.len())
            .filter(|&o| share[o] >= STIFF_OWNER_RATIO * median && share[o] > 0.0)
            .collect();
        stiff.sort_by(|&a, &b| share[b].total_cmp(&share[a]).then(a.cmp(&b)));
        stiff.truncate(share.len().div_ceil(MAX_STIFF_SHARE));
        let stencils = stiff.iter().map(|&o| term.owner(o).2.to_vec());
        Some(Self::of_stencils(springs, stencils, Some(term)))
    }

    /// Groups over the loosely held nodes of the springs' K alone: each node with fewer than
    /// `max_bonds` off-diagonal blocks (a free surface's particles kept by one or two bonds)
    /// together with its bonded neighbours, overlapping patches merged ([`merge_stencils`]).
    /// `None` when no node is loose.
    pub(crate) fn loose(springs: &BlockSparse, max_bonds: usize) -> Option<StiffGroups> {
        let m = springs.rows();
        let patches: Vec<Vec<u32>> = (0..m)
            .filter(|&n| springs.row(n).filter(|&(c, _)| c != n).count() < max_bonds)
            .map(|n| springs.row(n).map(|(c, _)| c as u32).collect())
            .collect();
        if patches.is_empty() {
            return None;
        }
        Some(Self::of_stencils(springs, patches.into_iter(), None))
    }

    /// The groups of `stencils` merged where they overlap ([`merge_stencils`]), each with
    /// the (pseudo-)inverse of K = `springs` (+ `term`) on its nodes.
    fn of_stencils(
        springs: &BlockSparse,
        stencils: impl Iterator<Item = Vec<u32>>,
        term: Option<&TermOperator>,
    ) -> StiffGroups {
        let groups: Vec<Group> = merge_stencils(springs.rows(), stencils)
            .into_par_iter()
            .filter(|g| !g.is_empty())
            .map(|mut nodes| {
                nodes.sort_unstable();
                Group::new(nodes, springs, term)
            })
            .collect();
        StiffGroups { groups }
    }

    /// z = M r on the groups' nodes (the first `cols` load cases), over the 6×6 block-Jacobi
    /// values there.
    pub(crate) fn apply<const C: usize>(&self, r: &[Cols<C>], z: &mut [Cols<C>], cols: usize) {
        let out: Vec<Vec<Cols<C>>> = self
            .groups
            .par_iter()
            .map(|g| {
                let n = g.nodes.len();
                let mut rv = DMatrix::<f64>::zeros(6 * n, cols);
                for (l, &node) in g.nodes.iter().enumerate() {
                    for c in 0..cols {
                        for i in 0..6 {
                            rv[(6 * l + i, c)] = r[node as usize][(i, c)];
                        }
                    }
                }
                let y = &g.inverse * rv;
                (0..n)
                    .map(|l| {
                        let mut b = Cols::<C>::zeros();
                        for c in 0..cols {
                            for i in 0..6 {
                                b[(i, c)] = y[(6 * l + i, c)];
                            }
                        }
                        b
                    })
                    .collect()
            })
            .collect();
        for (g, blocks) in self.groups.iter().zip(out) {
            for (&node, b) in g.nodes.iter().zip(blocks) {
                z[node as usize] = b;
            }
        }
    }
}

/// Stencils (node lists) merged where they overlap, in order (deterministic), into groups of
/// at most [`MAX_GROUP_NODES`] nodes: a stencil whose merge would pass the limit is skipped
/// (its nodes keep their 6×6 blocks).
fn merge_stencils(m: usize, stencils: impl Iterator<Item = Vec<u32>>) -> Vec<Vec<u32>> {
    let mut group_of = vec![u32::MAX; m];
    let mut members: Vec<Vec<u32>> = Vec::new();
    for mut nodes in stencils {
        nodes.sort_unstable();
        nodes.dedup();
        let mut touched: Vec<u32> = nodes
            .iter()
            .map(|&n| group_of[n as usize])
            .filter(|&g| g != u32::MAX)
            .collect();
        touched.sort_unstable();
        touched.dedup();
        let fresh = nodes
            .iter()
            .filter(|&&n| group_of[n as usize] == u32::MAX)
            .count();
        let size = fresh
            + touched
                .iter()
                .map(|&g| members[g as usize].len())
                .sum::<usize>();
        if size > MAX_GROUP_NODES {
            continue;
        }
        let target = match touched.first() {
            Some(&g) => g,
            None => {
                members.push(Vec::new());
                (members.len() - 1) as u32
            }
        };
        for &g in touched.iter().skip(1) {
            let moved = std::mem::take(&mut members[g as usize]);
            for &n in &moved {
                group_of[n as usize] = target;
            }
            members[target as usize].extend(moved);
        }
        for &n in &nodes {
            if group_of[n as usize] == u32::MAX {
                group_of[n as usize] = target;
                members[target as usize].push(n);
            }
        }
    }
    members
}

/// The term's Hessian blocks on `nodes` (ascending) added to `a`, K on their DOFs: every
/// owner whose stencil touches them, in owner order.
fn add_term_blocks(a: &mut DMatrix<f64>, nodes: &[u32], term: &TermOperator) {
    let mut owners: Vec<u32> = nodes
        .iter()
        .flat_map(|&r| term.owners_of_row(r as usize).iter().copied())
        .collect();
    owners.sort_unstable();
    owners.dedup();
    for o in owners {
        let (v, d, ns, cs) = term.owner(o as usize);
        let local: Vec<_> = ns
            .iter()
            .zip(cs)
            .filter_map(|(&q, c)| nodes.binary_search(&q).ok().map(|l| (l, strain_map(c))))
            .collect();
        for (la, na) in &local {
            let left = na.transpose() * d * v;
            for (lb, nb) in &local {
                let mut blk = a.fixed_view_mut::<3, 3>(6 * la, 6 * lb);
                blk += left * nb;
            }
        }
    }
}

impl Group {
    /// K (springs + term) on the DOFs of `nodes`, symmetrically scaled by its diagonal and
    /// inverted (Cholesky; a pseudo-inverse where it is singular), unscaled again.
    fn new(nodes: Vec<u32>, springs: &BlockSparse, term: Option<&TermOperator>) -> Group {
        let n = nodes.len();
        let mut a = DMatrix::<f64>::zeros(6 * n, 6 * n);
        for (li, &r) in nodes.iter().enumerate() {
            for (c, blk) in springs.row(r as usize) {
                if let Ok(lj) = nodes.binary_search(&(c as u32)) {
                    let mut v = a.fixed_view_mut::<6, 6>(6 * li, 6 * lj);
                    v += blk;
                }
            }
        }
        if let Some(term) = term {
            add_term_blocks(&mut a, &nodes, term);
        }
        let dim = 6 * n;
        let s: Vec<f64> = (0..dim)
            .map(|i| {
                let d = a[(i, i)];
                if d > 0.0 {
                    1.0 / d.sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let mut b = DMatrix::<f64>::from_fn(dim, dim, |i, j| s[i] * a[(i, j)] * s[j]);
        for i in 0..dim {
            if s[i] == 0.0 {
                b[(i, i)] = 1.0;
            }
        }
        // The springs alone (a held structure's loose patches) may have zero-energy modes
        // (a particle's rotation about its one or two bonds) that a Cholesky factorisation
        // passes with rounding-level pivots: their pseudo-inverse by eigenvalues, cut as
        // `pinv_psd` cuts the 6×6 blocks.
        let (attempt, cut) = match term {
            Some(_) => (b.clone().cholesky(), 1e-14),
            None => (None, 1e-10),
        };
        let inv = match attempt {
            Some(c) => c.inverse(),
            None => {
                let eig = b.symmetric_eigen();
                let max = eig.eigenvalues.max();
                let mut inv = DMatrix::<f64>::zeros(dim, dim);
                for k in 0..dim {
                    let lam = eig.eigenvalues[k];
                    if lam > cut * max {
                        let v = eig.eigenvectors.column(k);
                        inv += v * v.transpose() / lam;
                    }
                }
                inv
            }
        };
        let inverse = DMatrix::<f64>::from_fn(dim, dim, |i, j| s[i] * inv[(i, j)] * s[j]);
        Group { nodes, inverse }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bonds::{assign_stiffness, build_bonds, BondingRule};
    use crate::homogenize::relaxed::{network_with_term, with_term_hessian};
    use crate::homogenize::RelaxedOptions;
    use crate::manybody::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions};
    use crate::model::Model;
    use crate::packing::{generate, GenerateOptions};

    /// A generated 2,000-sphere packing bonded at gap 0.17 with Truszkowska's MRV springs.
    fn bonded_packing() -> (
        crate::packing::Packing,
        crate::bonds::BondSet,
        crate::bonds::BondStiffness,
    ) {
        let p = generate(
            &GenerateOptions {
                n_particles: 2000,
                ..Default::default()
            },
            &|_| {},
        )
        .unwrap();
        let bonds = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
        let model = Model::truszkowska_mrv();
        let scheme = model.build_scheme(None).unwrap();
        let k = assign_stiffness(&p, &bonds, scheme.as_ref(), &model.geometry).unwrap();
        (p, bonds, k)
    }

    /// The principal submatrix of `k` on the DOFs of `nodes` (ascending).
    fn principal(k: &BlockSparse, nodes: &[u32]) -> DMatrix<f64> {
        let n = nodes.len();
        let mut a = DMatrix::<f64>::zeros(6 * n, 6 * n);
        for (li, &r) in nodes.iter().enumerate() {
            for (c, blk) in k.row(r as usize) {
                if let Ok(lj) = nodes.binary_search(&(c as u32)) {
                    a.fixed_view_mut::<6, 6>(6 * li, 6 * lj).copy_from(blk);
                }
            }
        }
        a
    }

    /// The loose patches of the springs alone (a generated packing's particles on fewer than
    /// four bonds): every loose node whose patch is in a group has all its bonded neighbours
    /// in that group, and each group's block is the pseudo-inverse of the principal submatrix
    /// of the springs' K on its nodes (A M A = A and M A M = M, with the zero-energy rotations
    /// of one- and two-bond particles), applied on one load case as the dense product.
    #[test]
    fn loose_patches_pseudo_invert_the_springs_on_their_nodes() {
        let (p, bonds, k) = bonded_packing();
        let opts = RelaxedOptions::default();
        let (net, _, _) = network_with_term(&p, &bonds, &k, &opts, None, None).unwrap();
        let springs = BlockSparse::assemble(&net);
        let m = springs.rows();
        let groups = StiffGroups::loose(&springs, 4).expect("loose nodes");
        let mut group_of = vec![usize::MAX; m];
        for (gi, g) in groups.groups.iter().enumerate() {
            for &n in &g.nodes {
                group_of[n as usize] = gi;
            }
        }
        let mut covered = 0;
        for n in 0..m {
            let neighbours: Vec<usize> = springs.row(n).map(|(c, _)| c).collect();
            if neighbours.len() - 1 < 4 && group_of[n] != usize::MAX {
                covered += 1;
                assert!(neighbours.iter().all(|&c| group_of[c] == group_of[n]));
            }
        }
        assert!(covered > 0, "no loose node in a patch");
        for g in &groups.groups {
            let n = g.nodes.len();
            assert!(n <= MAX_GROUP_NODES);
            let a = principal(&springs, &g.nodes);
            let ama = &a * &g.inverse * &a;
            assert!((&ama - &a).amax() <= 1e-8 * a.amax(), "A M A − A");
            let mam = &g.inverse * &a * &g.inverse;
            assert!(
                (&mam - &g.inverse).amax() <= 1e-8 * g.inverse.amax(),
                "M A M − M"
            );
        }
        let r: Vec<Cols<1>> = (0..m)
            .map(|i| Cols::<1>::from_fn(|a, _| ((i * 7 + a * 3) % 11) as f64 - 5.0))
            .collect();
        let mut z = vec![Cols::<1>::from_element(9.0); m];
        groups.apply(&r, &mut z, 1);
        for (n, zn) in z.iter().enumerate() {
            let Some(g) = groups.groups.get(group_of[n]) else {
                assert_eq!(*zn, Cols::<1>::from_element(9.0));
                continue;
            };
            let l = g.nodes.binary_search(&(n as u32)).unwrap();
            let rv = DMatrix::<f64>::from_fn(6 * g.nodes.len(), 1, |i, _| {
                r[g.nodes[i / 6] as usize][(i % 6, 0)]
            });
            let y = &g.inverse * rv;
            for i in 0..6 {
                assert_eq!(zn[(i, 0)], y[(6 * l + i, 0)]);
            }
        }
    }

    /// Each group's block is the inverse of K on its nodes: against the principal submatrix
    /// of K assembled independently (the springs' blocks plus `ManyBody::hessian`, not the
    /// factored form the groups are built from), A·M·A = A and M·A = I where A is regular.
    /// Also the stiff owners are found at all on a generated packing (nearly degenerate
    /// particles), and `apply` writes M r on the groups' nodes only.
    #[test]
    fn group_blocks_invert_the_assembled_principal_submatrix() {
        let (p, bonds, k) = bonded_packing();
        let d = LocalTensor::Isotropic {
            bulk: 10e9,
            shear: 3e9,
        };
        let options = ManyBodyOptions {
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        };
        let mb = ManyBody::new(&p, &bonds, &d, &options).unwrap();
        let opts = RelaxedOptions::default();
        let (net, op, _) = network_with_term(&p, &bonds, &k, &opts, None, Some(&mb)).unwrap();
        let op = op.unwrap();
        let springs = BlockSparse::assemble(&net);
        let full = with_term_hessian(&springs, &mb, &net.index).unwrap();
        let groups = StiffGroups::new(&springs, &op).expect("stiff owners");
        assert!(!groups.groups.is_empty());
        for g in &groups.groups {
            let n = g.nodes.len();
            assert!(n <= MAX_GROUP_NODES);
            let a = principal(&full, &g.nodes);
            let ama = &a * &g.inverse * &a;
            let scale = a.amax();
            assert!((&ama - &a).amax() <= 1e-8 * scale, "A M A − A");
            // Scaled by the diagonal, M·A is the identity where A is regular.
            let ma = &g.inverse * &a;
            let regular = a.clone().cholesky().is_some();
            if regular {
                let err = (ma - DMatrix::<f64>::identity(6 * n, 6 * n)).amax();
                assert!(err <= 1e-6, "M A − I: {err:.3e}");
            }
        }
        // apply: M r on the groups' nodes, the rest untouched.
        let m = springs.rows();
        let r: Vec<Block6> = (0..m)
            .map(|i| Block6::from_fn(|a, b| ((i * 7 + a * 3 + b) % 11) as f64 - 5.0))
            .collect();
        let mut z = vec![Block6::from_element(9.0); m];
        groups.apply(&r, &mut z, 6);
        let mut inside = vec![false; m];
        for g in &groups.groups {
            let n = g.nodes.len();
            let rv =
                DMatrix::<f64>::from_fn(6 * n, 6, |i, c| r[g.nodes[i / 6] as usize][(i % 6, c)]);
            let y = &g.inverse * rv;
            for (l, &node) in g.nodes.iter().enumerate() {
                inside[node as usize] = true;
                for i in 0..6 {
                    for c in 0..6 {
                        assert_eq!(z[node as usize][(i, c)], y[(6 * l + i, c)]);
                    }
                }
            }
        }
        for (zi, &g) in z.iter().zip(&inside) {
            if !g {
                assert_eq!(*zi, Block6::from_element(9.0));
            }
        }
    }

    /// A cubic D's Kelvin eigenvalues are C11 + 2C12, C11 − C12 and 2C44 (closed form).
    #[test]
    fn kelvin_contrast_of_cubic_tensors_is_the_closed_form() {
        for (c11, c12, c44) in [
            (195.41, 182.64, 68.13),
            (175.92, 143.33, 103.72),
            (13.0, 7.0, 3.0),
        ] {
            let mut d = Stiffness6::zeros();
            for i in 0..3 {
                for j in 0..3 {
                    d[(i, j)] = if i == j { c11 } else { c12 };
                }
                d[(i + 3, i + 3)] = c44;
            }
            let eig = [c11 + 2.0 * c12, c11 - c12, 2.0 * c44];
            let want = eig.iter().cloned().fold(0.0, f64::max)
                / eig.iter().cloned().fold(f64::INFINITY, f64::min);
            let got = kelvin_contrast(&d);
            assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
        }
        // Isotropic K' = 10, G' = 3: 3K'/2G' = 5, below the threshold; copper's D above it.
        let (k, g) = (10.0, 3.0);
        let iso = (k + 4.0 * g / 3.0, k - 2.0 * g / 3.0, g);
        let mut d = Stiffness6::zeros();
        for i in 0..3 {
            for j in 0..3 {
                d[(i, j)] = if i == j { iso.0 } else { iso.1 };
            }
            d[(i + 3, i + 3)] = iso.2;
        }
        assert!((kelvin_contrast(&d) - 5.0).abs() < 1e-12);
        assert!(kelvin_contrast(&d) < STRAIN_MODES_CONTRAST);
        let mut neg = d;
        neg[(0, 0)] = -1.0;
        assert!(kelvin_contrast(&neg).is_infinite());
    }
}
