//! Two-level preconditioner for the relaxed CG: block-Jacobi on the particles plus an exact
//! coarse solve on the rigid-body motions of spatial clusters of particles (plain
//! aggregation with six rigid modes per aggregate, coarse system factored by
//! [`super::cholesky::BlockCholesky`]).
//!
//! Balancing (Neumann–Neumann) form, SPD for any SPD smoother M:
//! z = Q r + (I − QK) M (I − KQ) r with Q = P (PᵀKP)⁺ Pᵀ (Mandel 1993; Tang et al. 2009,
//! "A-DEF2/BNN"). The coarse space removes the slow long-wavelength modes that make the
//! block-Jacobi iteration count grow with N, so iterations stay nearly flat.

use super::cholesky::BlockCholesky;
use super::fused::{self, CaseRows};
use super::network::Block6;
use super::sparse::{
    add_scaled_cols, avx2, direction_cols, mul6_cols, mul_add6_cols, mul_add6_transposed_cols,
    BlockRows, BlockSparse, Cols,
};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Skew matrix [a]× with [a]× v = a × v.
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Grid cell of every position and its arm from the cell's centre (wrapped into the box like
/// the index): cells of about `per_aggregate` positions each, at most one per position along
/// an axis (a far-away particle in a free cluster, a bounding box of 1e12 × 1 × 1, must not
/// ask for a dense grid of cells).
fn grid_cells(
    positions: &[Vec3],
    box_lengths: Vec3,
    per_aggregate: usize,
) -> ([usize; 3], Vec<([usize; 3], Vec3)>) {
    let m = positions.len();
    let volume = box_lengths.x * box_lengths.y * box_lengths.z;
    let h = (volume * per_aggregate as f64 / m as f64).cbrt();
    let cells: [usize; 3] =
        std::array::from_fn(|a| ((box_lengths[a] / h).round().min(m as f64) as usize).max(1));
    let size = Vec3::from_fn(|a, _| box_lengths[a] / cells[a] as f64);
    let cell_of = |x: &Vec3| -> ([usize; 3], Vec3) {
        let mut idx = [0usize; 3];
        let mut centre = Vec3::zeros();
        for a in 0..3 {
            let w = x[a].rem_euclid(box_lengths[a]);
            let i = ((w / size[a]) as usize).min(cells[a] - 1);
            idx[a] = i;
            centre[a] = (i as f64 + 0.5) * size[a];
            // Arm from the centre, with the position wrapped like the cell index.
            centre[a] = w - centre[a];
        }
        (idx, centre)
    };
    (cells, positions.par_iter().map(cell_of).collect())
}

/// Nested-dissection elimination order of the occupied cells (`occupied`, sorted; cell
/// (i, j, k) is aggregate `occupied.binary_search`) of a periodic grid of `cells`: the two
/// levels' coarse matrix couples only neighbouring cells (27-point stencil, bonds shorter
/// than a cell), so plane separators, eliminated after the two halves they separate, bound
/// the fill (George 1973); AMD on the same matrix kept 2.1× the factor's entries (1,000,000
/// particles, 4,096 cells: 104.0 M against 48.7 M). `None` when the grid holds many more
/// cells than are occupied. Any order is exact; this one only makes the factor smaller and
/// faster (a box that is not periodic, the specimen's, is cut as if it were: still exact).
fn nested_dissection(cells: [usize; 3], occupied: &[[usize; 3]]) -> Option<Vec<u32>> {
    let total = cells[0].checked_mul(cells[1])?.checked_mul(cells[2])?;
    if total > 8 * occupied.len() {
        return None;
    }
    let mut id = vec![u32::MAX; total];
    for (a, c) in occupied.iter().enumerate() {
        id[(c[0] * cells[1] + c[1]) * cells[2] + c[2]] = a as u32;
    }
    let mut order = Vec::with_capacity(occupied.len());
    dissect(
        &Grid { cells, id: &id },
        [0; 3],
        cells,
        [true; 3],
        &mut order,
    );
    (order.len() == occupied.len()).then_some(order)
}

/// The occupied cells of a grid, by cell index (`u32::MAX`: empty).
struct Grid<'a> {
    cells: [usize; 3],
    id: &'a [u32],
}

impl Grid<'_> {
    /// The occupied cells of the box `len` cells from `lo` (wrapped), in (x, y, z) order.
    fn emit(&self, lo: [usize; 3], len: [usize; 3], order: &mut Vec<u32>) {
        let c = self.cells;
        for i in 0..len[0] {
            for j in 0..len[1] {
                for k in 0..len[2] {
                    let x = [(lo[0] + i) % c[0], (lo[1] + j) % c[1], (lo[2] + k) % c[2]];
                    let a = self.id[(x[0] * c[1] + x[1]) * c[2] + x[2]];
                    if a != u32::MAX {
                        order.push(a);
                    }
                }
            }
        }
    }
}

