//! Smoothed-aggregation algebraic multigrid (SA-AMG; Vaněk, Mandel & Brezina 1996) on the
//! 6×6 block-sparse stiffness, as a V-cycle preconditioner of the relaxed CG.
//!
//! - Near-null space: per particle the six rigid-body modes, u = t + θ × d, ω = θ, with d the
//!   particle's (minimum-image) arm from its aggregate's centre (PETSc GAMG's rigid-body
//!   near-null space with the spins).
//! - Aggregation: greedy, in node order, on the block graph (on the finest level every bond
//!   is a connection, on the coarse ones the blocks above a strength threshold): roots
//!   whose neighbours are all free take them; the rest join the neighbouring aggregate they
//!   are most strongly coupled to (Vaněk et al. 1996, Sec. 4).
//! - Tentative prolongator: a local QR (modified Gram–Schmidt) of the near-null vectors per
//!   aggregate; its R is the next level's near-null space, so every coarse node has six
//!   unknowns again and the coarse matrices are 6×6 block-sparse too.
//! - Prolongator smoothing: P = (I − ω D⁻¹A) P₀, ω = 4/(3ρ), ρ ≈ ρ(D⁻¹A) by power iteration
//!   (D = the 6×6 diagonal blocks, pseudo-inverted).
//! - Galerkin coarse matrices PᵀAP, down to at most [`COARSE_NODES`] nodes, factored by
//!   [`BlockCholesky`].
//! - V-cycle with damped block-Jacobi pre- and post-smoothing (ω = 4/(3ρ); the same
//!   symmetric smoother on both sides and an exact coarse solve, so the preconditioner is
//!   symmetric and CG holds).
//!
//! No Rust crate fitted (2026-11): the smoothed-aggregation crates found (scirs2-sparse,
//! oxiphysics-fem, oxicuda-sparse) are scalar CSR with the constant vector as near-null
//! space, none takes 6×6 blocks with a user near-null space (the spins).
//!
//! Every sum runs in a fixed order (rows in parallel, each row sequential; aggregation
//! sequential), so the result does not depend on the thread count.

use super::cholesky::BlockCholesky;
use super::network::{pinv_psd, Block6};
use super::sparse::{mul6_cols, mul_add6, mul_add6_cols, BlockSparse};
use crate::packing::PeriodicCell;
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::Mutex;

/// Coarsening stops at or below this many nodes; that level is solved directly.
pub const COARSE_NODES: usize = 256;

/// At most this many levels (the finest included).
const MAX_LEVELS: usize = 12;

/// Damped block-Jacobi sweeps before and after the coarse correction on every level (two
/// take 21 iterations on the 30,700-particle standard assembly, one 37).
const SWEEPS: usize = 2;

/// Strength threshold θ of the coarse levels: a block A_ij is a connection when
/// ‖A_ij‖ ≥ θ·√(‖A_ii‖‖A_jj‖) (Frobenius norms). The finest level keeps every bond; without
/// it the second coarsening of the standard assembly went from 2,264 nodes to 26 (45
/// neighbours per row) and cost 16 iterations of 37.
const COARSE_THETA: f64 = 0.02;

/// Power iterations for ρ(D⁻¹A).
const POWER_ITERATIONS: usize = 20;

/// A near-null vector whose part orthogonal to the previous ones is below this fraction of
/// its norm on an aggregate is dropped there (e.g. the rotations of a one-node aggregate
/// with locked spins).
const RANK_TOLERANCE: f64 = 1e-8;

/// Rows of 6×6 blocks (CSR): a prolongator (fine rows, coarse columns) or its transpose.
struct BlockRows {
    start: Vec<usize>,
    entries: Vec<(u32, Block6)>,
}

impl BlockRows {
    /// From per-row lists.
    fn from_rows(rows: Vec<Vec<(u32, Block6)>>) -> BlockRows {
        let mut start = Vec::with_capacity(rows.len() + 1);
        start.push(0);
        let mut entries = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for r in rows {
            entries.extend(r);
            start.push(entries.len());
        }
        BlockRows { start, entries }
    }

