//! K X with fused multiply-adds, the load cases in the lanes (AVX-512; issue 35).
//!
//! The CG multiplies K by six load cases at once. [`super::sparse`]'s kernels run along a
//! block's column (six DOFs: a 4 + 2 lane split) and must transpose every block read from
//! the lower triangle. Here X is first transposed particle by particle ([`CaseRows`]: each
//! DOF a row of eight lanes, one per load case), after which every block, read straight or
//! transposed, is 36 fused multiply-adds of a broadcast entry by a row of X. Each entry of
//! K X is still the sum over the row's blocks in column order and, within a block, over
//! its six columns in order, as in [`super::sparse::mul_add6_cols`]: the same sums, each
//! product added without its own rounding. So the bits are those of the unfused kernels
//! with every `a * b + c` replaced by `a.mul_add(b, c)`; on a processor without AVX-512 the
//! callers keep the unfused kernels (and their bits). Either way the bits do not depend on
//! the thread count.

use super::network::{Block6, Cols};
use rayon::prelude::*;
use std::cell::RefCell;

/// One particle's block of X transposed: its six DOFs as rows of eight lanes, lane j the
/// load case j (lanes at or past the live columns hold zero), aligned for whole-row loads.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct CaseRows([[f64; 8]; 6]);

/// Whether the fused kernels run on blocks of `C` load cases: on a processor with AVX-512F
/// and for three load cases or more. One or two (a specimen) would fill one or two of the
/// eight lanes while the transposed copy of X read at random takes eight: at 1,000,000
/// spheres the periodic specimen took 59.2 s so against 52.5 s unfused.
#[inline]
pub(crate) fn runs<const C: usize>() -> bool {
    C > 2 && available()
}

/// Whether this processor has the fused kernels' instructions (AVX-512F; its detection is
/// cached).
#[inline]
pub(crate) fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

thread_local! {
    /// The transposed X of the calling thread's last product, kept so that each product
    /// does not fault in fresh pages (11.5 MB at 30,000 particles).
    static SCRATCH: RefCell<Vec<CaseRows>> = const { RefCell::new(Vec::new()) };
}

/// `f(Some(X transposed))` on the first `cols` load cases when the fused kernels run on
/// them ([`runs`]), else `f(None)` (the caller's unfused path).
pub(crate) fn with_transposed<R, const C: usize>(
    x: &[Cols<C>],
    cols: usize,
    f: impl FnOnce(Option<&[CaseRows]>) -> R,
) -> R {
    if !runs::<C>() {
        return f(None);
    }
    let live = cols.min(C);
    let fill = |xt: &mut Vec<CaseRows>| {
        xt.resize(x.len(), CaseRows::default());
        xt.par_iter_mut()
            .with_min_len(1024)
            .zip(x.par_iter().with_min_len(1024))
            .for_each(|(t, xq)| {
                let s = xq.as_slice();
                for (k, row) in t.0.iter_mut().enumerate() {
                    for (j, lane) in row.iter_mut().enumerate() {
                        *lane = if j < live { s[k + 6 * j] } else { 0.0 };
                    }
                }
            });
    };
    // A nested product on the same thread (work stolen while this one waits) gets its own.
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut xt) => {
            fill(&mut xt);
            f(Some(&xt))
        }
        Err(_) => {
            let mut xt = Vec::new();
            fill(&mut xt);
            f(Some(&xt))
        }
    })
}