/// [`nested_dissection`] of the box `len` cells from `lo`, periodic along the axes marked:
/// cut across the axis with the smallest separator (two planes across a periodic axis, one
/// across another), the halves first, then the separating planes.
fn dissect(
    grid: &Grid,
    lo: [usize; 3],
    len: [usize; 3],
    periodic: [bool; 3],
    order: &mut Vec<u32>,
) {
    let volume = len[0] * len[1] * len[2];
    let cut = (0..3)
        .filter(|&a| len[a] >= if periodic[a] { 4 } else { 3 })
        .min_by_key(|&a| volume / len[a] * if periodic[a] { 2 } else { 1 });
    let Some(a) = cut.filter(|_| volume > 16) else {
        return grid.emit(lo, len, order);
    };
    let h = len[a] / 2;
    // (first cell, length) along axis a of the halves and of the separating planes.
    let (halves, planes) = if periodic[a] {
        (
            [(lo[a] + 1, h - 1), (lo[a] + h + 1, len[a] - h - 1)],
            vec![lo[a], lo[a] + h],
        )
    } else {
        (
            [(lo[a], h), (lo[a] + h + 1, len[a] - h - 1)],
            vec![lo[a] + h],
        )
    };
    let along = |start: usize, n: usize| {
        let (mut l, mut s) = (lo, len);
        l[a] = start;
        s[a] = n;
        (l, s)
    };
    let mut open = periodic;
    open[a] = false;
    for (start, n) in halves {
        let (l, s) = along(start, n);
        dissect(grid, l, s, open, order);
    }
    for start in planes {
        let (l, s) = along(start, 1);
        grid.emit(l, s, order);
    }
}

/// Rigid-mode prolongation of a node at arm `d` from its aggregate's centre: u = t + θ × d,
/// and ω = θ when the nodes rotate.
fn rigid_modes(d: &Vec3, rotations: bool) -> Block6 {
    let mut p = Block6::zeros();
    p.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
    p.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(d)));
    if rotations {
        p.fixed_view_mut::<3, 3>(3, 3).copy_from(&Mat3::identity());
    }
    p
}

/// Counting sort of `(group, row, value)` items into CSR by group (`n_groups` groups),
/// keeping the items' order within a group: every group's start and its (row, value)s.
fn group_by<T: Copy>(
    n_groups: usize,
    items: impl Iterator<Item = (u32, u32, T)> + Clone,
    zero: T,
) -> (Vec<usize>, Vec<(u32, T)>) {
    let mut start = vec![0usize; n_groups + 1];
    for (g, _, _) in items.clone() {
        start[g as usize + 1] += 1;
    }
    for a in 0..n_groups {
        start[a + 1] += start[a];
    }
    let mut fill = start.clone();
    let mut out = vec![(0u32, zero); start[n_groups]];
    for (g, row, v) in items {
        out[fill[g as usize]] = (row, v);
        fill[g as usize] += 1;
    }
    (start, out)
}

/// K P, one short row per fine node (CSR: start, (aggregate, Σ_q∈aggregate K_pq P_q)), in
/// a fixed order: the row's columns in order, aggregates sorted; `extra` rows (another
/// operator's K P, e.g. a many-body term applied in factored form) added after k's.
fn k_times_p(
    k: &impl BlockRows,
    aggregate: &[u32],
    (layers, prolongation): (usize, &[Block6]),
    extra: Option<&[Vec<(u32, Block6)>]>,
) -> (Vec<usize>, Vec<(u32, Block6)>) {
    let kp_rows: Vec<Vec<(u32, Block6)>> = (0..k.rows())
        .into_par_iter()
        .map(|p| {
            let mut acc: Vec<(u32, Block6)> = Vec::new();
            k.each_in_row(p, |q, kpq| {
                for l in 0..layers {
                    let b = aggregate[q] * layers as u32 + l as u32;
                    let v = times_prolongation(kpq, &prolongation[q * layers + l]);
                    match acc.iter_mut().find(|(a, _)| *a == b) {
                        Some((_, s)) => *s += v,
                        None => acc.push((b, v)),
                    }
                }
            });
            for (b, v) in extra.map_or(&[][..], |e| &e[p][..]) {
                match acc.iter_mut().find(|(a, _)| a == b) {
                    Some((_, s)) => *s += v,
                    None => acc.push((*b, *v)),
                }
            }
            acc.sort_by_key(|(a, _)| *a);
            acc
        })
        .collect();
    let mut kp_start = Vec::with_capacity(k.rows() + 1);
    kp_start.push(0);
    let mut kp = Vec::new();
    for row in kp_rows {
        kp.extend(row);
        kp_start.push(kp.len());
    }
    (kp_start, kp)
}

/// K_pq P_q: for a rigid-mode block P_q = [[I, T], [0, I]] ([`rigid_modes`]) as
/// [K_pq[:, :3], K_pq[:, :3] T + K_pq[:, 3:]] (a quarter of the general product's work),
/// else the general product.
fn times_prolongation(k: &Block6, p: &Block6) -> Block6 {
    let rigid = p.fixed_view::<3, 3>(0, 0) == Mat3::identity()
        && p.fixed_view::<3, 3>(3, 0).iter().all(|&x| x == 0.0)
        && p.fixed_view::<3, 3>(3, 3) == Mat3::identity();
    if !rigid {
        return k * p;
    }
    let mut out = *k;
    let turn = k.fixed_view::<6, 3>(0, 0) * p.fixed_view::<3, 3>(0, 3);
    let mut right = out.fixed_view_mut::<6, 3>(0, 3);
    right += turn;
    out
}

