//! The 6×6 block-sparse symmetric matrix every static solve shares (the relaxed tensor, the
//! specimen, the cavity, buckling, LAF) and its unrolled 6×6 block kernels: the bottom layer
//! of `homogenize`, below the solvers (`cholesky`, `two_level`, `relaxed`) that use it.

use super::fused;
use super::network::{csr, Block6, Network};
use crate::{Error, Result};
use rayon::prelude::*;

pub(crate) use super::network::Cols;

/// The CG's blocks of `C` load cases seen as six, for the operators that only take six (the
/// many-body term in factored form, its stiff groups, the multigrid): `None` below six.
pub(crate) trait AsSix: Sized {
    /// `x` as blocks of six load cases, when it is.
    fn six(x: &[Self]) -> Option<&[Block6]>;
    /// `x` as blocks of six load cases, when it is.
    fn six_mut(x: &mut [Self]) -> Option<&mut [Block6]>;
}

impl AsSix for Block6 {
    fn six(x: &[Self]) -> Option<&[Block6]> {
        Some(x)
    }
    fn six_mut(x: &mut [Self]) -> Option<&mut [Block6]> {
        Some(x)
    }
}

/// [`AsSix`] of the narrow blocks: never six.
macro_rules! narrow_cols {
    ($($c:literal),*) => {$(
        impl AsSix for Cols<$c> {
            fn six(_: &[Self]) -> Option<&[Block6]> {
                None
            }
            fn six_mut(_: &mut [Self]) -> Option<&mut [Block6]> {
                None
            }
        }
    )*};
}
narrow_cols!(1, 2);

/// Block-sparse symmetric matrix with 6×6 blocks, stored by rows (both triangles).
pub struct BlockSparse {
    row_start: Vec<usize>,
    col: Vec<u32>,
    block: Vec<Block6>,
}

impl BlockSparse {
    /// Assemble K of a network row by row, forming each bond's element from its springs at
    /// both of its rows (never all elements at once: at a million particles they would take
    /// 6.6 GB; issue 35). Each block is summed in the order of [`Self::assemble_blocks`]
    /// (bond, then K_ii, K_jj, K_ij, K_ijᵀ), so the bits are the same.
    pub fn assemble(net: &Network) -> BlockSparse {
        let mut k = BlockSparse::from_rows(Vec::new());
        assemble_rows(net.n_active, &net.ends, element_blocks(net), |rows| {
            k.push_rows(rows)
        });
        k
    }

    /// [`Self::assemble_blocks`] row by row over `m` nodes and the edges `ends`, forming edge
    /// e's blocks `blocks(e)` = (K_ii, K_jj, K_ij) at both of its rows instead of holding
    /// every edge's (the same bits).
    pub(crate) fn assemble_rows(
        m: usize,
        ends: &[(u32, u32)],
        blocks: impl Fn(usize) -> (Block6, Block6, Block6) + Sync,
    ) -> BlockSparse {
        let mut k = BlockSparse::from_rows(Vec::new());
        assemble_rows(m, ends, blocks, |rows| k.push_rows(rows));
        k
    }

    /// (K X, the diagonal blocks of K) of the K that [`Self::assemble_rows`] would form,
    /// without storing it: each chunk of rows multiplied as soon as it is formed, by the
    /// kernel and in the order of [`Self::apply`], so the bits of `assemble_rows(..).apply(x)`
    /// and of its `diagonal(p)` (a specimen's reactions after its solve: at a million
    /// particles no second K's 2.5 GB; issue 35).
    pub(crate) fn assemble_rows_times(
        m: usize,
        ends: &[(u32, u32)],
        blocks: impl Fn(usize) -> (Block6, Block6, Block6) + Sync,
        x: &[Block6],
    ) -> (Vec<Block6>, Vec<Block6>) {
        let (mut kx, mut diagonal) = (Vec::with_capacity(m), Vec::with_capacity(m));
        fused::with_transposed(x, 6, |xt| {
            assemble_rows(m, ends, blocks, |rows| {
                // The chunk's rows as a matrix of their own (columns stay global): its
                // `row_times` is `apply`'s product of each row.
                let first = kx.len();
                let chunk = BlockSparse::from_rows(rows);
                let products: Vec<(Block6, Block6)> = (0..chunk.rows())
                    .into_par_iter()
                    .map(|k| {
                        let diag = chunk
                            .row(k)
                            .find(|&(c, _)| c == first + k)
                            .map_or(Block6::zeros(), |(_, d)| *d);
                        (chunk.row_times_with(k, x, xt, 6), diag)
                    })
                    .collect();
                for (a, d) in products {
                    kx.push(a);
                    diagonal.push(d);
                }
            });
        });
        (kx, diagonal)
    }