/// One row of K X: Σ_q K_pq X_q over the blocks read transposed, (q, at) in `low` with
/// K_pq = `blocks[at]`ᵀ (the lower triangle read from the rows above), and then the row's
/// own, K_pq = `own[k]` at q = `cols[k]`, in that order, with `xt` = X transposed
/// ([`with_transposed`]). Plain slices, no iterator: a call left in the loop would spill
/// the accumulators to the stack at every block (every vector register is caller-saved).
///
/// # Safety
/// The processor must have AVX-512F ([`available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn row<const C: usize>(
    xt: &[CaseRows],
    low: &[(u32, u32)],
    blocks: &[Block6],
    cols: &[u32],
    own: &[Block6],
) -> Cols<C> {
    use std::arch::x86_64::*;
    // Six accumulators as plain locals (an array of them was kept on the stack between the
    // two loops and reloaded for every block).
    let z = _mm512_setzero_pd();
    let (mut c0, mut c1, mut c2, mut c3, mut c4, mut c5) = (z, z, z, z, z, z);
    // One block: c_i += Σ_k a[at(i, k)] x_k, k = 0..6 in order.
    macro_rules! block {
        ($q:expr, $a:expr, $at:expr) => {{
            let a: &[f64; 36] = $a
                .as_slice()
                .try_into()
                .expect("a 6×6 block has 36 entries");
            let x = &xt[$q].0;
            for k in 0..6 {
                let xk = _mm512_load_pd(x[k].as_ptr());
                c0 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(0, k)]), xk, c0);
                c1 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(1, k)]), xk, c1);
                c2 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(2, k)]), xk, c2);
                c3 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(3, k)]), xk, c3);
                c4 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(4, k)]), xk, c4);
                c5 = _mm512_fmadd_pd(_mm512_set1_pd(a[$at(5, k)]), xk, c5);
            }
        }};
    }
    // (aᵀ)[i, k] = a[k, i], column-major at k + 6 i.
    for &(q, at) in low {
        block!(q as usize, &blocks[at as usize], |i: usize, k: usize| k + 6
            * i);
    }
    for (&q, a) in cols.iter().zip(own) {
        block!(q as usize, a, |i: usize, k: usize| i + 6 * k);
    }
    let mut lanes = CaseRows::default();
    for (row, c) in lanes.0.iter_mut().zip([c0, c1, c2, c3, c4, c5]) {
        _mm512_store_pd(row.as_mut_ptr(), c);
    }
    Cols::<C>::from_fn(|i, j| lanes.0[i][j])
}

/// [`row`] where there is no AVX-512: never called ([`available`] is false).
///
/// # Safety
/// None needed; it panics.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) unsafe fn row<const C: usize>(
    _: &[CaseRows],
    _: &[(u32, u32)],
    _: &[Block6],
    _: &[u32],
    _: &[Block6],
) -> Cols<C> {
    unreachable!("the fused kernels run only where `available()`")
}

impl CaseRows {
    /// `x` transposed on its first `cols` load cases (the other lanes zero).
    #[inline(always)]
    pub(crate) fn of<const C: usize>(x: &Cols<C>, cols: usize) -> CaseRows {
        let (s, live) = (x.as_slice(), cols.min(C));
        let mut t = CaseRows::default();
        for (k, row) in t.0.iter_mut().enumerate() {
            for (j, lane) in row.iter_mut().take(live).enumerate() {
                *lane = s[k + 6 * j];
            }
        }
        t
    }

    /// The six DOF rows.
    #[inline(always)]
    pub(crate) fn rows(&self) -> &[[f64; 8]; 6] {
        &self.0
    }

    /// The six DOF rows, to write.
    #[inline(always)]
    pub(crate) fn rows_mut(&mut self) -> &mut [[f64; 8]; 6] {
        &mut self.0
    }

    /// Back to a block of `C` load cases.
    #[inline(always)]
    pub(crate) fn to_cols<const C: usize>(self) -> Cols<C> {
        Cols::<C>::from_fn(|i, j| self.0[i][j])
    }
}

/// acc += aᵀ x with acc and x transposed ([`CaseRows`]): acc_i += Σ_k a[k, i] x_k, k in
/// order (the sums of [`super::sparse::mul_add6_transposed_cols`], fused).
///
/// # Safety
/// The processor must have AVX-512F ([`available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn add_transposed(acc: &mut CaseRows, a: &Block6, x: &CaseRows) {
    use std::arch::x86_64::*;
    let a: &[f64; 36] = a.as_slice().try_into().expect("a 6×6 block has 36 entries");
    let mut c: [__m512d; 6] = std::array::from_fn(|i| _mm512_load_pd(acc.0[i].as_ptr()));
    for k in 0..6 {
        let xk = _mm512_load_pd(x.0[k].as_ptr());
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = _mm512_fmadd_pd(_mm512_set1_pd(a[k + 6 * i]), xk, *ci);
        }
    }
    for (row, ci) in acc.0.iter_mut().zip(c) {
        _mm512_store_pd(row.as_mut_ptr(), ci);
    }
}