    /// The entries of row `i`.
    fn row(&self, i: usize) -> &[(u32, Block6)] {
        &self.entries[self.start[i]..self.start[i + 1]]
    }

    /// Number of rows.
    fn rows(&self) -> usize {
        self.start.len() - 1
    }

    /// The transpose over `n_cols` rows, every block transposed; a row's entries in
    /// increasing original row order (counting sort, a fixed order).
    fn transpose(&self, n_cols: usize) -> BlockRows {
        let mut start = vec![0usize; n_cols + 1];
        for (c, _) in &self.entries {
            start[*c as usize + 1] += 1;
        }
        for a in 0..n_cols {
            start[a + 1] += start[a];
        }
        let mut fill = start.clone();
        let mut entries = vec![(0u32, Block6::zeros()); self.entries.len()];
        for i in 0..self.rows() {
            for (c, b) in self.row(i) {
                let f = &mut fill[*c as usize];
                entries[*f] = (i as u32, b.transpose());
                *f += 1;
            }
        }
        BlockRows { start, entries }
    }

    /// y = B x on the first `cols` columns (`add`: y += B x).
    fn apply(&self, x: &[Block6], y: &mut [Block6], cols: usize, add: bool) {
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let mut acc = if add { *yi } else { Block6::zeros() };
            for (c, b) in self.row(i) {
                mul_add6_cols(&mut acc, b, &x[*c as usize], cols);
            }
            *yi = acc;
        });
    }

    /// Memory held (bytes).
    fn bytes(&self) -> usize {
        self.entries.len() * std::mem::size_of::<(u32, Block6)>() + self.start.len() * 8
    }
}

/// Skew matrix [a]× with [a]× v = a × v.
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// The six rigid-body modes at arm `d` (columns: translations t, rotations θ):
/// u = t + θ × d, and ω = θ when the particles rotate.
fn rigid_modes(d: &Vec3, rotations: bool) -> Block6 {
    let mut b = Block6::zeros();
    b.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
    b.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(d)));
    if rotations {
        b.fixed_view_mut::<3, 3>(3, 3).copy_from(&Mat3::identity());
    }
    b
}

/// A weighted graph in CSR form: every node's neighbours (itself excluded) with the
/// strength of the connection.
struct Graph {
    start: Vec<usize>,
    edges: Vec<(u32, f64)>,
}

impl Graph {
    /// The block graph of `a`: an edge per stored off-diagonal block A_ij with
    /// ‖A_ij‖ ≥ θ·√(‖A_ii‖‖A_jj‖), weighted by ‖A_ij‖² (Frobenius norms).
    fn of_matrix(a: &BlockSparse, theta: f64) -> Graph {
        let dn: Vec<f64> = (0..a.rows())
            .into_par_iter()
            .map(|i| a.diagonal(i).norm())
            .collect();
        let rows: Vec<Vec<(u32, f64)>> = (0..a.rows())
            .into_par_iter()
            .map(|i| {
                a.row(i)
                    .filter(|(j, b)| *j != i && b.norm_squared() >= theta * theta * dn[i] * dn[*j])
                    .map(|(j, b)| (j as u32, b.norm_squared()))
                    .collect()
            })
            .collect();
        Graph::from_rows(rows)
    }

    /// From every node's neighbour list.
    fn from_rows(rows: Vec<Vec<(u32, f64)>>) -> Graph {
        let mut start = Vec::with_capacity(rows.len() + 1);
        start.push(0);
        let mut edges = Vec::new();
        for r in rows {
            edges.extend(r);
            start.push(edges.len());
        }
        Graph { start, edges }
    }

    /// Number of nodes.
    fn nodes(&self) -> usize {
        self.start.len() - 1
    }

    /// The neighbours of node `i` with their strengths.
    fn row(&self, i: usize) -> &[(u32, f64)] {
        &self.edges[self.start[i]..self.start[i + 1]]
    }
}