    /// Assemble a symmetric matrix over `m` nodes from per-edge blocks: edge e joining
    /// `ends[e] = (i, j)` adds `blocks(e) = (K_ii, K_jj, K_ij)` (and K_ijᵀ to K_ji), summed
    /// in edge order (so the result does not depend on the thread count).
    pub fn assemble_blocks(
        m: usize,
        ends: &[(u32, u32)],
        blocks: impl Fn(usize) -> (Block6, Block6, Block6),
    ) -> BlockSparse {
        let blocks: Vec<(Block6, Block6, Block6)> = (0..ends.len()).map(&blocks).collect();
        let net_ends = ends;
        // (row, col, element, kind: 0 = kii, 1 = kjj, 2 = kij, 3 = kijᵀ)
        let mut entries: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(4 * net_ends.len());
        for (e, &(pi, pj)) in net_ends.iter().enumerate() {
            entries.push((pi, pi, e as u32, 0));
            entries.push((pj, pj, e as u32, 1));
            entries.push((pi, pj, e as u32, 2));
            entries.push((pj, pi, e as u32, 3));
        }
        entries.par_sort_unstable();
        let mut row_start = vec![0usize; m + 1];
        let mut col = Vec::new();
        let mut block = Vec::new();
        let mut k0 = 0;
        while k0 < entries.len() {
            let (r, c) = (entries[k0].0, entries[k0].1);
            let mut acc = Block6::zeros();
            let mut k1 = k0;
            while k1 < entries.len() && entries[k1].0 == r && entries[k1].1 == c {
                let (kii, kjj, kij) = &blocks[entries[k1].2 as usize];
                match entries[k1].3 {
                    0 => acc += kii,
                    1 => acc += kjj,
                    2 => acc += kij,
                    _ => acc += kij.transpose(),
                }
                k1 += 1;
            }
            col.push(c);
            block.push(acc);
            row_start[r as usize + 1] = col.len();
            k0 = k1;
        }
        BlockSparse {
            row_start,
            col,
            block,
        }
    }

    /// Gᵀq and qᵀKq, summed particle by particle in order, for the fluctuation response q
    /// (one 6×6 block per particle) to the load G: the relaxed tensor is
    /// C·V = H − Gᵀq − qᵀG + qᵀKq.
    pub fn fluctuation_terms(&self, g: &[Block6], q: &[Block6]) -> (Block6, Block6) {
        let mut kq = filled(q.len(), Block6::zeros());
        self.apply(q, &mut kq);
        fluctuation_sums(g, q, &kq)
    }

    /// Y = K X for a block vector X (one 6×6 block per particle: DOF × load case).
    pub fn apply(&self, x: &[Block6], y: &mut [Block6]) {
        self.apply_cols(x, y, 6);
    }

    /// [`Self::apply`] on the first `cols` load cases only (the others of Y are zero): a
    /// solve with fewer than six right-hand sides does not pay for six.
    pub fn apply_cols<const C: usize>(&self, x: &[Cols<C>], y: &mut [Cols<C>], cols: usize) {
        fused::with_transposed(x, cols, |xt| {
            y.par_iter_mut()
                .enumerate()
                .for_each(|(p, yp)| *yp = self.row_times_with(p, x, xt, cols))
        });
    }

    /// Row `p` of K X: by the fused kernel on X transposed (`xt`, as
    /// [`fused::with_transposed`] gives it), else by [`Self::row_times`].
    #[inline(always)]
    fn row_times_with<const C: usize>(
        &self,
        p: usize,
        x: &[Cols<C>],
        xt: Option<&[fused::CaseRows]>,
        cols: usize,
    ) -> Cols<C> {
        let Some(xt) = xt else {
            return self.row_times(p, x, cols);
        };
        let range = self.row_start[p]..self.row_start[p + 1];
        // SAFETY: `with_transposed` gives `xt` only where the fused kernels run.
        unsafe { fused::row(xt, &[], &[], &self.col[range.clone()], &self.block[range]) }
    }

    /// Row `p` of K X on the first `n` load cases, its blocks in column order.
    #[inline(always)]
    pub(crate) fn row_times<const C: usize>(&self, p: usize, x: &[Cols<C>], n: usize) -> Cols<C> {
        let mut acc = Cols::<C>::zeros();
        for k in self.row_start[p]..self.row_start[p + 1] {
            mul_add6_cols(&mut acc, &self.block[k], &x[self.col[k] as usize], n);
        }
        acc
    }

    /// The most stored blocks in one row.
    pub(crate) fn max_row_blocks(&self) -> usize {
        self.row_start
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(0)
    }

    /// The diagonal block of row `p`.
    pub fn diagonal(&self, p: usize) -> Block6 {
        (self.row_start[p]..self.row_start[p + 1])
            .find(|&k| self.col[k] as usize == p)
            .map(|k| self.block[k])
            .unwrap_or_else(Block6::zeros)
    }

    /// Number of block rows (particles).
    pub fn rows(&self) -> usize {
        self.row_start.len() - 1
    }

