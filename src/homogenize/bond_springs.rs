//! K of the bond network applied bond by bond, without its off-diagonal blocks (issue 35).
//!
//! Every off-diagonal block of K is one bond's B_rᵀ S B_o − R (Kruyt 2014 Eqs. 10–14,
//! network.rs), and it has few free numbers. With N = [n]× the cross-product matrix of the
//! bond's unit normal (pointing from row r's particle to the other end o), S = k_s I +
//! (k_n − k_s) nn, B_r = [−I, a N], B_o = [I, b N] (a, b the contact arms of r and o):
//! S N = N S = k_s N, since N n = 0, so
//!
//! K_ro = [[−S − S_g, −b k_s N], [−a k_s N, (ab k_s − k_r) I − (ab k_s + k_tw − k_r) nn]],
//!
//! with S_g = (N_ax/l)(I − nn) the preload's geometric stiffness on the translations
//! ([`super::network::geometric_element`]). Nine numbers per bond end (72 bytes) instead of
//! the 288 of a stored block, read twice: the CG's product with K reads a quarter of the
//! memory, and forms the block's product in 38 vector operations instead of 36 fused
//! multiply-adds of broadcast entries. The diagonal blocks are kept as assembled (the same
//! bits as [`super::sparse::UpperBlocks`]'): the block-Jacobi pieces and the coarse space
//! read them.

use super::fused::CaseRows;
use super::network::{csr, Block6, Cols, HalfBond, Network};
use super::sparse::{filled, mul_add6_cols, BlockRows, RowProducts};
use rayon::prelude::*;

/// The springs' K of a network: its diagonal blocks assembled, the rest applied bond end by
/// bond end from [`HalfBond`]s.
pub(crate) struct BondSprings {
    /// Row r's bond ends (CSR): the other particle and the coefficients of K_ro, the bonds in
    /// order (a bond of a particle to its own image sits in the diagonal block instead).
    start: Vec<usize>,
    other: Vec<u32>,
    half: Vec<HalfBond>,
    /// K_rr, summed as [`super::sparse::BlockSparse::assemble`] sums it.
    diag: Vec<Block6>,
    /// The most bond ends in one row, plus one (the diagonal).
    max_row_blocks: usize,
}

impl BondSprings {
    /// K of `net` (before its springs are released): each row's ends counted, then written
    /// in parallel straight into their place.
    pub(crate) fn of(net: &Network) -> BondSprings {
        const ROWS: usize = 1024;
        let m = net.n_active;
        let (start, edges) = csr(m, net.end_pairs(), |k, _| k as u32);
        let self_bond = |e: u32| {
            let (pi, pj) = net.ends[e as usize];
            pi == pj
        };
        // A bond to the particle's own image is listed twice in its row, and sits in the
        // diagonal block instead of among the ends.
        let counts: Vec<usize> = (0..m)
            .into_par_iter()
            .map(|r| {
                let listed = &edges[start[r]..start[r + 1]];
                listed.len() - listed.iter().filter(|&&e| self_bond(e)).count()
            })
            .collect();
        let mut row_start = Vec::with_capacity(m + 1);
        row_start.push(0);
        for c in &counts {
            row_start.push(row_start.last().copied().unwrap_or(0) + c);
        }
        let total = row_start[m];
        let mut other = filled(total, 0u32);
        let mut half = filled(total, HalfBond::default());
        let mut diag = filled(m, Block6::zeros());
        // Every chunk of ROWS rows with its share of the three arrays.
        let mut parts = Vec::with_capacity(m.div_ceil(ROWS));
        let (mut o_rest, mut h_rest, mut d_rest) = (&mut other[..], &mut half[..], &mut diag[..]);
        for r0 in (0..m).step_by(ROWS) {
            let r1 = (r0 + ROWS).min(m);
            let len = row_start[r1] - row_start[r0];
            let (o, ot) = o_rest.split_at_mut(len);
            let (h, ht) = h_rest.split_at_mut(len);
            let (d, dt) = d_rest.split_at_mut(r1 - r0);
            (o_rest, h_rest, d_rest) = (ot, ht, dt);
            parts.push((r0, o, h, d));
        }
        parts.into_par_iter().for_each(|(r0, o, h, d)| {
            let mut at = 0;
            for (r, dr) in (r0..).zip(d.iter_mut()) {
                let mut last = u32::MAX;
                for &e in &edges[start[r]..start[r + 1]] {
                    if e == last {
                        continue;
                    }
                    last = e;
                    let (pi, pj) = net.ends[e as usize];
                    if pi == pj {
                        // The diagonal's parts in the order of the assembled rows: per bond,
                        // K_ii, K_jj, K_ij, K_ijᵀ.
                        let (kii, kjj, kij) = net.stiffness_blocks(e as usize);
                        *dr += kii;
                        *dr += kjj;
                        *dr += kij;
                        *dr += kij.transpose();
                        continue;
                    }
                    let at_i = pi as usize == r;
                    *dr += net.own_block(e as usize, at_i);
                    o[at] = if at_i { pj } else { pi };
                    h[at] = net.half_bond(e as usize, at_i);
                    at += 1;
                }
            }
        });
        let max_row_blocks = 1 + counts.into_iter().max().unwrap_or(0);
        BondSprings {
            start: row_start,
            other,
            half,
            diag,
            max_row_blocks,
        }
    }