/// Coarse matrix PᵀKP, one block row per coarse node (`layers` per aggregate, `members`:
/// CSR of every aggregate's nodes), from the rows of K P (`kp`: CSR by fine node), in a
/// fixed summation order.
fn coarse_matrix(
    (layers, prolongation): (usize, &[Block6]),
    (start, nodes): (&[usize], &[u32]),
    (kp_start, kp): (&[usize], &[(u32, Block6)]),
) -> BlockSparse {
    let rows: Vec<Vec<(u32, Block6)>> = (0..(start.len() - 1) * layers)
        .into_par_iter()
        .map(|c| {
            let (a, l) = (c / layers, c % layers);
            let mut acc: BTreeMap<u32, Block6> = BTreeMap::new();
            for &p in &nodes[start[a]..start[a + 1]] {
                let p = p as usize;
                let ppt = prolongation[p * layers + l].transpose();
                for (b, kpb) in &kp[kp_start[p]..kp_start[p + 1]] {
                    *acc.entry(*b).or_insert_with(Block6::zeros) += ppt * kpb;
                }
            }
            acc.into_iter().collect()
        })
        .collect();
    BlockSparse::from_rows(rows)
}

/// A further coarse node per aggregate: the prolongation of a node at arm d / h (h the cells'
/// mean edge) in an aggregate of the given size ([`TwoLevel::with_layers`]).
pub(crate) type CoarseLayer<'a> = &'a (dyn Fn(&Vec3, usize) -> Block6 + Sync);

/// The prescribed DOFs of a held structure ([`TwoLevel::held`]) and the node that is its
/// own aggregate (the specimen's period changes), if any.
pub(crate) struct HeldSpace<'a> {
    /// Per node, its prescribed DOFs (eliminated: their rows and columns of K hold only the
    /// diagonal).
    pub held: &'a [[bool; 6]],
    /// A node whose six DOFs are not a particle's motion: an aggregate of its own.
    pub apart: Option<usize>,
    /// The unit of the spins: the unknowns hold `spin_scale` × ω (the specimen's R̄ ω), so a
    /// rigid turn θ gives them `spin_scale` × θ.
    pub spin_scale: f64,
}

/// The coarse space and its factored coarse matrix.
pub struct TwoLevel {
    /// Aggregate of every node.
    aggregate: Vec<u32>,
    /// Coarse nodes per aggregate (1: the rigid modes; more with [`Self::with_layers`]).
    layers: usize,
    /// Prolongation of every node and layer (`layers` blocks per node): fine DOFs (u, ω) =
    /// Σ_l P_pl x_(aggregate, l); layer 0 the rigid modes u = t + θ × d, ω = θ
    /// (d = position − aggregate centre).
    prolongation: Vec<Block6>,
    /// Nodes of every aggregate (CSR), in increasing order, for fixed-order restriction.
    start: Vec<usize>,
    nodes: Vec<u32>,
    coarse: BlockCholesky,
    /// K P by fine rows (CSR): (aggregate, Σ_q∈aggregate K_pq P_q); few blocks per row, so
    /// K Q r and Qᵀ-side products cost far less than a product with K.
    kp_start: Vec<usize>,
    kp: Vec<(u32, Block6)>,
    /// (KP)ᵀ w by streaming: every [`RESTRICT_ROWS`] fine rows sum their blocks (read
    /// transposed, [`mul_add6_transposed_cols`]) into partial sums, one per coarse node the
    /// rows touch (`slot`: each block's partial within its chunk), which every coarse node
    /// then adds in chunk order (`parts`: CSR by coarse node of (chunk, slot)). Reading the
    /// blocks by coarse node instead jumped through K P and w: at 300,000 particles it took
    /// 40 % of a product with K (issue 35).
    slot: Vec<u32>,
    chunk_slots: Vec<u32>,
    parts_start: Vec<usize>,
    parts: Vec<(u32, u32)>,
}

/// Fine rows per chunk of the streamed restriction ([`TwoLevel::coarse_of_k_cols`]): fixed,
/// so the sums are the same on any thread count.
const RESTRICT_ROWS: usize = 8192;

/// Fine rows per task of the prolongation ([`TwoLevel::deflate_cols`]).
const PROLONG_ROWS: usize = 2048;

/// The restriction's chunks of `RESTRICT_ROWS` rows of K P (CSR `kp_start`, `kp`): per
/// block its slot in its chunk's partial sums, per chunk its number of slots, and per
/// coarse node (of `n_coarse`) its (chunk, slot)s in chunk order.
#[allow(clippy::type_complexity)]
fn restriction_chunks(
    kp_start: &[usize],
    kp: &[(u32, Block6)],
    n_coarse: usize,
) -> (Vec<u32>, Vec<u32>, Vec<usize>, Vec<(u32, u32)>) {
    let m = kp_start.len() - 1;
    let chunks: Vec<(Vec<u32>, Vec<u32>)> = (0..m.div_ceil(RESTRICT_ROWS))
        .into_par_iter()
        .map(|c| {
            let rows = c * RESTRICT_ROWS..((c + 1) * RESTRICT_ROWS).min(m);
            let blocks = &kp[kp_start[rows.start]..kp_start[rows.end]];
            let mut nodes: Vec<u32> = blocks.iter().map(|(b, _)| *b).collect();
            nodes.sort_unstable();
            nodes.dedup();
            let slots = blocks
                .iter()
                .map(|(b, _)| nodes.binary_search(b).expect("listed above") as u32)
                .collect();
            (nodes, slots)
        })
        .collect();
    let chunk_slots = chunks.iter().map(|(n, _)| n.len() as u32).collect();
    let items = chunks
        .iter()
        .enumerate()
        .flat_map(|(c, (nodes, _))| (0u32..).zip(nodes).map(move |(at, &b)| (b, c as u32, at)));
    let (parts_start, parts) = group_by(n_coarse, items, 0u32);
    let slot = chunks.into_iter().flat_map(|(_, s)| s).collect();
    (slot, chunk_slots, parts_start, parts)
}