    /// The stored blocks (column, K_pq) of row `p`, in increasing column order.
    pub fn row(&self, p: usize) -> impl Iterator<Item = (usize, &Block6)> + '_ {
        (self.row_start[p]..self.row_start[p + 1])
            .map(move |k| (self.col[k] as usize, &self.block[k]))
    }

    /// A matrix from its block rows, each sorted by column (both triangles stored).
    pub fn from_rows(rows: Vec<Vec<(u32, Block6)>>) -> BlockSparse {
        let mut k = BlockSparse {
            row_start: vec![0],
            col: Vec::new(),
            block: Vec::new(),
        };
        k.push_rows(rows);
        k
    }

    /// Append block rows, each sorted by column, below the stored ones.
    pub(crate) fn push_rows(&mut self, rows: Vec<Vec<(u32, Block6)>>) {
        for r in rows {
            for (c, b) in r {
                self.col.push(c);
                self.block.push(b);
            }
            self.row_start.push(self.col.len());
        }
    }

    /// Every stored block rewritten in place by `f(row, column, block)`, chunks of rows in
    /// parallel: the same structure without a second copy of the matrix (the specimen's
    /// elimination of the prescribed DOFs at a million particles: 11 s serial and 2.5 GB
    /// more as a copy; issue 35).
    pub(crate) fn map_blocks(&mut self, f: impl Fn(usize, usize, &mut Block6) + Sync) {
        const ROWS: usize = 4096;
        let BlockSparse {
            row_start,
            col,
            block,
        } = self;
        let m = row_start.len() - 1;
        let mut chunks = Vec::with_capacity(m.div_ceil(ROWS));
        let mut rest: &mut [Block6] = block;
        for r0 in (0..m).step_by(ROWS) {
            let r1 = (r0 + ROWS).min(m);
            let (head, tail) = rest.split_at_mut(row_start[r1] - row_start[r0]);
            chunks.push((r0..r1, head));
            rest = tail;
        }
        let (row_start, col) = (&*row_start, &*col);
        chunks.into_par_iter().for_each(|(rows, blocks)| {
            let base = row_start[rows.start];
            for r in rows {
                for k in row_start[r]..row_start[r + 1] {
                    f(r, col[k] as usize, &mut blocks[k - base]);
                }
            }
        });
    }

    /// The rows and columns of the nodes with `map[p] != u32::MAX`, renumbered by `map`
    /// (increasing with p), scaled by `sign`: K restricted to the free nodes of a held
    /// structure.
    pub fn restrict(&self, map: &[u32], sign: f64) -> BlockSparse {
        let rows = (0..self.rows())
            .filter(|&p| map[p] != u32::MAX)
            .map(|p| {
                self.row(p)
                    .filter(|(c, _)| map[*c] != u32::MAX)
                    .map(|(c, b)| (map[c], b * sign))
                    .collect()
            })
            .collect();
        BlockSparse::from_rows(rows)
    }

    /// `self + other` over the same block rows (both stored by rows with sorted columns):
    /// rows merged by column, a shared block summed as self's + other's (a fixed order).
    /// Refuses ([`Error::Invalid`]) matrices of different sizes.
    pub fn add(&self, other: &BlockSparse) -> Result<BlockSparse> {
        if self.rows() != other.rows() {
            return Err(Error::Invalid(format!(
                "block-sparse sum: {} rows and {} rows",
                self.rows(),
                other.rows()
            )));
        }
        let rows = (0..self.rows())
            .into_par_iter()
            .map(|p| {
                let (a, b): (Vec<_>, Vec<_>) = (self.row(p).collect(), other.row(p).collect());
                let mut row = Vec::with_capacity(a.len().max(b.len()));
                let (mut i, mut j) = (0, 0);
                while i < a.len() || j < b.len() {
                    let ca = a.get(i).map_or(usize::MAX, |e| e.0);
                    let cb = b.get(j).map_or(usize::MAX, |e| e.0);
                    if ca == cb {
                        row.push((ca as u32, a[i].1 + b[j].1));
                        i += 1;
                        j += 1;
                    } else if ca < cb {
                        row.push((ca as u32, *a[i].1));
                        i += 1;
                    } else {
                        row.push((cb as u32, *b[j].1));
                        j += 1;
                    }
                }
                row
            })
            .collect();
        Ok(BlockSparse::from_rows(rows))
    }

    /// Number of stored blocks (both triangles).
    pub fn blocks(&self) -> usize {
        self.block.len()
    }

    /// Memory held by the matrix (bytes).
    pub fn bytes(&self) -> usize {
        self.block.len() * std::mem::size_of::<Block6>()
            + self.col.len() * 4
            + self.row_start.len() * 8
    }
}

/// Edge e's blocks (K_ii, K_jj, K_ij) of a network, from its element.
fn element_blocks(net: &Network) -> impl Fn(usize) -> (Block6, Block6, Block6) + Sync + '_ {
    |e| net.stiffness_blocks(e)
}

/// The block rows of K over `m` nodes and the edges `ends`, by chunks of rows handed to
/// `sink` in order, each edge's blocks `blocks(e)` = (K_ii, K_jj, K_ij) formed at both of its
/// rows (never all elements at once:
/// at a million particles they would take 6.6 GB; issue 35). Each block is summed in the
/// order of [`BlockSparse::assemble_blocks`] (bond, then K_ii, K_jj, K_ij, K_ijᵀ), so the
/// bits are the same.
fn assemble_rows(
    m: usize,
    ends: &[(u32, u32)],
    blocks: impl Fn(usize) -> (Block6, Block6, Block6) + Sync,
    mut sink: impl FnMut(Vec<Vec<(u32, Block6)>>),
) {
    const ROWS: usize = 4096;
    let pairs = ends.iter().map(|&(a, b)| (a as usize, b as usize));
    let (start, edges) = csr(m, pairs, |k, _| k as u32);
    for r0 in (0..m).step_by(ROWS) {
        let rows: Vec<Vec<(u32, Block6)>> = (r0..(r0 + ROWS).min(m))
            .into_par_iter()
            .map(|r| {
                // (column, bond, kind: 0 = K_ii, 1 = K_jj, 2 = K_ij, 3 = K_ijᵀ, element)
                let mut parts: Vec<(u32, u32, u8, usize)> = Vec::new();
                let mut elements = Vec::new();
                let mut last = u32::MAX;
                for &e in &edges[start[r]..start[r + 1]] {
                    if e == last {
                        continue; // a bond to the particle's own image is listed twice
                    }
                    last = e;
                    let (pi, pj) = ends[e as usize];
                    let at = elements.len();
                    elements.push(blocks(e as usize));
                    if pi as usize == r {
                        parts.push((pi, e, 0, at));
                        parts.push((pj, e, 2, at));
                    }
                    if pj as usize == r {
                        parts.push((pj, e, 1, at));
                        parts.push((pi, e, 3, at));
                    }
                }
                parts.sort_unstable();
                let mut row: Vec<(u32, Block6)> = Vec::new();
                for &(c, _, kind, at) in &parts {
                    if !matches!(row.last(), Some(x) if x.0 == c) {
                        row.push((c, Block6::zeros()));
                    }
                    let (kii, kjj, kij) = &elements[at];
                    let acc = &mut row.last_mut().expect("pushed above").1;
                    match kind {
                        0 => *acc += kii,
                        1 => *acc += kjj,
                        2 => *acc += kij,
                        _ => *acc += kij.transpose(),
                    }
                }
                row
            })
            .collect();
        sink(rows);
    }
}