/// Greedy aggregation of a graph, in node order: (aggregate of every node, number of
/// aggregates). Phase 1: a node whose neighbours are all free roots an aggregate of itself
/// and them; phase 2: every other node joins the phase-1 aggregate of the neighbour it is
/// most strongly connected to (the first on a tie); phase 3: an isolated node is an
/// aggregate of its own (Vaněk, Mandel & Brezina 1996, Sec. 4).
fn aggregate(graph: &Graph) -> (Vec<u32>, usize) {
    const FREE: u32 = u32::MAX;
    let n = graph.nodes();
    let mut agg = vec![FREE; n];
    let mut count = 0u32;
    for i in 0..n {
        let row = graph.row(i);
        if agg[i] != FREE || row.is_empty() || row.iter().any(|(j, _)| agg[*j as usize] != FREE) {
            continue;
        }
        agg[i] = count;
        for (j, _) in row {
            agg[*j as usize] = count;
        }
        count += 1;
    }
    let phase1 = agg.clone();
    for (i, gi) in agg.iter_mut().enumerate() {
        if *gi != FREE {
            continue;
        }
        let mut best: Option<(f64, u32)> = None;
        for (j, w) in graph.row(i) {
            let g = phase1[*j as usize];
            if g != FREE && !matches!(best, Some((bw, _)) if *w <= bw) {
                best = Some((*w, g));
            }
        }
        if let Some((_, g)) = best {
            *gi = g;
        }
    }
    for g in agg.iter_mut() {
        if *g == FREE {
            *g = count;
            count += 1;
        }
    }
    (agg, count as usize)
}

/// Members of every aggregate (CSR: start, nodes in increasing order).
fn members(agg: &[u32], n_agg: usize) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; n_agg + 1];
    for &g in agg {
        start[g as usize + 1] += 1;
    }
    for a in 0..n_agg {
        start[a + 1] += start[a];
    }
    let mut fill = start.clone();
    let mut nodes = vec![0u32; agg.len()];
    for (p, &g) in agg.iter().enumerate() {
        nodes[fill[g as usize]] = p as u32;
        fill[g as usize] += 1;
    }
    (start, nodes)
}

/// The fine level's near-null space: the rigid modes of every node about its aggregate's
/// centre (minimum-image arms from the aggregate's first node, then from their mean).
fn rigid_near_null(
    positions: &[Vec3],
    cell: &PeriodicCell,
    rotations: bool,
    (start, nodes): (&[usize], &[u32]),
) -> Vec<Block6> {
    let arms: Vec<Vec<(u32, Vec3)>> = (0..start.len() - 1)
        .into_par_iter()
        .map(|a| {
            let group = &nodes[start[a]..start[a + 1]];
            let x0 = positions[group[0] as usize];
            let offsets: Vec<Vec3> = group
                .iter()
                .map(|&p| cell.minimum_image(positions[p as usize] - x0).0)
                .collect();
            let centre = offsets.iter().fold(Vec3::zeros(), |s, o| s + o) / group.len() as f64;
            group
                .iter()
                .zip(offsets)
                .map(|(&p, o)| (p, o - centre))
                .collect()
        })
        .collect();
    let mut b = vec![Block6::zeros(); positions.len()];
    for (p, d) in arms.into_iter().flatten() {
        b[p as usize] = rigid_modes(&d, rotations);
    }
    b
}