/// Σ_t a_t b_t over `terms` = [(a_t, b_t)] on the first `cols` load cases (the others
/// zero), column by column in the blocks' own layout (six of eight lanes), every sum in
/// registers: column j = Σ_t Σ_k a_t[:, k] b_t[k, j], t then k in order (the sums of
/// [`super::sparse::mul_add6_cols`] from zero, fused). The accumulators never pass through
/// memory: a masked store read back at once cannot be forwarded and stalls.
///
/// # Safety
/// The processor must have AVX-512F ([`available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn straight_sum<'a, const C: usize>(
    terms: impl Iterator<Item = (&'a Block6, &'a Cols<C>)>,
    cols: usize,
) -> Cols<C> {
    use std::arch::x86_64::*;
    const SIX: __mmask8 = 0b0011_1111;
    let mut c = [_mm512_setzero_pd(); C];
    for (a, b) in terms {
        let a = a.as_slice().as_ptr();
        let ak: [__m512d; 6] = std::array::from_fn(|k| _mm512_maskz_loadu_pd(SIX, a.add(6 * k)));
        let b = b.as_slice();
        for (k, ak) in ak.iter().enumerate() {
            for (j, cj) in c.iter_mut().enumerate() {
                *cj = _mm512_fmadd_pd(*ak, _mm512_set1_pd(b[k + 6 * j]), *cj);
            }
        }
    }
    let mut out = Cols::<C>::zeros();
    let o = out.as_mut_slice().as_mut_ptr();
    for (j, cj) in c.iter().enumerate().take(cols) {
        _mm512_mask_storeu_pd(o.add(6 * j), SIX, *cj);
    }
    out
}

/// [`add_transposed`] where there is no AVX-512: never called.
///
/// # Safety
/// None needed; it panics.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) unsafe fn add_transposed(_: &mut CaseRows, _: &Block6, _: &CaseRows) {
    unreachable!("the fused kernels run only where `available()`")
}

/// [`straight_sum`] where there is no AVX-512: never called.
///
/// # Safety
/// None needed; it panics.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) unsafe fn straight_sum<'a, const C: usize>(
    _: impl Iterator<Item = (&'a Block6, &'a Cols<C>)>,
    _: usize,
) -> Cols<C> {
    unreachable!("the fused kernels run only where `available()`")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(seed: usize) -> Block6 {
        Block6::from_fn(|i, j| (((seed * 37 + i * 11 + j * 5) % 23) as f64 - 11.0) / 7.0)
    }

    /// Every entry is the unfused kernel's sum with each product fused into it: the same
    /// bits as a scalar `mul_add` chain in the same order, on every live column, and zero
    /// past them.
    #[test]
    fn a_row_is_the_fused_chain_of_the_unfused_kernel() {
        if !available() {
            eprintln!("skipped: this processor has no AVX-512F (the fused kernels do not run)");
            return;
        }
        let x: Vec<Block6> = (0..4).map(|q| block(q + 100)).collect();
        let blocks = [block(1), block(2), block(3), block(4)];
        let (low, qs) = ([(0u32, 1u32), (2, 0)], [1u32, 3]);
        let own = &blocks[2..];
        for cols in [1, 4, 6] {
            let got: Block6 = with_transposed(&x, cols, |xt| unsafe {
                row(xt.expect("available"), &low, &blocks, &qs, own)
            });
            for i in 0..6 {
                for j in 0..6 {
                    let mut want = 0.0f64;
                    if j < cols {
                        for &(q, at) in &low {
                            for k in 0..6 {
                                let a = blocks[at as usize][(k, i)];
                                want = a.mul_add(x[q as usize][(k, j)], want);
                            }
                        }
                        for (&q, a) in qs.iter().zip(own) {
                            for k in 0..6 {
                                want = a[(i, k)].mul_add(x[q as usize][(k, j)], want);
                            }
                        }
                    }
                    assert_eq!(
                        got[(i, j)].to_bits(),
                        want.to_bits(),
                        "({i}, {j}), {cols} columns"
                    );
                }
            }
        }
    }
}