/// Row-by-row read access to a symmetric block matrix, stored in full ([`BlockSparse`]) or
/// by its upper triangle ([`UpperBlocks`]): what the preconditioners' setups read.
pub(crate) trait BlockRows: Sync {
    /// Number of block rows.
    fn rows(&self) -> usize;
    /// Calls `f(q, K_pq)` for the stored blocks of row `p`, in increasing column order.
    fn each_in_row(&self, p: usize, f: impl FnMut(usize, &Block6));
    /// The diagonal block of row `p` (zero when not stored).
    fn diagonal(&self, p: usize) -> Block6;
}

impl BlockRows for BlockSparse {
    fn rows(&self) -> usize {
        BlockSparse::rows(self)
    }
    fn each_in_row(&self, p: usize, mut f: impl FnMut(usize, &Block6)) {
        for (q, b) in self.row(p) {
            f(q, b);
        }
    }
    fn diagonal(&self, p: usize) -> Block6 {
        BlockSparse::diagonal(self, p)
    }
}

impl BlockRows for UpperBlocks {
    fn rows(&self) -> usize {
        self.row_start.len() - 1
    }
    fn each_in_row(&self, p: usize, mut f: impl FnMut(usize, &Block6)) {
        for &(q, at) in &self.low[self.low_start[p]..self.low_start[p + 1]] {
            f(q as usize, &self.block[at as usize].transpose());
        }
        for k in self.row_start[p]..self.row_start[p + 1] {
            f(self.col[k] as usize, &self.block[k]);
        }
    }
    fn diagonal(&self, p: usize) -> Block6 {
        let k = self.row_start[p];
        if k < self.row_start[p + 1] && self.col[k] as usize == p {
            self.block[k]
        } else {
            Block6::zeros()
        }
    }
}

/// A [`BlockSparse`] whose off-diagonal blocks are exact transposes of each other (K_qp =
/// K_pqᵀ bit for bit, as [`BlockSparse::assemble`] sums them), stored once: the upper
/// triangle and the diagonal by rows, each row's lower blocks read transposed from the rows
/// above. Products give the same bits as the full matrix's (the same blocks, in column
/// order, by the same kernel) with about half its memory and traffic (issue 35).
pub(crate) struct UpperBlocks {
    row_start: Vec<usize>,
    col: Vec<u32>,
    block: Vec<Block6>,
    /// Row p's blocks left of the diagonal (CSR by p): (column q, position of K_qp in `block`),
    /// q increasing.
    low_start: Vec<usize>,
    low: Vec<(u32, u32)>,
    max_row_blocks: usize,
}

impl UpperBlocks {
    /// The upper triangle of `k`, or `None` when some off-diagonal block differs in any bit
    /// from its mirror's transpose (then products must use `k` itself) or `k` holds 2³² blocks
    /// or more.
    pub(crate) fn of(k: &BlockSparse) -> Option<UpperBlocks> {
        let m = k.rows();
        if !Self::mirrored(k) {
            return None;
        }
        let mut row_start = Vec::with_capacity(m + 1);
        row_start.push(0);
        let upper = k.blocks().div_ceil(2) + m;
        let mut col = Vec::with_capacity(upper);
        let mut block = Vec::with_capacity(upper);
        for p in 0..m {
            for (q, b) in k.row(p).filter(|&(q, _)| q >= p) {
                col.push(q as u32);
                block.push(*b);
            }
            row_start.push(col.len());
        }
        Some(UpperBlocks::of_rows(row_start, col, block))
    }

    /// [`Self::of`] on a matrix given away: its upper triangle compacted in place, in row
    /// order, and the storage shrunk: the same bits without a second copy's fresh memory (a
    /// million-particle specimen: 3.8 s and 1.3 GB for the copy, 1.1–1.3 s for this; issue
    /// 35). The matrix back when it does not mirror.
    pub(crate) fn of_owned(k: BlockSparse) -> std::result::Result<UpperBlocks, BlockSparse> {
        if !Self::mirrored(&k) {
            return Err(k);
        }
        let BlockSparse {
            row_start,
            mut col,
            mut block,
        } = k;
        let m = row_start.len() - 1;
        let mut upper_start = Vec::with_capacity(m + 1);
        upper_start.push(0);
        let mut w = 0;
        for p in 0..m {
            // Every kept block moves to a slot at or before its own: a forward pass is safe.
            for at in row_start[p]..row_start[p + 1] {
                if col[at] as usize >= p {
                    col[w] = col[at];
                    block[w] = block[at];
                    w += 1;
                }
            }
            upper_start.push(w);
        }
        drop(row_start);
        col.truncate(w);
        col.shrink_to_fit();
        block.truncate(w);
        block.shrink_to_fit();
        Ok(UpperBlocks::of_rows(upper_start, col, block))
    }

