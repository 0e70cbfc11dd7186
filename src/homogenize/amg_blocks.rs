//! Compact storage of the multigrid preconditioner's operators (`amg.rs`): 6×6 blocks in
//! single precision, rows in CSR form, applied in double precision. The V-cycle then is
//! the exact V-cycle of the rounded operators Ã, P̃ (symmetric as A, and Pᵀ the exact
//! transpose of P̃), so it stays a fixed symmetric positive preconditioner of the CG on the
//! double-precision K: only its quality changes (by about 1e-7 relative), not the answer,
//! which the CG's residual test on K sets. Half the bytes per block: half the memory of
//! the coarse levels and transfers, and of their traffic in every cycle.

use super::network::Block6;
use rayon::prelude::*;

/// A 6×6 block in single precision, column-major as [`Block6`].
pub(crate) type Block32 = [f32; 36];

/// The block rounded to single precision.
pub(crate) fn to_f32(b: &Block6) -> Block32 {
    std::array::from_fn(|k| b.as_slice()[k] as f32)
}

/// acc[:, j] += a·b[:, j] for j < `cols`, a widened to double precision first.
#[inline(always)]
fn mul_add32_cols(acc: &mut Block6, a: &Block32, b: &Block6, cols: usize) {
    let a: [f64; 36] = std::array::from_fn(|k| a[k] as f64);
    super::sparse::mul_add_columns_of(acc, &a, b, cols);
}

/// Σ_q B_pq x_q over row `p`'s blocks, in stored order, on the first `cols` columns.
#[inline(always)]
fn row_product(cols_of_row: &[u32], blocks: &[Block32], x: &[Block6], cols: usize) -> Block6 {
    let mut acc = Block6::zeros();
    if cols >= 6 {
        for (c, b) in cols_of_row.iter().zip(blocks) {
            mul_add32_cols(&mut acc, b, &x[*c as usize], 6);
        }
    } else {
        for (c, b) in cols_of_row.iter().zip(blocks) {
            mul_add32_cols(&mut acc, b, &x[*c as usize], cols);
        }
    }
    acc
}

/// Rows of single-precision 6×6 blocks (CSR): a level's matrix, a prolongator or its
/// transpose.
pub(crate) struct CompactRows {
    start: Vec<usize>,
    col: Vec<u32>,
    block: Vec<Block32>,
}

impl CompactRows {
    /// From rows given as (column, block) iterators, rounded to single precision.
    pub(crate) fn from_rows<'a, I, R>(rows: I) -> CompactRows
    where
        I: Iterator<Item = R>,
        R: Iterator<Item = (u32, &'a Block6)>,
    {
        let mut start = vec![0usize];
        let mut col = Vec::new();
        let mut block = Vec::new();
        for r in rows {
            for (c, b) in r {
                col.push(c);
                block.push(to_f32(b));
            }
            start.push(col.len());
        }
        CompactRows { start, col, block }
    }

    /// Memory held (bytes).
    pub(crate) fn bytes(&self) -> usize {
        self.block.len() * std::mem::size_of::<Block32>()
            + self.col.len() * 4
            + self.start.len() * 8
    }

    fn row(&self, p: usize) -> (&[u32], &[Block32]) {
        let (a, b) = (self.start[p], self.start[p + 1]);
        (&self.col[a..b], &self.block[a..b])
    }

    /// y = B x (`add`: y += B x) on the first `cols` columns, rows in parallel, each row
    /// summed in stored order (the same bits on any thread count).
    pub(crate) fn apply(&self, x: &[Block6], y: &mut [Block6], cols: usize, add: bool) {
        y.par_iter_mut().enumerate().for_each(|(p, yp)| {
            let (c, b) = self.row(p);
            let s = row_product(c, b, x, cols);
            if add {
                *yp += s;
            } else {
                *yp = s;
            }
        });
    }

    /// r = b − B x on the first `cols` columns.
    pub(crate) fn residual(&self, b: &[Block6], x: &[Block6], r: &mut [Block6], cols: usize) {
        r.par_iter_mut()
            .zip(b.par_iter())
            .enumerate()
            .for_each(|(p, (rp, bp))| {
                let (c, blk) = self.row(p);
                *rp = bp - row_product(c, blk, x, cols);
            });
    }

    /// r −= B d on the first `cols` columns.
    pub(crate) fn subtract_product(&self, d: &[Block6], r: &mut [Block6], cols: usize) {
        r.par_iter_mut().enumerate().for_each(|(p, rp)| {
            let (c, blk) = self.row(p);
            *rp -= row_product(c, blk, d, cols);
        });
    }
}