/// Tentative prolongator of every node (its rows of the aggregate's orthonormalised
/// near-null vectors) and every aggregate's R (the coarse near-null space), by modified
/// Gram–Schmidt (twice) per aggregate: B restricted to an aggregate = Q R.
fn tentative(b: &[Block6], (start, nodes): (&[usize], &[u32])) -> (Vec<Block6>, Vec<Block6>) {
    let per_agg: Vec<(Vec<Block6>, Block6)> = (0..start.len() - 1)
        .into_par_iter()
        .map(|a| {
            let group = &nodes[start[a]..start[a + 1]];
            let mut q: Vec<Block6> = group.iter().map(|&p| b[p as usize]).collect();
            let mut r = Block6::zeros();
            let dot = |q: &[Block6], i: usize, j: usize| -> f64 {
                q.iter().map(|m| m.column(i).dot(&m.column(j))).sum()
            };
            for k in 0..6 {
                let original = dot(&q, k, k).sqrt();
                for _ in 0..2 {
                    for j in 0..k {
                        let d = dot(&q, j, k);
                        r[(j, k)] += d;
                        for m in q.iter_mut() {
                            let cj = m.column(j).into_owned();
                            m.column_mut(k).axpy(-d, &cj, 1.0);
                        }
                    }
                }
                let norm = dot(&q, k, k).sqrt();
                if norm > RANK_TOLERANCE * original && norm > 0.0 {
                    r[(k, k)] = norm;
                    for m in q.iter_mut() {
                        m.column_mut(k).scale_mut(1.0 / norm);
                    }
                } else {
                    for m in q.iter_mut() {
                        m.column_mut(k).fill(0.0);
                    }
                }
            }
            (q, r)
        })
        .collect();
    let mut p0 = vec![Block6::zeros(); b.len()];
    let mut coarse_b = Vec::with_capacity(per_agg.len());
    for (a, (q, r)) in per_agg.into_iter().enumerate() {
        for (&p, qp) in nodes[start[a]..start[a + 1]].iter().zip(q) {
            p0[p as usize] = qp;
        }
        coarse_b.push(r);
    }
    (p0, coarse_b)
}

/// splitmix64 of `i` as a number in [−0.5, 0.5): a fixed start vector.
fn pseudo_random(i: u64) -> f64 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// Σ_p a_p[:, 0] · b_p[:, 0] in fixed chunks (deterministic on any thread count).
fn dot0(a: &[Block6], b: &[Block6]) -> f64 {
    const CH: usize = 2048;
    let parts: Vec<f64> = a
        .par_chunks(CH)
        .zip(b.par_chunks(CH))
        .map(|(ca, cb)| {
            ca.iter()
                .zip(cb)
                .map(|(x, y)| x.column(0).dot(&y.column(0)))
                .sum()
        })
        .collect();
    parts.into_iter().sum()
}

/// ρ(D⁻¹A) by power iteration on one column: the D-norm ratio ‖D⁻¹Av‖_D/‖v‖_D, which
/// increases towards ρ (D⁻¹A is self-adjoint in the D inner product).
fn spectral_radius(a: &BlockSparse, diag: &[Block6], dinv: &[Block6]) -> f64 {
    let n = a.rows();
    let mut v: Vec<Block6> = (0..n)
        .map(|p| {
            let mut b = Block6::zeros();
            for k in 0..6 {
                b[(k, 0)] = pseudo_random((6 * p + k) as u64);
            }
            // In the range of D⁻¹ (no component along a node's null directions).
            mul6_cols(&dinv[p], &mul6_cols(&diag[p], &b, 1), 1)
        })
        .collect();
    let mut av = vec![Block6::zeros(); n];
    let mut dv = vec![Block6::zeros(); n];
    let mut rho = 0.0f64;
    for _ in 0..POWER_ITERATIONS {
        let dn = |v: &[Block6], dv: &mut [Block6]| {
            dv.par_iter_mut()
                .zip(v.par_iter())
                .zip(diag.par_iter())
                .for_each(|((o, x), d)| *o = mul6_cols(d, x, 1));
        };
        dn(&v, &mut dv);
        let vdv = dot0(&v, &dv);
        if vdv <= 0.0 {
            break;
        }
        a.apply_cols(&v, &mut av, 1);
        // y = D⁻¹ A v; ‖y‖²_D = yᵀ D y.
        v.par_iter_mut()
            .zip(av.par_iter())
            .zip(dinv.par_iter())
            .for_each(|((y, w), di)| *y = mul6_cols(di, w, 1));
        dn(&v, &mut dv);
        let ydy = dot0(&v, &dv);
        if ydy <= 0.0 {
            break;
        }
        rho = (ydy / vdv).sqrt();
        let s = 1.0 / ydy.sqrt();
        v.par_iter_mut().for_each(|y| {
            for i in 0..6 {
                y[(i, 0)] *= s;
            }
        });
    }
    rho
}