    /// Whether every off-diagonal block of `k` is its mirror's transpose bit for bit, and
    /// `k` holds fewer than 2³² blocks (the lower lists index them by `u32`).
    fn mirrored(k: &BlockSparse) -> bool {
        let mirrored = (0..k.rows()).into_par_iter().all(|p| {
            k.row(p).filter(|&(q, _)| q < p).all(|(q, b)| {
                k.row(q)
                    .find(|&(c, _)| c == p)
                    .is_some_and(|(_, u)| u.transpose() == *b)
            }) && k
                .row(p)
                .filter(|&(q, _)| q > p)
                .all(|(q, _)| k.row(q).any(|(c, _)| c == p))
        });
        mirrored && k.blocks() < u32::MAX as usize
    }

    /// The upper triangle from its rows (CSR, columns increasing from the diagonal): the
    /// lower lists and the longest full row added.
    fn of_rows(row_start: Vec<usize>, col: Vec<u32>, block: Vec<Block6>) -> UpperBlocks {
        let m = row_start.len() - 1;
        let mut low_count = vec![0usize; m + 1];
        for &q in &col {
            low_count[q as usize + 1] += 1;
        }
        // The diagonal blocks counted above are no lower blocks.
        for p in 0..m {
            if row_start[p] < row_start[p + 1] && col[row_start[p]] as usize == p {
                low_count[p + 1] -= 1;
            }
        }
        for p in 0..m {
            low_count[p + 1] += low_count[p];
        }
        let low_start = low_count;
        let mut fill = low_start.clone();
        let mut low = vec![(0u32, 0u32); low_start[m]];
        // Rows in increasing order: every row's lower list fills with q increasing.
        for q in 0..m {
            let first = row_start[q];
            for (at, &c) in (first..).zip(&col[first..row_start[q + 1]]) {
                let p = c as usize;
                if p > q {
                    low[fill[p]] = (q as u32, at as u32);
                    fill[p] += 1;
                }
            }
        }
        let max_row_blocks = (0..m)
            .map(|p| row_start[p + 1] - row_start[p] + low_start[p + 1] - low_start[p])
            .max()
            .unwrap_or(0);
        UpperBlocks {
            row_start,
            col,
            block,
            low_start,
            low,
            max_row_blocks,
        }
    }

    /// Row `p` of K X on the first `n` load cases: the blocks in column order, as
    /// [`BlockSparse::row_times`].
    #[inline(always)]
    pub(crate) fn row_times<const C: usize>(&self, p: usize, x: &[Cols<C>], n: usize) -> Cols<C> {
        let mut acc = Cols::<C>::zeros();
        for &(q, at) in &self.low[self.low_start[p]..self.low_start[p + 1]] {
            mul_add6_transposed_cols(&mut acc, &self.block[at as usize], &x[q as usize], n);
        }
        for k in self.row_start[p]..self.row_start[p + 1] {
            mul_add6_cols(&mut acc, &self.block[k], &x[self.col[k] as usize], n);
        }
        acc
    }

    /// Rows `first..` of K X into `ys` by the fused kernel ([`fused::row`]): the lower
    /// blocks read transposed, then the row's own, in column order.
    ///
    /// # Safety
    /// As [`fused::row`]: only where [`fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn fused_rows_avx512<const C: usize>(
        &self,
        first: usize,
        xt: &[fused::CaseRows],
        ys: &mut [Cols<C>],
    ) {
        for (p, yp) in (first..).zip(ys.iter_mut()) {
            let low = &self.low[self.low_start[p]..self.low_start[p + 1]];
            let own = self.row_start[p]..self.row_start[p + 1];
            *yp = fused::row(
                xt,
                low,
                &self.block,
                &self.col[own.clone()],
                &self.block[own],
            );
        }
    }

    /// The most blocks in one row of the full matrix.
    pub(crate) fn max_row_blocks(&self) -> usize {
        self.max_row_blocks
    }
}

impl RowProducts for UpperBlocks {
    #[inline(always)]
    fn row_product<const C: usize>(&self, p: usize, x: &[Cols<C>], cols: usize) -> Cols<C> {
        self.row_times(p, x, cols)
    }

    unsafe fn fused_rows<const C: usize>(
        &self,
        first: usize,
        xt: &[fused::CaseRows],
        ys: &mut [Cols<C>],
    ) {
        self.fused_rows_avx512(first, xt, ys)
    }
}

/// K X of a matrix applied row by row (the springs' [`UpperBlocks`] and
/// [`super::bond_springs::BondSprings`]): the chunked, parallel products the CG takes, from
/// each one's row kernel and its fused kernel on X transposed.
pub(crate) trait RowProducts: Sync {
    /// Row `p` of K X on the first `cols` load cases (unfused; always inlined, so that it is
    /// compiled for AVX2 inside [`avx2!`]).
    fn row_product<const C: usize>(&self, p: usize, x: &[Cols<C>], cols: usize) -> Cols<C>;

    /// Rows `first..` of K X into `ys` by the fused kernel on X transposed (`xt`).
    ///
    /// # Safety
    /// Only where [`fused::available`].
    unsafe fn fused_rows<const C: usize>(
        &self,
        first: usize,
        xt: &[fused::CaseRows],
        ys: &mut [Cols<C>],
    );