impl TwoLevel {
    /// Aggregates = cells of a regular grid over the periodic box holding about
    /// `per_aggregate` nodes each; `positions` are the nodes' centres, `box_lengths` the cell.
    pub fn new(
        k: &BlockSparse,
        positions: &[Vec3],
        box_lengths: Vec3,
        rotations: bool,
        per_aggregate: usize,
    ) -> Result<TwoLevel> {
        Self::with_extra(
            k,
            positions,
            box_lengths,
            rotations,
            per_aggregate,
            |_, _| None,
        )
    }

    /// [`Self::new`] for the operator K = `k` + K', K' known only through its products with
    /// the prolongation: `extra(aggregate, prolongation)` gives, per fine node, K'P's blocks
    /// (aggregate, Σ_q∈aggregate K'_pq P_q) sorted by aggregate (the relaxed solve's
    /// many-body term, applied in factored form and never assembled).
    pub(crate) fn with_extra(
        k: &impl BlockRows,
        positions: &[Vec3],
        box_lengths: Vec3,
        rotations: bool,
        per_aggregate: usize,
        extra: impl FnMut(&[u32], &[Block6]) -> Option<Vec<Vec<(u32, Block6)>>>,
    ) -> Result<TwoLevel> {
        Self::with_layers(
            k,
            positions,
            box_lengths,
            (rotations, per_aggregate),
            &[],
            extra,
        )
    }

    /// [`Self::with_extra`] with further coarse nodes per aggregate beyond the rigid modes:
    /// layer l + 1 prolongs node p by `more[l](d_p / h, members)` (d_p its arm from the
    /// aggregate's centre, h the cells' mean edge, `members` the aggregate's size); `extra` is
    /// called once per layer with that layer's coarse node of every fine node.
    pub(crate) fn with_layers(
        k: &impl BlockRows,
        positions: &[Vec3],
        box_lengths: Vec3,
        (rotations, per_aggregate): (bool, usize),
        more: &[CoarseLayer],
        extra: impl FnMut(&[u32], &[Block6]) -> Option<Vec<Vec<(u32, Block6)>>>,
    ) -> Result<TwoLevel> {
        Self::build(
            k,
            positions,
            box_lengths,
            (rotations, per_aggregate),
            (more, None),
            extra,
        )
    }

    /// The coarse space of a held structure (the specimen's K with its prescribed DOFs
    /// eliminated, which has no rigid-body modes): the rigid modes vanish on the prescribed
    /// DOFs, as the structure's own near-null modes do (Vaněk, Mandel & Brezina 1996: the
    /// tentative prolongator is zero on Dirichlet DOFs), the spins in the unknowns' unit, a
    /// node held `apart` (the period
    /// changes' node) is its own aggregate with all six DOFs, and the coarse matrix is factored
    /// without pinning a node ([`BlockCholesky::factor_definite`]): the coarse solve is
    /// exact, as the balancing preconditioner assumes.
    pub(crate) fn held(
        k: &BlockSparse,
        positions: &[Vec3],
        box_lengths: Vec3,
        per_aggregate: usize,
        held: &HeldSpace,
    ) -> Result<TwoLevel> {
        Self::build(
            k,
            positions,
            box_lengths,
            (true, per_aggregate),
            (&[], Some(held)),
            |_, _| None,
        )
    }