    /// The most blocks in one row of K (the bond ends plus the diagonal).
    pub(crate) fn max_row_blocks(&self) -> usize {
        self.max_row_blocks
    }

    /// Row `p` of K X on the first `cols` load cases: the diagonal block, then the bond ends
    /// in order.
    #[inline(always)]
    pub(crate) fn row_times<const C: usize>(
        &self,
        p: usize,
        x: &[Cols<C>],
        cols: usize,
    ) -> Cols<C> {
        let mut acc = Cols::<C>::zeros();
        mul_add6_cols(&mut acc, &self.diag[p], &x[p], cols);
        for k in self.start[p]..self.start[p + 1] {
            self.half[k].mul_add(&mut acc, &x[self.other[k] as usize], cols.min(C));
        }
        acc
    }

    /// Rows `first..` of K X into `ys` by the fused kernel ([`fused_row`]).
    ///
    /// # Safety
    /// Only where [`super::fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn fused_rows_avx512<const C: usize>(
        &self,
        first: usize,
        xt: &[CaseRows],
        ys: &mut [Cols<C>],
    ) {
        for (p, yp) in (first..).zip(ys.iter_mut()) {
            let ends = self.start[p]..self.start[p + 1];
            *yp = fused_row(
                xt,
                p,
                &self.diag[p],
                &self.other[ends.clone()],
                &self.half[ends],
            );
        }
    }
}

impl RowProducts for BondSprings {
    #[inline(always)]
    fn row_product<const C: usize>(&self, p: usize, x: &[Cols<C>], cols: usize) -> Cols<C> {
        self.row_times(p, x, cols)
    }

    unsafe fn fused_rows<const C: usize>(&self, first: usize, xt: &[CaseRows], ys: &mut [Cols<C>]) {
        self.fused_rows_avx512(first, xt, ys)
    }
}

impl HalfBond {
    /// acc += K_ro x on the first `cols` load cases, column by column (module doc).
    #[inline(always)]
    fn mul_add<const C: usize>(&self, acc: &mut Cols<C>, x: &Cols<C>, cols: usize) {
        let [n0, n1, n2] = self.normal;
        let (xs, ys) = (x.as_slice(), acc.as_mut_slice());
        for j in 0..cols {
            let v = &xs[6 * j..6 * j + 6];
            let (u, w) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
            let du = n0 * u[0] + n1 * u[1] + n2 * u[2];
            let dw = n0 * w[0] + n1 * w[1] + n2 * w[2];
            let cu = [
                n1 * u[2] - n2 * u[1],
                n2 * u[0] - n0 * u[2],
                n0 * u[1] - n1 * u[0],
            ];
            let cw = [
                n1 * w[2] - n2 * w[1],
                n2 * w[0] - n0 * w[2],
                n0 * w[1] - n1 * w[0],
            ];
            let (tu, tw) = (self.axial * du, self.turn_axial * dw);
            let y = &mut ys[6 * j..6 * j + 6];
            for k in 0..3 {
                y[k] -= self.shear * u[k] + tu * self.normal[k] + self.other_arm_shear * cw[k];
                y[k + 3] += self.turn * w[k] - self.own_arm_shear * cu[k] - tw * self.normal[k];
            }
        }
    }
}