    /// Y = K X on the first `cols` load cases, with AVX2 where the processor has it.
    fn apply_cols<const C: usize>(&self, x: &[Cols<C>], y: &mut [Cols<C>], cols: usize) {
        self.apply_cols_then(x, y, cols, 512, |_, _| ());
    }

    /// [`Self::apply_cols`] by chunks of `rows` rows, calling `then(first row, chunk of Y)`
    /// on each chunk as soon as it is computed (while it is in cache); the chunks' results
    /// in order.
    fn apply_cols_then<T: Send, const C: usize>(
        &self,
        x: &[Cols<C>],
        y: &mut [Cols<C>],
        cols: usize,
        rows: usize,
        then: impl Fn(usize, &[Cols<C>]) -> T + Sync,
    ) -> Vec<T> {
        fused::with_transposed(x, cols, |xt| self.chunks_then(x, xt, y, cols, rows, then))
    }

    /// [`Self::apply_cols_then`] with X also given transposed (`xt`, each row as
    /// [`fused::CaseRows::of`] makes it): the fused kernels read it instead of transposing X
    /// again. The same bits.
    fn apply_transposed_then<T: Send, const C: usize>(
        &self,
        x: &[Cols<C>],
        xt: &[fused::CaseRows],
        y: &mut [Cols<C>],
        cols: usize,
        rows: usize,
        then: impl Fn(usize, &[Cols<C>]) -> T + Sync,
    ) -> Vec<T> {
        assert_eq!(xt.len(), x.len(), "X and X transposed differ in length");
        let xt = fused::runs::<C>().then_some(xt);
        self.chunks_then(x, xt, y, cols, rows, then)
    }

    /// The chunks of [`Self::apply_cols_then`]: by the fused kernel on `xt` when given (only
    /// where the fused kernels run), else row by row on `x`.
    fn chunks_then<T: Send, const C: usize>(
        &self,
        x: &[Cols<C>],
        xt: Option<&[fused::CaseRows]>,
        y: &mut [Cols<C>],
        cols: usize,
        rows: usize,
        then: impl Fn(usize, &[Cols<C>]) -> T + Sync,
    ) -> Vec<T> {
        y.par_chunks_mut(rows)
            .enumerate()
            .map(|(c, ys)| {
                let first = c * rows;
                match xt {
                    // SAFETY: `xt` is given only where the fused kernels run.
                    Some(xt) => unsafe { self.fused_rows(first, xt, ys) },
                    None => avx2!({
                        for (p, yp) in (first..).zip(ys.iter_mut()) {
                            *yp = self.row_product(p, x, cols);
                        }
                    }),
                }
                then(first, ys)
            })
            .collect()
    }
}

/// `avx2!(expr)`: `expr` evaluated in code compiled for AVX2 where the processor has it
/// ([`with_avx2`] of an always-inlined closure): the 6×6 kernels below then run four lanes
/// wide instead of two, with the same operations (no fused multiply-add) in the same order,
/// so the same bits. The closure must be inlined into the function with the feature, else
/// it is compiled without it (the K product of every relaxed solve ran two lanes wide so:
/// 18 % slower); the macro gives it `#[inline(always)]` so no caller can forget.
macro_rules! avx2 {
    ($body:expr) => {
        $crate::homogenize::sparse::with_avx2(
            #[inline(always)]
            || $body,
        )
    };
}
pub(crate) use avx2;

/// `f()` compiled for AVX2 where the processor has it, provided `f` is inlined into it:
/// called through [`avx2!`], which makes sure it is.
#[inline(always)]
pub(crate) fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn run<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        // SAFETY: the processor has AVX2 (checked above).
        return unsafe { run(f) };
    }
    f()
}

/// acc += a·b for 6×6 blocks: an unrolled column-major kernel (nalgebra's generic product
/// of fixed 6×6 matrices goes through its gemm path and is several times slower here).
#[inline(always)]
pub(crate) fn mul_add6(acc: &mut Block6, a: &Block6, b: &Block6) {
    mul_add_columns(acc, a, b, 6);
}

/// [`mul_add6`] on the first `cols` columns of b (and of acc), of `C` load cases; all `C`
/// when `cols` ≥ `C`, by the same kernel and in the same order.
#[inline(always)]
pub(crate) fn mul_add6_cols<const C: usize>(
    acc: &mut Cols<C>,
    a: &Block6,
    b: &Cols<C>,
    cols: usize,
) {
    if cols >= C {
        return mul_add_columns(acc, a, b, C);
    }
    mul_add_columns(acc, a, b, cols);
}

/// The kernel of [`mul_add6`] and [`mul_add6_cols`]: acc[:, j] += a·b[:, j] for j < `cols`,
/// column by column. Always inlined, so a constant `cols` (6 in [`mul_add6`]) unrolls.
#[inline(always)]
fn mul_add_columns<const C: usize>(acc: &mut Cols<C>, a: &Block6, b: &Cols<C>, cols: usize) {
    let a: &[f64; 36] = a.as_slice().try_into().expect("a 6×6 block has 36 entries");
    mul_add_columns_of(acc, a, b, cols);
}