/// The smoothed prolongator P = (I − ω D⁻¹A) P₀ by rows (columns = aggregates, sorted).
fn smoothed_prolongator(
    a: &BlockSparse,
    dinv: &[Block6],
    omega: f64,
    agg: &[u32],
    p0: &[Block6],
) -> BlockRows {
    let rows: Vec<Vec<(u32, Block6)>> = (0..a.rows())
        .into_par_iter()
        .map(|p| {
            let mut acc: Vec<(u32, Block6)> = Vec::new();
            for (q, apq) in a.row(p) {
                let g = agg[q];
                let i = match acc.iter().position(|(c, _)| *c == g) {
                    Some(i) => i,
                    None => {
                        acc.push((g, Block6::zeros()));
                        acc.len() - 1
                    }
                };
                mul_add6(&mut acc[i].1, apq, &p0[q]);
            }
            acc.sort_by_key(|(c, _)| *c);
            let own = agg[p];
            for (c, blk) in acc.iter_mut() {
                let mut s = Block6::zeros();
                mul_add6(&mut s, &dinv[p], blk);
                *blk = if *c == own {
                    p0[p] - s * omega
                } else {
                    -s * omega
                };
            }
            acc
        })
        .collect();
    BlockRows::from_rows(rows)
}

/// The Galerkin coarse matrix PᵀAP (`pt` = Pᵀ by coarse rows), in a fixed order.
fn galerkin(a: &BlockSparse, p: &BlockRows, pt: &BlockRows) -> BlockSparse {
    // A P by fine rows.
    let ap_rows: Vec<Vec<(u32, Block6)>> = (0..a.rows())
        .into_par_iter()
        .map(|i| {
            let mut acc: Vec<(u32, Block6)> = Vec::new();
            for (q, aiq) in a.row(i) {
                for (c, pq) in p.row(q) {
                    let k = match acc.iter().position(|(x, _)| x == c) {
                        Some(k) => k,
                        None => {
                            acc.push((*c, Block6::zeros()));
                            acc.len() - 1
                        }
                    };
                    mul_add6(&mut acc[k].1, aiq, pq);
                }
            }
            acc.sort_by_key(|(c, _)| *c);
            acc
        })
        .collect();
    let ap = BlockRows::from_rows(ap_rows);
    let rows: Vec<Vec<(u32, Block6)>> = (0..pt.rows())
        .into_par_iter()
        .map(|g| {
            let mut acc: BTreeMap<u32, Block6> = BTreeMap::new();
            for (i, pti) in pt.row(g) {
                for (c, apic) in ap.row(*i as usize) {
                    mul_add6(acc.entry(*c).or_insert_with(Block6::zeros), pti, apic);
                }
            }
            acc.into_iter().collect()
        })
        .collect();
    BlockSparse::from_rows(rows)
}

/// One level's damped block-Jacobi smoother.
struct Smoother {
    /// Pseudo-inverses of the diagonal blocks.
    dinv: Vec<Block6>,
    /// Damping 4/(3ρ(D⁻¹A)).
    omega: f64,
}

/// Transfer between a level and the next coarser one.
struct Transfer {
    /// P by fine rows.
    p: BlockRows,
    /// Pᵀ by coarse rows.
    pt: BlockRows,
}

/// Work vectors of one V-cycle: right-hand side, iterate and residual on every level.
struct Work {
    b: Vec<Vec<Block6>>,
    x: Vec<Vec<Block6>>,
    r: Vec<Vec<Block6>>,
}

/// The multigrid hierarchy of a stiffness matrix (borrowed: the finest level's).
pub struct Amg<'a> {
    fine: &'a BlockSparse,
    /// Matrices of levels 1, 2, … (level 0 is `fine`).
    coarse: Vec<BlockSparse>,
    /// Smoother of every level (the coarsest too, used when it cannot be factored).
    smoothers: Vec<Smoother>,
    /// Transfers between level l and l + 1.
    transfers: Vec<Transfer>,
    /// Direct solve of the coarsest level; `None` when it cannot be factored (a global
    /// mechanism): then smoothing sweeps only (the preconditioner is weaker, the answer the
    /// same).
    direct: Option<BlockCholesky>,
    work: Mutex<Option<Work>>,
}