/// One row of K X with X transposed (`xt`, [`CaseRows`]): the diagonal block `diag` on row
/// `p`, then every bond end's K_ro X_o (module doc) in order, the load cases in the lanes.
///
/// # Safety
/// The processor must have AVX-512F ([`super::fused::available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn fused_row<const C: usize>(
    xt: &[CaseRows],
    p: usize,
    diag: &Block6,
    other: &[u32],
    half: &[HalfBond],
) -> Cols<C> {
    use std::arch::x86_64::*;
    let a: &[f64; 36] = diag
        .as_slice()
        .try_into()
        .expect("a 6×6 block has 36 entries");
    let x = xt[p].rows();
    let z = _mm512_setzero_pd();
    let (mut c0, mut c1, mut c2, mut c3, mut c4, mut c5) = (z, z, z, z, z, z);
    for (k, xk) in x.iter().enumerate() {
        let xk = _mm512_load_pd(xk.as_ptr());
        c0 = _mm512_fmadd_pd(_mm512_set1_pd(a[6 * k]), xk, c0);
        c1 = _mm512_fmadd_pd(_mm512_set1_pd(a[1 + 6 * k]), xk, c1);
        c2 = _mm512_fmadd_pd(_mm512_set1_pd(a[2 + 6 * k]), xk, c2);
        c3 = _mm512_fmadd_pd(_mm512_set1_pd(a[3 + 6 * k]), xk, c3);
        c4 = _mm512_fmadd_pd(_mm512_set1_pd(a[4 + 6 * k]), xk, c4);
        c5 = _mm512_fmadd_pd(_mm512_set1_pd(a[5 + 6 * k]), xk, c5);
    }
    for (&o, h) in other.iter().zip(half) {
        let x = xt[o as usize].rows();
        let [u0, u1, u2, w0, w1, w2] = [0, 1, 2, 3, 4, 5].map(|k| _mm512_load_pd(x[k].as_ptr()));
        let [n0, n1, n2] = h.normal.map(|v| _mm512_set1_pd(v));
        let du = _mm512_fmadd_pd(n2, u2, _mm512_fmadd_pd(n1, u1, _mm512_mul_pd(n0, u0)));
        let dw = _mm512_fmadd_pd(n2, w2, _mm512_fmadd_pd(n1, w1, _mm512_mul_pd(n0, w0)));
        // n × v, each component as one product and one fused multiply-subtract.
        let cross = |a0, a1, a2| {
            [
                _mm512_fmsub_pd(n1, a2, _mm512_mul_pd(n2, a1)),
                _mm512_fmsub_pd(n2, a0, _mm512_mul_pd(n0, a2)),
                _mm512_fmsub_pd(n0, a1, _mm512_mul_pd(n1, a0)),
            ]
        };
        let cu = cross(u0, u1, u2);
        let cw = cross(w0, w1, w2);
        let tu = _mm512_mul_pd(_mm512_set1_pd(h.axial), du);
        let tw = _mm512_mul_pd(_mm512_set1_pd(h.turn_axial), dw);
        let (shear, b) = (_mm512_set1_pd(h.shear), _mm512_set1_pd(h.other_arm_shear));
        let (turn, a) = (_mm512_set1_pd(h.turn), _mm512_set1_pd(h.own_arm_shear));
        c0 = _mm512_fnmadd_pd(
            b,
            cw[0],
            _mm512_fnmadd_pd(tu, n0, _mm512_fnmadd_pd(shear, u0, c0)),
        );
        c1 = _mm512_fnmadd_pd(
            b,
            cw[1],
            _mm512_fnmadd_pd(tu, n1, _mm512_fnmadd_pd(shear, u1, c1)),
        );
        c2 = _mm512_fnmadd_pd(
            b,
            cw[2],
            _mm512_fnmadd_pd(tu, n2, _mm512_fnmadd_pd(shear, u2, c2)),
        );
        c3 = _mm512_fnmadd_pd(
            tw,
            n0,
            _mm512_fnmadd_pd(a, cu[0], _mm512_fmadd_pd(turn, w0, c3)),
        );
        c4 = _mm512_fnmadd_pd(
            tw,
            n1,
            _mm512_fnmadd_pd(a, cu[1], _mm512_fmadd_pd(turn, w1, c4)),
        );
        c5 = _mm512_fnmadd_pd(
            tw,
            n2,
            _mm512_fnmadd_pd(a, cu[2], _mm512_fmadd_pd(turn, w2, c5)),
        );
    }
    let mut lanes = CaseRows::default();
    for (row, c) in lanes.rows_mut().iter_mut().zip([c0, c1, c2, c3, c4, c5]) {
        _mm512_store_pd(row.as_mut_ptr(), c);
    }
    lanes.to_cols()
}