    /// [`Self::with_layers`], or [`Self::held`] with `held`.
    fn build(
        k: &impl BlockRows,
        positions: &[Vec3],
        box_lengths: Vec3,
        (rotations, per_aggregate): (bool, usize),
        (more, held): (&[CoarseLayer], Option<&HeldSpace>),
        mut extra: impl FnMut(&[u32], &[Block6]) -> Option<Vec<Vec<(u32, Block6)>>>,
    ) -> Result<TwoLevel> {
        let m = k.rows();
        if positions.len() != m || m == 0 {
            return Err(Error::Invalid(format!(
                "two-level preconditioner: {} positions for {m} particles",
                positions.len()
            )));
        }
        if per_aggregate == 0 {
            return Err(Error::Invalid(
                "two-level preconditioner: particles per aggregate must be positive".into(),
            ));
        }
        if let Some(h) = held {
            // The node held apart gets its own cluster with one identity block per layer:
            // only one layer keeps those columns independent.
            if h.apart.is_some_and(|a| a >= m) || !more.is_empty() {
                return Err(Error::Invalid(format!(
                    "two-level preconditioner: a held structure's node apart ({:?}) must be \
                     one of its {m} nodes, with no extra coarse layers ({} given)",
                    h.apart,
                    more.len()
                )));
            }
        }
        let (cells, raw) = grid_cells(positions, box_lengths, per_aggregate);
        // Number the non-empty cells in increasing (x, y, z) order; sorting the occupied
        // cells costs O(m log m) whatever the grid's size.
        let apart = held.and_then(|h| h.apart);
        let mut occupied: Vec<[usize; 3]> = raw
            .iter()
            .enumerate()
            .filter(|&(p, _)| Some(p) != apart)
            .map(|(_, (c, _))| *c)
            .collect();
        occupied.sort_unstable();
        occupied.dedup();
        let mut n_agg = occupied.len();
        let mut aggregate: Vec<u32> = raw
            .iter()
            .map(|(c, _)| occupied.binary_search(c).unwrap_or(0) as u32)
            .collect();
        if let Some(a) = apart {
            aggregate[a] = n_agg as u32;
            n_agg += 1;
        }
        let members = aggregate
            .iter()
            .enumerate()
            .map(|(p, &a)| (a, p as u32, ()));
        let (start, nodes) = group_by(n_agg, members, ());
        let nodes: Vec<u32> = nodes.into_iter().map(|(p, ())| p).collect();
        let layers = 1 + more.len();
        let h = (box_lengths.x * box_lengths.y * box_lengths.z * per_aggregate as f64 / m as f64)
            .cbrt();
        let mut prolongation: Vec<Block6> = raw
            .par_iter()
            .zip(aggregate.par_iter())
            .flat_map_iter(|((_, d), &a)| {
                let size = start[a as usize + 1] - start[a as usize];
                std::iter::once(rigid_modes(d, rotations))
                    .chain(more.iter().map(move |f| f(&(d / h), size)))
            })
            .collect();
        if let Some(hs) = held {
            if hs.held.len() != m {
                return Err(Error::Invalid(format!(
                    "two-level preconditioner: {} held masks for {m} particles",
                    hs.held.len()
                )));
            }
            prolongation
                .par_chunks_mut(layers)
                .zip(hs.held.par_iter())
                .enumerate()
                .for_each(|(p, (blocks, mask))| {
                    for b in blocks.iter_mut() {
                        if Some(p) == apart {
                            *b = Block6::identity();
                        } else {
                            for d in 3..6 {
                                b.row_mut(d).scale_mut(hs.spin_scale);
                            }
                        }
                        for (d, _) in mask.iter().enumerate().filter(|(_, &h)| h) {
                            b.row_mut(d).fill(0.0);
                        }
                    }
                });
        }
        let mut extra_rows: Option<Vec<Vec<(u32, Block6)>>> = None;
        for l in 0..layers {
            let ids: Vec<u32> = aggregate
                .iter()
                .map(|&a| a * layers as u32 + l as u32)
                .collect();
            let pl: Vec<Block6> = prolongation
                .iter()
                .skip(l)
                .step_by(layers)
                .copied()
                .collect();
            let Some(rows) = extra(&ids, &pl) else {
                break;
            };
            if rows.len() != m {
                return Err(Error::Invalid(format!(
                    "two-level preconditioner: {} rows of the extra operator for {m} particles",
                    rows.len()
                )));
            }
            match extra_rows.as_mut() {
                None => extra_rows = Some(rows),
                Some(acc) => acc.par_iter_mut().zip(rows).for_each(|(a, r)| {
                    a.extend(r);
                    a.sort_by_key(|(b, _)| *b);
                }),
            }
        }
        let (kp_start, kp) = k_times_p(
            k,
            &aggregate,
            (layers, &prolongation),
            extra_rows.as_deref(),
        );
        let (slot, chunk_slots, parts_start, parts) =
            restriction_chunks(&kp_start, &kp, n_agg * layers);
        let coarse_matrix =
            coarse_matrix((layers, &prolongation), (&start, &nodes), (&kp_start, &kp));
        // Nested dissection where the grid allows it (the held structure's apart node, the
        // period change, last: it couples to every cluster the cut crosses), else AMD; a
        // held structure has no rigid-body modes, so no cluster is pinned.
        let order = nested_dissection(cells, &occupied).map(|mut order| {
            if apart.is_some() {
                order.push(occupied.len() as u32);
            }
            order
                .iter()
                .flat_map(|&a| (0..layers as u32).map(move |l| a * layers as u32 + l))
                .collect::<Vec<u32>>()
        });
        let coarse =
            BlockCholesky::factor_ordered(&coarse_matrix, held.is_none(), order.as_deref())?;
        Ok(TwoLevel {
            aggregate,
            layers,
            prolongation,
            start,
            nodes,
            coarse,
            kp_start,
            kp,
            slot,
            chunk_slots,
            parts_start,
            parts,
        })
    }

    /// Number of aggregates.
    pub fn aggregates(&self) -> usize {
        self.start.len() - 1
    }

    /// Q r = P (PᵀKP)⁺ Pᵀ r into `q`, and K Q r = (KP)(PᵀKP)⁺ Pᵀ r into `kq`, on `C` load
    /// cases.
    pub fn coarse_correction<const C: usize>(
        &self,
        r: &[Cols<C>],
        q: &mut [Cols<C>],
        kq: &mut [Cols<C>],
    ) -> Result<()> {
        let layers = self.layers;
        let restricted: Vec<Cols<C>> = (0..self.aggregates() * layers)
            .into_par_iter()
            .map(|c| {
                let (a, l) = (c / layers, c % layers);
                let mut s = Cols::<C>::zeros();
                for &p in &self.nodes[self.start[a]..self.start[a + 1]] {
                    mul_add6_cols(
                        &mut s,
                        &self.prolongation[p as usize * layers + l].transpose(),
                        &r[p as usize],
                        C,
                    );
                }
                s
            })
            .collect();
        let xc = self.coarse.solve_in_halves(&restricted)?;
        q.par_iter_mut()
            .zip(kq.par_iter_mut())
            .enumerate()
            .for_each(|(p, (q, kq))| {
                let c = self.aggregate[p] as usize * layers;
                *q = mul6_cols(&self.prolongation[p * layers], &xc[c], C);
                for l in 1..layers {
                    mul_add6_cols(q, &self.prolongation[p * layers + l], &xc[c + l], C);
                }
                let mut s = Cols::<C>::zeros();
                for (b, kpb) in &self.kp[self.kp_start[p]..self.kp_start[p + 1]] {
                    mul_add6_cols(&mut s, kpb, &xc[*b as usize], C);
                }
                *kq = s;
            });
        Ok(())
    }