/// [`mul_add_columns`] with `a` as its 36 column-major entries (the multigrid's
/// single-precision blocks widen into such an array first).
#[inline(always)]
pub(crate) fn mul_add_columns_of<const C: usize>(
    acc: &mut Cols<C>,
    a: &[f64; 36],
    b: &Cols<C>,
    cols: usize,
) {
    let b = b.as_slice();
    let c = acc.as_mut_slice();
    for j in 0..cols {
        let mut col = [0.0f64; 6];
        col.copy_from_slice(&c[6 * j..6 * j + 6]);
        for k in 0..6 {
            let s = b[k + 6 * j];
            let ak = &a[6 * k..6 * k + 6];
            for i in 0..6 {
                col[i] += ak[i] * s;
            }
        }
        c[6 * j..6 * j + 6].copy_from_slice(&col);
    }
}

/// acc += aᵀ·b on the first `cols` columns of b, reading `a` transposed in place: the same
/// products summed in the same order as [`mul_add6_cols`] on an explicitly transposed block,
/// so the same bits without storing the transpose.
#[inline(always)]
pub(crate) fn mul_add6_transposed_cols<const C: usize>(
    acc: &mut Cols<C>,
    a: &Block6,
    b: &Cols<C>,
    cols: usize,
) {
    let a = a.as_slice();
    // aᵀ column-major in registers: (aᵀ)[i, k] = a[k, i], stored at 6 i + k; the kernel
    // then reads contiguous columns (strided reads kept it scalar).
    let t: [f64; 36] = std::array::from_fn(|n| a[6 * (n % 6) + n / 6]);
    mul_add_columns_of(acc, &t, b, cols.min(C));
}

/// a·b on the first `cols` columns of b (see [`mul_add6_cols`]).
#[inline(always)]
pub(crate) fn mul6_cols<const C: usize>(a: &Block6, b: &Cols<C>, cols: usize) -> Cols<C> {
    let mut c = Cols::<C>::zeros();
    mul_add6_cols(&mut c, a, b, cols);
    c
}

/// a·b for 6×6 blocks (see [`mul_add6`]).
#[inline(always)]
pub(crate) fn mul6(a: &Block6, b: &Block6) -> Block6 {
    let mut c = Block6::zeros();
    mul_add6(&mut c, a, b);
    c
}

/// (Gᵀq, qᵀ(Kq)) summed over the particles in order, given Kq: the two fluctuation terms of
/// the relaxed tensor C·V = H − Gᵀq − qᵀG + qᵀKq, whatever applied K.
pub(crate) fn fluctuation_sums(g: &[Block6], q: &[Block6], kq: &[Block6]) -> (Block6, Block6) {
    let mut gtq = Block6::zeros();
    let mut qtkq = Block6::zeros();
    for p in 0..q.len() {
        gtq += g[p].transpose() * q[p];
        qtkq += q[p].transpose() * kq[p];
    }
    (gtq, qtkq)
}

/// y[:, c] += α_c x[:, c] for every load case c (the CG's x += α p, r += (−α) K p).
#[inline(always)]
pub(crate) fn add_scaled_cols<const C: usize>(y: &mut Cols<C>, x: &Cols<C>, alpha: &[f64; C]) {
    for (c, &a) in alpha.iter().enumerate() {
        for i in 0..6 {
            y[(i, c)] += x[(i, c)] * a;
        }
    }
}

/// p[:, c] ← z[:, c] + β_c p[:, c] for every load case c (the CG's next search direction).
#[inline(always)]
pub(crate) fn direction_cols<const C: usize>(p: &mut Cols<C>, z: &Cols<C>, beta: &[f64; C]) {
    for (c, &b) in beta.iter().enumerate() {
        for i in 0..6 {
            p[(i, c)] = z[(i, c)] + p[(i, c)] * b;
        }
    }
}

/// `n` copies of `zero`, written in parallel. `vec![zero; n]` of a block vector writes
/// (and faults in) its pages on one thread: about 20 ms of the CG's start at 30,000 spheres,
/// seven vectors of 8.6 MB (issue 35).
pub(crate) fn filled<T: Copy + Send + Sync>(n: usize, zero: T) -> Vec<T> {
    (0..n).into_par_iter().map(|_| zero).collect()
}

