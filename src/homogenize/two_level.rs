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
use super::network::Block6;
use super::sparse::{
    mul6, mul6_cols, mul_add6, mul_add6_cols, mul_add6_transposed_cols, BlockRows, BlockSparse,
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
) -> Vec<([usize; 3], Vec3)> {
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
    positions.par_iter().map(cell_of).collect()
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
                    let v = kpq * prolongation[q * layers + l];
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
    /// (KP)ᵀ by coarse node: CSR of (fine row, position of its block in `kp`), the
    /// blocks read transposed ([`mul_add6_transposed_cols`]) rather than stored twice
    /// (0.9 GB at a million particles; issue 35).
    kpt_start: Vec<usize>,
    kpt: Vec<(u32, u32)>,
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
        let raw = grid_cells(positions, box_lengths, per_aggregate);
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
        // (KP)ᵀ by aggregate: the blocks of every aggregate's column, by fine row.
        let (kp_start_ref, kp_ref) = (&kp_start, &kp);
        let columns = (0..m).flat_map(|p| {
            (kp_start_ref[p]..kp_start_ref[p + 1])
                .map(move |at| (kp_ref[at].0, p as u32, at as u32))
        });
        let (kpt_start, kpt) = group_by(n_agg * layers, columns, 0u32);
        let coarse_matrix =
            coarse_matrix((layers, &prolongation), (&start, &nodes), (&kp_start, &kp));
        let coarse = match held {
            Some(_) => BlockCholesky::factor_definite(&coarse_matrix)?,
            None => BlockCholesky::factor(&coarse_matrix)?,
        };
        Ok(TwoLevel {
            aggregate,
            layers,
            prolongation,
            start,
            nodes,
            coarse,
            kp_start,
            kp,
            kpt_start,
            kpt,
        })
    }

    /// Number of aggregates.
    pub fn aggregates(&self) -> usize {
        self.start.len() - 1
    }

    /// Q r = P (PᵀKP)⁺ Pᵀ r into `q`, and K Q r = (KP)(PᵀKP)⁺ Pᵀ r into `kq`.
    pub fn coarse_correction(
        &self,
        r: &[Block6],
        q: &mut [Block6],
        kq: &mut [Block6],
    ) -> Result<()> {
        let layers = self.layers;
        let restricted: Vec<Block6> = (0..self.aggregates() * layers)
            .into_par_iter()
            .map(|c| {
                let (a, l) = (c / layers, c % layers);
                let mut s = Block6::zeros();
                for &p in &self.nodes[self.start[a]..self.start[a + 1]] {
                    mul_add6(
                        &mut s,
                        &self.prolongation[p as usize * layers + l].transpose(),
                        &r[p as usize],
                    );
                }
                s
            })
            .collect();
        let xc = self.coarse.solve(&restricted)?;
        q.par_iter_mut()
            .zip(kq.par_iter_mut())
            .enumerate()
            .for_each(|(p, (q, kq))| {
                let c = self.aggregate[p] as usize * layers;
                *q = mul6(&self.prolongation[p * layers], &xc[c]);
                for l in 1..layers {
                    mul_add6(q, &self.prolongation[p * layers + l], &xc[c + l]);
                }
                let mut s = Block6::zeros();
                for (b, kpb) in &self.kp[self.kp_start[p]..self.kp_start[p + 1]] {
                    mul_add6(&mut s, kpb, &xc[*b as usize]);
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
        let layers = self.layers;
        let restricted: Vec<Block6> = (0..self.aggregates() * layers)
            .into_par_iter()
            .map(|a| {
                let mut s = Block6::zeros();
                for &(p, at) in &self.kpt[self.kpt_start[a]..self.kpt_start[a + 1]] {
                    mul_add6_transposed_cols(&mut s, &self.kp[at as usize].1, &w[p as usize], cols);
                }
                s
            })
            .collect();
        let xc = self.coarse.solve(&restricted)?;
        out.par_iter_mut().enumerate().for_each(|(p, o)| {
            let c = self.aggregate[p] as usize * layers;
            *o = mul6_cols(&self.prolongation[p * layers], &xc[c], cols);
            for l in 1..layers {
                mul_add6_cols(o, &self.prolongation[p * layers + l], &xc[c + l], cols);
            }
        });
        Ok(())
    }
}