/// [`fused_row`] where there is no AVX-512: never called.
///
/// # Safety
/// None needed; it panics.
#[cfg(not(target_arch = "x86_64"))]
unsafe fn fused_row<const C: usize>(
    _: &[CaseRows],
    _: usize,
    _: &Block6,
    _: &[u32],
    _: &[HalfBond],
) -> Cols<C> {
    unreachable!("the fused kernels run only where `available()`")
}

impl BlockRows for BondSprings {
    fn rows(&self) -> usize {
        self.diag.len()
    }

    /// The diagonal block, then every bond end's block formed from its coefficients.
    fn each_in_row(&self, p: usize, mut f: impl FnMut(usize, &Block6)) {
        f(p, &self.diag[p]);
        for k in self.start[p]..self.start[p + 1] {
            f(self.other[k] as usize, &self.half[k].block());
        }
    }

    fn diagonal(&self, p: usize) -> Block6 {
        self.diag[p]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::homogenize::network::mrv_test_network_with;
    use crate::homogenize::sparse::BlockSparse;

    /// The networks checked: with rotations, without, and preloaded.
    fn networks() -> Vec<Network> {
        [(true, false), (false, false), (true, true)]
            .into_iter()
            .map(|(rotations, preloaded)| mrv_test_network_with(rotations, preloaded))
            .collect()
    }

    /// Every bond end's block is the assembled K's off-diagonal block to rounding, and the
    /// diagonal is the assembled one bit for bit.
    #[test]
    fn bond_ends_give_the_assembled_blocks() {
        for net in networks() {
            bond_ends_give_the_assembled_blocks_of(&net);
        }
    }

    fn bond_ends_give_the_assembled_blocks_of(net: &Network) {
        let k = BlockSparse::assemble(net);
        let springs = BondSprings::of(net);
        for p in 0..k.rows() {
            assert_eq!(springs.diagonal(p), k.diagonal(p), "row {p}");
            let mut formed: Vec<(usize, Block6)> = Vec::new();
            springs.each_in_row(p, |q, b| match formed.iter_mut().find(|(c, _)| *c == q) {
                Some((_, s)) => *s += b,
                None => formed.push((q, *b)),
            });
            formed.sort_by_key(|(q, _)| *q);
            let assembled: Vec<(usize, Block6)> = k.row(p).map(|(q, b)| (q, *b)).collect();
            assert_eq!(formed.len(), assembled.len(), "row {p}");
            for ((q, a), (c, b)) in formed.iter().zip(&assembled) {
                assert_eq!(q, c);
                let scale = b.amax();
                assert!(
                    (a - b).amax() <= 1e-14 * scale,
                    "row {p} col {q}: {a} vs {b}"
                );
            }
        }
    }

    /// K X bond by bond (both kernels) is the assembled product to rounding.
    #[test]
    fn products_are_the_assembled_products() {
        for net in networks() {
            products_are_the_assembled_products_of(&net);
        }
    }

    fn products_are_the_assembled_products_of(net: &Network) {
        let k = BlockSparse::assemble(net);
        let springs = BondSprings::of(net);
        let m = k.rows();
        let x: Vec<Block6> = (0..m)
            .map(|p| Block6::from_fn(|i, j| ((p * 36 + i * 6 + j) as f64 * 0.37).sin()))
            .collect();
        let mut want = vec![Block6::zeros(); m];
        k.apply(&x, &mut want);
        let scale = want.iter().map(|b| b.amax()).fold(0.0, f64::max);
        // The fused kernel (where it runs) on six and three load cases, and the row kernel.
        let by_rows = |cols| (0..m).map(|p| springs.row_times(p, &x, cols)).collect();
        for (cols, got) in [
            (6, None),
            (3, None),
            (6, Some(by_rows(6))),
            (2, Some(by_rows(2))),
        ] {
            let got: Vec<Block6> = got.unwrap_or_else(|| {
                let mut y = vec![Block6::zeros(); m];
                springs.apply_cols(&x, &mut y, cols);
                y
            });
            for p in 0..m {
                for j in 0..6 {
                    let w = if j < cols {
                        want[p].column(j).into_owned()
                    } else {
                        nalgebra::Vector6::zeros()
                    };
                    let d = (got[p].column(j) - w).amax();
                    assert!(d <= 1e-13 * scale, "row {p} column {j}: {d:e}");
                }
            }
        }
    }
}