/// A copy of `x`, written in parallel (as [`filled`]).
pub(crate) fn copied<T: Copy + Send + Sync>(x: &[T]) -> Vec<T> {
    x.par_iter().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block with entries that are not round numbers, different for every seed.
    fn block(seed: usize) -> Block6 {
        Block6::from_fn(|i, j| {
            ((seed * 31 + i * 7 + j * 13) % 17) as f64 / 3.0 - 2.7 + 1e-3 * seed as f64
        })
    }

    /// A matrix of a ring with chords, a repeated edge (a bond to two images of one
    /// neighbour) and a self edge (a bond to the particle's own image).
    fn matrix() -> BlockSparse {
        let n = 23;
        let mut ends: Vec<(u32, u32)> = (0..n).map(|i| (i, (i + 1) % n)).collect();
        ends.extend((0..n).step_by(3).map(|i| ((i + 7) % n, i)));
        ends.push((4, 5));
        ends.push((9, 9));
        BlockSparse::assemble_blocks(n as usize, &ends, |e| {
            let a = block(e);
            (
                a * a.transpose(),
                block(e + 100) * block(e + 100).transpose(),
                block(e + 200),
            )
        })
    }

    /// The transposed kernel gives the bits of the plain kernel on the explicit transpose.
    #[test]
    fn transposed_kernel_equals_the_explicit_transpose() {
        for cols in [1, 4, 6] {
            let (a, b) = (block(1), block(2));
            let mut plain = block(3);
            let mut read = plain;
            mul_add6_cols(&mut plain, &a.transpose(), &b, cols);
            mul_add6_transposed_cols(&mut read, &a, &b, cols);
            assert_eq!(plain, read, "{cols} columns");
        }
    }

    /// The upper triangle multiplies with the full matrix's bits and reads its rows alike.
    #[test]
    fn upper_triangle_gives_the_full_products_bit_for_bit() {
        let k = matrix();
        let upper = UpperBlocks::of(&k).expect("assembled blocks mirror exactly");
        assert_eq!(upper.max_row_blocks(), k.max_row_blocks());
        let x: Vec<Block6> = (0..k.rows()).map(|p| block(p + 300)).collect();
        for cols in [2, 6] {
            let (mut full, mut half) = (
                vec![Block6::zeros(); k.rows()],
                vec![Block6::zeros(); k.rows()],
            );
            k.apply_cols(&x, &mut full, cols);
            upper.apply_cols(&x, &mut half, cols);
            assert_eq!(full, half, "{cols} columns");
        }
        for p in 0..k.rows() {
            let mut read = Vec::new();
            upper.each_in_row(p, |q, b| read.push((q, *b)));
            let want: Vec<(usize, Block6)> = k.row(p).map(|(q, b)| (q, *b)).collect();
            assert_eq!(read, want, "row {p}");
            assert_eq!(BlockRows::diagonal(&upper, p), k.diagonal(p));
        }
    }

    /// Two upper triangles are the same bit for bit: blocks, lower lists, the longest row.
    fn assert_same_triangle(a: &UpperBlocks, b: &UpperBlocks) {
        assert_eq!(a.row_start, b.row_start);
        assert_eq!(a.col, b.col);
        assert!(a.block == b.block);
        assert_eq!(a.low_start, b.low_start);
        assert_eq!(a.low, b.low);
        assert_eq!(a.max_row_blocks, b.max_row_blocks);
    }

    /// A matrix whose mirrored blocks differ (in one bit, or a missing mirror) is refused.
    #[test]
    fn upper_triangle_refuses_an_unmirrored_matrix() {
        let k = matrix();
        let rows = |change: &dyn Fn(usize, usize, &mut Block6) -> bool| {
            let rows: Vec<Vec<(u32, Block6)>> = (0..k.rows())
                .map(|p| {
                    k.row(p)
                        .filter_map(|(q, b)| {
                            let mut b = *b;
                            change(p, q, &mut b).then_some((q as u32, b))
                        })
                        .collect()
                })
                .collect();
            BlockSparse::from_rows(rows)
        };
        let nudged = rows(&|p, q, b| {
            if (p, q) == (5, 4) {
                b[(1, 2)] = f64::from_bits(b[(1, 2)].to_bits() ^ 1);
            }
            true
        });
        assert!(UpperBlocks::of(&nudged).is_none());
        assert!(UpperBlocks::of_owned(nudged).is_err());
        let missing = rows(&|p, q, _| (p, q) != (4, 5));
        assert!(UpperBlocks::of(&missing).is_none());
        assert!(UpperBlocks::of(&rows(&|_, _, _| true)).is_some());
    }

    /// The triangle compacted in place from a matrix given away is the copied one, bit for
    /// bit (blocks, lower lists, the longest row).
    #[test]
    fn upper_triangle_compacted_in_place_equals_the_copied_one() {
        let k = matrix();
        let copied = UpperBlocks::of(&k).expect("mirrored");
        let Ok(owned) = UpperBlocks::of_owned(k) else {
            panic!("mirrored")
        };
        assert_same_triangle(&owned, &copied);
    }

    /// K assembled row by row (each element formed at both of its rows) is K assembled from
    /// all elements at once, bit for bit, with a repeated edge and a self edge, and so are
    /// its product and diagonal streamed without storing it; the in-place block map rewrites
    /// each block given its own row and column.
    #[test]
    fn rows_assembled_in_place_equal_the_elementwise_assembly() {
        let n = 23;
        let mut ends: Vec<(u32, u32)> = (0..n).map(|i| (i, (i + 1) % n)).collect();
        ends.extend((0..n).step_by(3).map(|i| ((i + 7) % n, i)));
        ends.push((4, 5));
        ends.push((9, 9));
        let blocks = |e: usize| (block(e), block(e + 100), block(e + 200));
        let rows = BlockSparse::assemble_rows(n as usize, &ends, blocks);
        let all = BlockSparse::assemble_blocks(n as usize, &ends, blocks);
        assert_eq!(rows.row_start, all.row_start);
        assert_eq!(rows.col, all.col);
        assert!(rows.block == all.block);
        let x: Vec<Block6> = (0..n as usize).map(|p| block(p + 300)).collect();
        let mut kx = vec![Block6::zeros(); n as usize];
        all.apply(&x, &mut kx);
        let (streamed, diagonal) = BlockSparse::assemble_rows_times(n as usize, &ends, blocks, &x);
        assert_eq!(streamed, kx);
        let stored: Vec<Block6> = (0..all.rows()).map(|p| all.diagonal(p)).collect();
        assert_eq!(diagonal, stored);
        let mut mapped = all;
        mapped.map_blocks(|p, q, b| b[(0, 0)] = (100 * p + q) as f64);
        for p in 0..mapped.rows() {
            for (q, b) in mapped.row(p) {
                assert_eq!(b[(0, 0)], (100 * p + q) as f64);
            }
        }
    }
}