    /// Q K w = P (PᵀKP)⁺ (KP)ᵀ w, written into `out` (no product with K itself).
    pub fn coarse_of_k(&self, w: &[Block6], out: &mut [Block6]) -> Result<()> {
        self.coarse_of_k_cols(w, out, 6)
    }

    /// [`Self::coarse_of_k`] on the first `cols` load cases (the others of `out` are zero).
    pub fn coarse_of_k_cols(&self, w: &[Block6], out: &mut [Block6], cols: usize) -> Result<()> {
        self.prolong_coarse_of_k(w, out, cols, |_, _, o, s, _: &mut ()| *o = s, |_| ())
    }

    /// w − Q K w into `z` on the first `cols` of `C` load cases (the bits of `w` less
    /// [`Self::coarse_of_k_cols`], in one pass: the two-level preconditioner's (I − QK) w).
    pub(crate) fn deflate_cols<const C: usize>(
        &self,
        w: &[Cols<C>],
        z: &mut [Cols<C>],
        cols: usize,
    ) -> Result<()> {
        self.prolong_coarse_of_k(w, z, cols, |p, _, o, s, _: &mut ()| *o = w[p] - s, |_| ())
    }

    /// The CG's next search direction with the two-level preconditioner, p ← (I − QK) w + β p
    /// column by column, in one pass over the rows: the deflated w (the bits of
    /// [`Self::deflate_cols`]) is never stored. Before p is overwritten, x += α p (the bits of
    /// the CG's step, taken here where p is read anyway); with `pt`, the new p is also written
    /// transposed there, for the next product with K ([`fused::CaseRows`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn deflated_direction<const C: usize>(
        &self,
        w: &[Cols<C>],
        p: &mut [Cols<C>],
        pt: Option<&mut [CaseRows]>,
        (x, alpha): (&mut [Cols<C>], &[f64; C]),
        beta: &[f64; C],
        cols: usize,
    ) -> Result<()> {
        const CH: usize = PROLONG_ROWS;
        // Each chunk's rows of p transposed (when kept) and of x.
        type Rows<'a, const C: usize> = (Option<&'a mut [CaseRows]>, &'a mut [Cols<C>]);
        let pts: Vec<Option<&mut [CaseRows]>> = match pt {
            Some(t) => t.chunks_mut(CH).map(Some).collect(),
            None => (0..p.len().div_ceil(CH)).map(|_| None).collect(),
        };
        let mut chunks = pts.into_iter().zip(x.chunks_mut(CH));
        let finish = |q: usize, at: usize, o: &mut Cols<C>, s: Cols<C>, rows: &mut Rows<C>| {
            add_scaled_cols(&mut rows.1[at], o, alpha);
            direction_cols(o, &(w[q] - s), beta);
            if let Some(t) = rows.0.as_deref_mut() {
                t[at] = CaseRows::of(o, cols);
            }
        };
        self.prolong_coarse_of_k(w, p, cols, finish, |_| {
            chunks.next().expect("one per chunk")
        })
    }

    /// `finish`(p, p's index in its chunk, out_p, (Q K w)_p, the chunk's `aux`) for every
    /// fine node p, by chunks of [`PROLONG_ROWS`] rows; `aux` is called once per chunk, in
    /// order, before the chunks run.
    fn prolong_coarse_of_k<A: Send, const C: usize>(
        &self,
        w: &[Cols<C>],
        out: &mut [Cols<C>],
        cols: usize,
        finish: impl Fn(usize, usize, &mut Cols<C>, Cols<C>, &mut A) + Sync,
        mut aux: impl FnMut(usize) -> A,
    ) -> Result<()> {
        let layers = self.layers;
        let m = self.aggregate.len();
        let fused = fused::runs::<C>();
        let partial: Vec<Vec<Cols<C>>> = self
            .chunk_slots
            .par_iter()
            .enumerate()
            .map(|(c, &slots)| {
                if fused {
                    // SAFETY: the fused kernels run here (checked above).
                    return unsafe { self.restrict_chunk_fused(c, slots as usize, w, cols) };
                }
                let mut part = vec![Cols::<C>::zeros(); slots as usize];
                avx2!({
                    let first = c * RESTRICT_ROWS;
                    let rows = &w[first..(first + RESTRICT_ROWS).min(m)];
                    for (p, wp) in (first..).zip(rows) {
                        for at in self.kp_start[p]..self.kp_start[p + 1] {
                            mul_add6_transposed_cols(
                                &mut part[self.slot[at] as usize],
                                &self.kp[at].1,
                                wp,
                                cols,
                            );
                        }
                    }
                });
                part
            })
            .collect();
        let restricted: Vec<Cols<C>> = (0..self.aggregates() * layers)
            .into_par_iter()
            .map(|a| {
                let mut s = Cols::<C>::zeros();
                for &(c, at) in &self.parts[self.parts_start[a]..self.parts_start[a + 1]] {
                    s += partial[c as usize][at as usize];
                }
                s
            })
            .collect();
        let xc = self.coarse.solve_in_halves(&restricted)?;
        const CH: usize = PROLONG_ROWS;
        let mut auxes: Vec<A> = (0..out.len().div_ceil(CH)).map(&mut aux).collect();
        out.par_chunks_mut(CH)
            .zip(auxes.par_iter_mut())
            .enumerate()
            .for_each(|(k, (outs, aux))| {
                if fused {
                    // SAFETY: the fused kernels run here (checked above).
                    unsafe { self.prolong_chunk_fused(k * CH, outs, aux, &xc, cols, &finish) };
                    return;
                }
                avx2!({
                    for (at, (p, o)) in (k * CH..).zip(outs.iter_mut()).enumerate() {
                        let c = self.aggregate[p] as usize * layers;
                        let mut s = mul6_cols(&self.prolongation[p * layers], &xc[c], cols);
                        for l in 1..layers {
                            mul_add6_cols(
                                &mut s,
                                &self.prolongation[p * layers + l],
                                &xc[c + l],
                                cols,
                            );
                        }
                        finish(p, at, o, s, aux);
                    }
                });
            });
        Ok(())
    }

    /// Chunk `c`'s partial restriction (K P)ᵀ w over its `slots` coarse nodes, by the fused
    /// kernel: each fine row of w transposed once, the sums kept transposed.
    ///
    /// # Safety
    /// As [`fused::add_transposed`]: only where [`fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn restrict_chunk_fused<const C: usize>(
        &self,
        c: usize,
        slots: usize,
        w: &[Cols<C>],
        cols: usize,
    ) -> Vec<Cols<C>> {
        let mut part = vec![CaseRows::default(); slots];
        let first = c * RESTRICT_ROWS;
        let rows = &w[first..(first + RESTRICT_ROWS).min(self.aggregate.len())];
        for (p, wp) in (first..).zip(rows) {
            let wt = CaseRows::of(wp, cols);
            for at in self.kp_start[p]..self.kp_start[p + 1] {
                fused::add_transposed(&mut part[self.slot[at] as usize], &self.kp[at].1, &wt);
            }
        }
        part.into_iter().map(CaseRows::to_cols).collect()
    }

    /// The prolongation of the coarse solution `xc` into the rows `first..` (`outs`), by the
    /// fused kernel, each passed through `finish`.
    ///
    /// # Safety
    /// As [`fused::straight_sum`]: only where [`fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn prolong_chunk_fused<A, const C: usize>(
        &self,
        first: usize,
        outs: &mut [Cols<C>],
        aux: &mut A,
        xc: &[Cols<C>],
        cols: usize,
        finish: &impl Fn(usize, usize, &mut Cols<C>, Cols<C>, &mut A),
    ) {
        let layers = self.layers;
        for (at, (p, o)) in (first..).zip(outs.iter_mut()).enumerate() {
            let c = self.aggregate[p] as usize * layers;
            let terms = self.prolongation[p * layers..(p + 1) * layers]
                .iter()
                .zip(&xc[c..c + layers]);
            finish(p, at, o, fused::straight_sum(terms, cols), aux);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// K P by the rigid-mode shortcut is the general product to rounding, with and without
    /// rotations (the latter's P is not of the shortcut's form).
    #[test]
    fn rigid_mode_products_are_the_general_products() {
        let k =
            Block6::from_fn(|i, j| ((i * 5 + j * 7) as f64 * 0.731).sin() * 10f64.powi(i as i32));
        for rotations in [true, false] {
            let p = rigid_modes(&Vec3::new(0.31, -1.7, 0.55), rotations);
            let (fast, slow) = (times_prolongation(&k, &p), k * p);
            assert!(
                (fast - slow).amax() <= 1e-15 * slow.amax(),
                "{fast} vs {slow}"
            );
        }
    }

    /// A periodic cubic lattice of `n`³ nodes joined to their 26 neighbours (faces, edges,
    /// corners: the cells of a packing couple so) by the SPD block A (K = L ⊗ A, null on
    /// equal motions of every node), with its nodes' positions.
    fn lattice(n: usize) -> (BlockSparse, Vec<Vec3>) {
        let a = Block6::from_fn(|i, j| ((i * 7 + j * 3) % 11) as f64 / 7.0 + 0.1 * (i + j) as f64);
        let a = a * a.transpose() + Block6::identity() * 3.1;
        let id = |x: usize, y: usize, z: usize| ((x % n) * n + y % n) * n + z % n;
        let mut ends = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let p = id(x, y, z) as u32;
                    // The 13 neighbours ahead in (x, y, z) order, each pair once.
                    for d in 14..27 {
                        // Shifts d / 9 − 1 etc. in −1, 0, +1, wrapped by + n.
                        let q = id(x + n - 1 + d / 9, y + n - 1 + d / 3 % 3, z + n - 1 + d % 3);
                        ends.push((p, q as u32));
                    }
                }
            }
        }
        let k = BlockSparse::assemble_blocks(n * n * n, &ends, |_| (a, a, -a));
        let positions = (0..n * n * n)
            .map(|p| {
                Vec3::new((p / (n * n)) as f64, (p / n % n) as f64, (p % n) as f64)
                    + Vec3::repeat(0.5)
            })
            .collect();
        (k, positions)
    }

    /// Every occupied cell exactly once, also with empty cells and uneven sides.
    #[test]
    fn nested_dissection_orders_every_occupied_cell_once() {
        let cells = [6, 5, 9];
        let occupied: Vec<[usize; 3]> = (0..6 * 5 * 9)
            .filter(|c| c % 7 != 3)
            .map(|c| [c / 45, c / 9 % 5, c % 9])
            .collect();
        let order = nested_dissection(cells, &occupied).expect("a dense grid");
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..occupied.len() as u32).collect::<Vec<_>>());
        // A grid far larger than its occupied cells is left to AMD.
        assert!(nested_dissection([1000, 1000, 1000], &occupied).is_none());
    }

    /// The streamed restriction (K P)ᵀ w, by chunks of K P's rows, against the direct one
    /// Pᵀ (K w) through the aggregates' members: Q K w by both, on a lattice of more rows
    /// than one chunk holds; and the coarse factor in nested-dissection order is smaller
    /// than AMD's on the same coarse matrix.
    #[test]
    fn streamed_restriction_equals_the_direct_one() {
        let n = 26;
        let (k, positions) = lattice(n);
        assert!(k.rows() > 2 * RESTRICT_ROWS);
        let lengths = Vec3::repeat(n as f64);
        let tl = TwoLevel::new(&k, &positions, lengths, true, 16).expect("coarse space");
        let w: Vec<Block6> = (0..k.rows())
            .map(|p| Block6::from_fn(|i, j| ((p * 13 + i * 5 + j * 3) % 17) as f64 - 8.0))
            .collect();
        let mut streamed = vec![Block6::zeros(); k.rows()];
        tl.coarse_of_k(&w, &mut streamed).expect("solve");
        let mut kw = vec![Block6::zeros(); k.rows()];
        k.apply(&w, &mut kw);
        let (mut direct, mut kq) = (
            vec![Block6::zeros(); k.rows()],
            vec![Block6::zeros(); k.rows()],
        );
        tl.coarse_correction(&kw, &mut direct, &mut kq)
            .expect("solve");
        let scale = direct.iter().map(|b| b.amax()).fold(0.0, f64::max);
        let err = streamed
            .iter()
            .zip(&direct)
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        assert!(scale > 0.0 && err < 1e-10 * scale, "{err:e} of {scale:e}");
        // w − Q K w in one pass: the bits of the two steps.
        let mut deflated = vec![Block6::zeros(); k.rows()];
        tl.deflate_cols(&w, &mut deflated, 6).expect("solve");
        for p in 0..k.rows() {
            assert_eq!(deflated[p], w[p] - streamed[p]);
        }
        // The coarse matrix of the same aggregates, factored in both orders.
        let (cells, raw) = grid_cells(&positions, lengths, 16);
        let mut occupied: Vec<[usize; 3]> = raw.iter().map(|(c, _)| *c).collect();
        occupied.sort_unstable();
        occupied.dedup();
        let order = nested_dissection(cells, &occupied).expect("a dense grid");
        let coarse = {
            let prolongation: Vec<Block6> = raw.iter().map(|(_, d)| rigid_modes(d, true)).collect();
            let aggregate: Vec<u32> = raw
                .iter()
                .map(|(c, _)| occupied.binary_search(c).expect("occupied") as u32)
                .collect();
            let members = aggregate
                .iter()
                .enumerate()
                .map(|(p, &a)| (a, p as u32, ()));
            let (start, nodes) = group_by(occupied.len(), members, ());
            let nodes: Vec<u32> = nodes.into_iter().map(|(p, ())| p).collect();
            let (kp_start, kp) = k_times_p(&k, &aggregate, (1, &prolongation), None);
            coarse_matrix((1, &prolongation), (&start, &nodes), (&kp_start, &kp))
        };
        let amd = BlockCholesky::factor(&coarse).expect("factor");
        let nd = BlockCholesky::factor_ordered(&coarse, true, Some(&order)).expect("factor");
        // The same solution in either order (the pinned node is the same: the first that can).
        let b: Vec<Block6> = (0..coarse.rows())
            .map(|c| Block6::from_fn(|i, j| ((c * 11 + i * 3 + j * 7) % 13) as f64 - 6.0))
            .collect();
        // A load without net force, as the CG's restricted residuals.
        let mean: Block6 = b.iter().sum::<Block6>() / b.len() as f64;
        let b: Vec<Block6> = b.iter().map(|x| x - mean).collect();
        let (xa, xn) = (
            amd.solve(&b).expect("solve"),
            nd.solve_in_halves(&b).expect("solve"),
        );
        let scale = xa.iter().map(|x| x.amax()).fold(0.0, f64::max);
        let err = xa
            .iter()
            .zip(&xn)
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        assert!(scale > 0.0 && err < 1e-9 * scale, "{err:e} of {scale:e}");
        assert!(
            nd.factor_nonzeros() < amd.factor_nonzeros(),
            "{} ≥ {}",
            nd.factor_nonzeros(),
            amd.factor_nonzeros()
        );
    }
}