impl<'a> Amg<'a> {
    /// The hierarchy of `k` (rows = active particles at `positions` in `cell`; `rotations`:
    /// whether the particles' spins are unknowns).
    pub fn new(
        k: &'a BlockSparse,
        positions: &[Vec3],
        cell: &PeriodicCell,
        rotations: bool,
    ) -> Result<Amg<'a>> {
        Self::with_coarse_nodes(k, positions, cell, rotations, COARSE_NODES)
    }

    /// The hierarchy of the active network's `k`: row i is particle `original[i]` of
    /// `packing` (its periodic cell gives the minimum-image arms).
    pub fn of_network(
        k: &'a BlockSparse,
        packing: &crate::packing::Packing,
        original: &[u32],
        rotations: bool,
    ) -> Result<Amg<'a>> {
        let cell = packing
            .cell
            .ok_or_else(|| Error::Invalid("multigrid preconditioner: no periodic cell".into()))?;
        let positions: Vec<Vec3> = original
            .iter()
            .map(|&p| packing.positions[p as usize])
            .collect();
        Self::new(k, &positions, &cell, rotations)
    }

    /// [`Self::new`] coarsening down to at most `coarse_nodes` nodes.
    pub fn with_coarse_nodes(
        k: &'a BlockSparse,
        positions: &[Vec3],
        cell: &PeriodicCell,
        rotations: bool,
        coarse_nodes: usize,
    ) -> Result<Amg<'a>> {
        let m = k.rows();
        if positions.len() != m || m == 0 {
            return Err(Error::Invalid(format!(
                "multigrid preconditioner: {} positions for {m} particles",
                positions.len()
            )));
        }
        let mut coarse: Vec<BlockSparse> = Vec::new();
        let mut smoothers = Vec::new();
        let mut transfers = Vec::new();
        let mut near_null: Option<Vec<Block6>> = None;
        loop {
            let a = coarse.last().unwrap_or(k);
            let n = a.rows();
            let diag: Vec<Block6> = (0..n).into_par_iter().map(|p| a.diagonal(p)).collect();
            let dinv: Vec<Block6> = diag.par_iter().map(|d| pinv_psd(d).0).collect();
            let rho = spectral_radius(a, &diag, &dinv);
            let omega = if rho > 0.0 { 4.0 / (3.0 * rho) } else { 0.0 };
            let last = n <= coarse_nodes || smoothers.len() + 1 >= MAX_LEVELS;
            if last {
                smoothers.push(Smoother { dinv, omega });
                break;
            }
            let theta = if smoothers.is_empty() {
                0.0
            } else {
                COARSE_THETA
            };
            let (agg, n_agg) = aggregate(&Graph::of_matrix(a, theta));
            if n_agg * 10 > n * 9 {
                // Coarsening stalls: this level is the coarsest.
                smoothers.push(Smoother { dinv, omega });
                break;
            }
            let groups = members(&agg, n_agg);
            let b = match near_null.take() {
                Some(b) => b,
                None => rigid_near_null(positions, cell, rotations, (&groups.0, &groups.1)),
            };
            let (p0, coarse_b) = tentative(&b, (&groups.0, &groups.1));
            drop(b);
            let p = smoothed_prolongator(a, &dinv, omega, &agg, &p0);
            drop(p0);
            let pt = p.transpose(n_agg);
            let ac = galerkin(a, &p, &pt);
            smoothers.push(Smoother { dinv, omega });
            transfers.push(Transfer { p, pt });
            coarse.push(ac);
            near_null = Some(coarse_b);
        }
        let direct = BlockCholesky::factor(coarse.last().unwrap_or(k)).ok();
        Ok(Amg {
            fine: k,
            coarse,
            smoothers,
            transfers,
            direct,
            work: Mutex::new(None),
        })
    }

    /// Number of levels (the finest included).
    pub fn levels(&self) -> usize {
        self.smoothers.len()
    }

    /// Block rows of every level, finest first.
    pub fn level_rows(&self) -> Vec<usize> {
        (0..self.levels()).map(|l| self.matrix(l).rows()).collect()
    }

    /// Memory held by the coarse matrices and the transfers (bytes).
    pub fn bytes(&self) -> usize {
        self.coarse.iter().map(BlockSparse::bytes).sum::<usize>()
            + self
                .transfers
                .iter()
                .map(|t| t.p.bytes() + t.pt.bytes())
                .sum::<usize>()
            + self
                .smoothers
                .iter()
                .map(|s| s.dinv.len() * std::mem::size_of::<Block6>())
                .sum::<usize>()
    }

    /// The matrix of level `l`.
    fn matrix(&self, l: usize) -> &BlockSparse {
        if l == 0 {
            self.fine
        } else {
            &self.coarse[l - 1]
        }
    }

    /// z = one V-cycle applied to r, on the first `cols` load cases (the others of z zero).
    pub fn apply_cols(&self, r: &[Block6], z: &mut [Block6], cols: usize) -> Result<()> {
        let mut guard = self
            .work
            .lock()
            .map_err(|_| Error::Invalid("multigrid preconditioner: work space poisoned".into()))?;
        let work = guard.get_or_insert_with(|| {
            let sizes: Vec<usize> = (0..self.levels()).map(|l| self.matrix(l).rows()).collect();
            let vecs = || sizes.iter().map(|&n| vec![Block6::zeros(); n]).collect();
            Work {
                b: vecs(),
                x: vecs(),
                r: vecs(),
            }
        });
        work.b[0].copy_from_slice(r);
        self.cycle(work, cols)?;
        z.copy_from_slice(&work.x[0]);
        Ok(())
    }

    /// x_l = ω D⁻¹ b_l (the first sweep from zero), then `SWEEPS − 1` more.
    fn pre_smooth(&self, l: usize, work: &mut Work, cols: usize) {
        let s = &self.smoothers[l];
        work.x[l]
            .par_iter_mut()
            .zip(work.b[l].par_iter())
            .zip(s.dinv.par_iter())
            .for_each(|((x, b), d)| *x = mul6_cols(d, b, cols) * s.omega);
        for _ in 1..SWEEPS {
            self.sweep(l, work, cols);
        }
    }

    /// r_l = b_l − A_l x_l.
    fn residual(&self, l: usize, work: &mut Work, cols: usize) {
        let a = self.matrix(l);
        a.apply_cols(&work.x[l], &mut work.r[l], cols);
        work.r[l]
            .par_iter_mut()
            .zip(work.b[l].par_iter())
            .for_each(|(r, b)| *r = b - *r);
    }

    /// One damped block-Jacobi sweep x_l += ω D⁻¹ (b_l − A_l x_l).
    fn sweep(&self, l: usize, work: &mut Work, cols: usize) {
        self.residual(l, work, cols);
        let s = &self.smoothers[l];
        work.x[l]
            .par_iter_mut()
            .zip(work.r[l].par_iter())
            .zip(s.dinv.par_iter())
            .for_each(|((x, r), d)| *x += mul6_cols(d, r, cols) * s.omega);
    }

    /// One V-cycle: x₀ ≈ A₀⁻¹ b₀.
    fn cycle(&self, work: &mut Work, cols: usize) -> Result<()> {
        let last = self.levels() - 1;
        for l in 0..last {
            self.pre_smooth(l, work, cols);
            self.residual(l, work, cols);
            let (fine, coarse) = work.b.split_at_mut(l + 1);
            let _ = fine;
            self.transfers[l]
                .pt
                .apply(&work.r[l], &mut coarse[0], cols, false);
        }
        match &self.direct {
            Some(chol) => {
                let x = chol.solve(&work.b[last])?;
                work.x[last].copy_from_slice(&x);
            }
            None => {
                self.pre_smooth(last, work, cols);
                for _ in 0..SWEEPS {
                    self.sweep(last, work, cols);
                }
            }
        }
        for l in (0..last).rev() {
            let (fine, coarse) = work.x.split_at_mut(l + 1);
            self.transfers[l]
                .p
                .apply(&coarse[0], &mut fine[l], cols, true);
            for _ in 0..SWEEPS {
                self.sweep(l, work, cols);
            }
        }
        Ok(())
    }
}
