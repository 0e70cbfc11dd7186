//! Direct solve of the relaxed equilibrium K Q = G (Kruyt 2014 Eqs. 10–14) by faer's sparse
//! supernodal Cholesky factorisation LLᵀ with its approximate-minimum-degree ordering.
//!
//! K is only positive semi-definite; its null space is removed exactly, never regularised:
//! - local mechanisms (a two-bond particle's free rotation, collinear bonds, locked
//!   rotations) are null vectors of a particle's own 6×6 diagonal block, hence of K (K is
//!   PSD): each particle keeps only the range of its diagonal block as unknowns;
//! - the three rigid translations of the periodic assembly are removed by fixing the
//!   translation of one particle whose block contains them ("pinning").
//!
//! The right-hand sides are orthogonal to both (forces balance, torques about a free axis
//! vanish), so the reduced SPD system gives a solution of K Q = G that differs from any other
//! only by null vectors, which leave the tensor unchanged. A further (global) mechanism makes
//! the factorisation fail or the residual check fail: it is reported, not hidden.

use super::network::{symmetric_eigen6, Block6};
use super::sparse::{BlockSparse, Cols};
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

/// Relative eigenvalue threshold below which a direction of a diagonal block is null
/// (the same as [`super::network::pinv_psd`], so CG and Cholesky see the same range).
const NULL_THRESHOLD: f64 = 1e-10;

/// Orthonormal basis (first `rank` columns) of the range of a symmetric PSD 6×6 block; the
/// identity when the block is regular.
fn range_basis(block: &Block6) -> (Block6, usize) {
    let (values, vectors) = symmetric_eigen6(block);
    let max = values.iter().cloned().fold(0.0_f64, f64::max);
    let keep: Vec<usize> = (0..6)
        .filter(|&k| max > 0.0 && values[k] > NULL_THRESHOLD * max)
        .collect();
    if keep.len() == 6 {
        return (Block6::identity(), 6);
    }
    let mut t = Block6::zeros();
    for (c, &k) in keep.iter().enumerate() {
        t.set_column(c, &vectors.column(k));
    }
    (t, keep.len())
}

/// If the range spanned by `basis` contains the three translations, the orthonormal basis of
/// its part orthogonal to them (the rotations kept when the particle's translation is fixed).
fn pinned_basis(basis: &(Block6, usize)) -> Option<(Block6, usize)> {
    let (t, r) = basis;
    let tr = t.columns(0, *r);
    let proj = tr * tr.transpose();
    for k in 0..3 {
        let mut e = nalgebra::Vector6::zeros();
        e[k] = 1.0;
        if (proj * e - e).norm() > 1e-8 {
            return None;
        }
    }
    // proj = Π_translations + Π_(range ∩ rotations): the rotational 3×3 part is the latter.
    let rot: nalgebra::Matrix3<f64> = proj.fixed_view::<3, 3>(3, 3).into_owned();
    let eig = nalgebra::SymmetricEigen::new(rot);
    let mut out = Block6::zeros();
    let mut n = 0;
    for k in 0..3 {
        if eig.eigenvalues[k] > 0.5 {
            out.fixed_view_mut::<3, 1>(3, n)
                .copy_from(&eig.eigenvectors.column(k));
            n += 1;
        }
    }
    Some((out, n))
}

/// The faer parallelism matching the current rayon pool.
fn faer_par() -> Par {
    match rayon::current_num_threads() {
        0 | 1 => Par::Seq,
        n => Par::rayon(n),
    }
}

/// Per node the basis of its kept unknowns (the range of its diagonal block,
/// [`range_basis`]); with `pin`, the first node whose range holds the three translations
/// keeps only its rotations (the rigid translation removed). Returns the bases and the
/// pinned node (`usize::MAX` without `pin`); refuses a `pin` with no such node.
fn reduced_bases(k: &BlockSparse, pin: bool) -> Result<(Vec<(Block6, usize)>, usize)> {
    let m = k.rows();
    let mut basis: Vec<(Block6, usize)> = (0..m)
        .into_par_iter()
        .map(|p| range_basis(&k.diagonal(p)))
        .collect();
    if !pin {
        return Ok((basis, usize::MAX));
    }
    let (pinned, pb) = (0..m)
        .find_map(|p| pinned_basis(&basis[p]).map(|b| (p, b)))
        .ok_or_else(|| {
            Error::Invalid(
                "Cholesky: no particle is held in all three translations, so the rigid \
                 translation cannot be removed; use the CG solver"
                    .into(),
            )
        })?;
    basis[pinned] = pb;
    Ok((basis, pinned))
}

/// The upper triangle of the reduced matrix TᵀKT in compressed columns (column pointers,
/// row indices, values): column (q, c) holds rows (p, a) with p < q, or p = q and a ≤ c;
/// K_pq = K_qpᵀ is read from row q of the symmetric block storage.
fn reduced_upper(
    k: &BlockSparse,
    basis: &[(Block6, usize)],
    offset: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let columns: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = (0..k.rows())
        .into_par_iter()
        .map(|q| {
            let (tq, rq) = &basis[q];
            let blocks: Vec<(usize, Block6)> = k
                .row(q)
                .filter(|(p, _)| *p <= q)
                .map(|(p, kqp)| {
                    let (tp, _) = &basis[p];
                    (p, tp.transpose() * kqp.transpose() * tq)
                })
                .collect();
            let mut lens = Vec::with_capacity(*rq);
            let mut rows = Vec::new();
            let mut vals = Vec::new();
            for c in 0..*rq {
                let before = rows.len();
                for (p, b) in &blocks {
                    let rp = if *p == q { c + 1 } else { basis[*p].1 };
                    for a in 0..rp {
                        rows.push(offset[*p] + a);
                        vals.push(b[(a, c)]);
                    }
                }
                lens.push(rows.len() - before);
            }
            (lens, rows, vals)
        })
        .collect();
    let total: usize = columns.iter().map(|c| c.1.len()).sum();
    let mut col_ptr = Vec::with_capacity(offset[offset.len() - 1] + 1);
    col_ptr.push(0usize);
    let mut row_idx = Vec::with_capacity(total);
    let mut values = Vec::with_capacity(total);
    for (lens, rows, vals) in columns {
        row_idx.extend_from_slice(&rows);
        values.extend_from_slice(&vals);
        for len in lens {
            let last = col_ptr[col_ptr.len() - 1];
            col_ptr.push(last + len);
        }
    }
    (col_ptr, row_idx, values)
}

/// The numeric LLᵀ factor of `a` (upper triangle) on its symbolic analysis; refuses what
/// cannot be allocated and a matrix that is not positive definite (a global mechanism; `pin`
/// only words which null space was removed).
fn numeric_llt(
    symbolic: &SymbolicCholesky<usize>,
    a: SparseColMatRef<'_, usize, f64>,
    pin: bool,
) -> Result<Vec<f64>> {
    let mut factor = Vec::new();
    factor.try_reserve_exact(symbolic.len_val()).map_err(|_| {
        Error::Invalid(format!(
            "Cholesky: cannot allocate the factor ({} entries)",
            symbolic.len_val()
        ))
    })?;
    factor.resize(symbolic.len_val(), 0.0);
    let par = faer_par();
    let mut mem =
        MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()))
            .map_err(|_| Error::Invalid("Cholesky: cannot allocate workspace".into()))?;
    symbolic
        .factorize_numeric_llt(
            &mut factor,
            a,
            Side::Upper,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .map_err(|e| {
            let removed = if pin {
                "rigid translation and local mechanisms removed"
            } else {
                "held nodes and local mechanisms removed"
            };
            Error::Invalid(format!(
                "Cholesky: the stiffness matrix ({removed}) is not positive definite \
                 ({e:?}): the bond network contains a global mechanism"
            ))
        })?;
    Ok(factor)
}

/// LLᵀ factor of a block-sparse PSD matrix restricted to its range, with one node's
/// translations pinned; solves for six right-hand sides at once.
pub struct BlockCholesky {
    /// Per node: basis of the kept DOFs (first `rank` columns) and its rank.
    basis: Vec<(Block6, usize)>,
    /// First reduced unknown of every node.
    offset: Vec<usize>,
    /// Number of reduced unknowns.
    n: usize,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    /// Node whose translations were fixed (`usize::MAX` for [`Self::factor_definite`]).
    pub pinned: usize,
    /// Stored entries of the upper triangle of the reduced matrix.
    pub matrix_nonzeros: usize,
}

impl BlockCholesky {
    /// Reduce, order (AMD) and factor `k`. Errors when no node can be pinned or when the
    /// reduced matrix is not positive definite (a global mechanism).
    pub fn factor(k: &BlockSparse) -> Result<BlockCholesky> {
        BlockCholesky::factor_ordered(k, true, None)
    }

    /// Reduce, order and factor a `k` that has no rigid-body modes (a structure held by
    /// prescribed nodes, e.g. a clamped bar): only the local mechanisms are removed, no node
    /// is pinned (`pinned` is `usize::MAX`). Errors when the reduced matrix is not positive
    /// definite (a global mechanism, e.g. a part not held by the prescribed nodes).
    pub fn factor_definite(k: &BlockSparse) -> Result<BlockCholesky> {
        BlockCholesky::factor_ordered(k, false, None)
    }

    /// Reduce every node to the range of its diagonal block (and, with `pin`, fix one
    /// node's translations, as [`Self::factor`]; without, as [`Self::factor_definite`]),
    /// order and factor: the nodes eliminated in `order` (every node once, e.g. a nested
    /// dissection the caller knows from the geometry), else by AMD.
    pub(crate) fn factor_ordered(
        k: &BlockSparse,
        pin: bool,
        order: Option<&[u32]>,
    ) -> Result<BlockCholesky> {
        let m = k.rows();
        if m == 0 {
            return Err(Error::Invalid("Cholesky: empty stiffness matrix".into()));
        }
        let (basis, pinned) = reduced_bases(k, pin)?;
        let mut offset = vec![0usize; m + 1];
        for p in 0..m {
            offset[p + 1] = offset[p] + basis[p].1;
        }
        let n = offset[m];
        if n == 0 {
            return Err(Error::Invalid("Cholesky: no unknowns left".into()));
        }
        let (col_ptr, row_idx, values) = reduced_upper(k, &basis, &offset);
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        // The nodes' order expanded to their kept unknowns: forward[new] = old.
        let forward: Vec<usize> = match order {
            Some(order) => {
                if order.len() != m || {
                    let mut seen = vec![false; m];
                    order
                        .iter()
                        .any(|&p| p as usize >= m || std::mem::replace(&mut seen[p as usize], true))
                } {
                    return Err(Error::Invalid(format!(
                        "Cholesky: an elimination order of {} entries for {m} nodes, not \
                         each node once",
                        order.len()
                    )));
                }
                order
                    .iter()
                    .flat_map(|&p| offset[p as usize]..offset[p as usize + 1])
                    .collect()
            }
            None => Vec::new(),
        };
        let mut inverse = vec![0usize; forward.len()];
        for (new, &old) in forward.iter().enumerate() {
            inverse[old] = new;
        }
        let ordering = match order {
            Some(_) => SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n)),
            None => SymmetricOrdering::Amd,
        };
        let symbolic = factorize_symbolic_cholesky(sym, Side::Upper, ordering, Default::default())
            .map_err(|e| Error::Invalid(format!("Cholesky symbolic analysis: {e:?}")))?;
        let factor = numeric_llt(&symbolic, SparseColMatRef::new(sym, &values), pin)?;
        Ok(BlockCholesky {
            basis,
            offset,
            n,
            symbolic,
            factor,
            pinned,
            matrix_nonzeros: values.len(),
        })
    }

    /// Number of reduced unknowns.
    pub fn unknowns(&self) -> usize {
        self.n
    }

    /// Entries of the factor L.
    pub fn factor_nonzeros(&self) -> usize {
        self.factor.len()
    }

    /// X with K X = B for six right-hand sides (one 6×6 block per node: DOF × case), B
    /// orthogonal to the removed null space; X has zero components along it.
    pub fn solve(&self, b: &[Block6]) -> Result<Vec<Block6>> {
        self.solve_split(b, false)
    }

    /// [`Self::solve`] of `C` load cases with the triangular solves on them in two halves
    /// (three and three of six, one and one of two; one per thread: faer's solves are serial,
    /// and they are the CG's coarse solve in every iteration); the halves are the same on any
    /// thread count, so the bits. An odd `C` is solved at once.
    pub(crate) fn solve_in_halves<const C: usize>(&self, b: &[Cols<C>]) -> Result<Vec<Cols<C>>> {
        self.solve_split(b, C.is_multiple_of(2))
    }

    /// [`Self::solve`] of `C` load cases with the triangular solves on all at once, or
    /// `in_halves`.
    fn solve_split<const C: usize>(&self, b: &[Cols<C>], in_halves: bool) -> Result<Vec<Cols<C>>> {
        let m = self.basis.len();
        if b.len() != m {
            return Err(Error::Invalid(format!(
                "Cholesky solve: {} right-hand-side blocks for {m} nodes",
                b.len()
            )));
        }
        let n = self.n;
        let mut x = vec![0.0; C * n];
        for (p, (t, r)) in self.basis.iter().enumerate() {
            let tb = t.transpose() * b[p];
            for c in 0..C {
                for a in 0..*r {
                    x[c * n + self.offset[p] + a] = tb[(a, c)];
                }
            }
        }
        // Sequential triangular solves within a group: no synchronisation inside them.
        let par = Par::Seq;
        let llt = LltRef::new(&self.symbolic, &self.factor);
        let solve_group = |x: &mut [f64]| -> Result<()> {
            let cols = x.len() / n;
            let mut mem =
                MemBuffer::try_new(self.symbolic.solve_in_place_scratch::<f64>(cols, par))
                    .map_err(|_| {
                        Error::Invalid("Cholesky: cannot allocate solve workspace".into())
                    })?;
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(x, n, cols),
                par,
                MemStack::new(&mut mem),
            );
            Ok(())
        };
        if !in_halves {
            solve_group(&mut x)?;
        } else {
            let (first, second) = x.split_at_mut(C / 2 * n);
            let (ra, rb) = rayon::join(|| solve_group(first), || solve_group(second));
            ra?;
            rb?;
        }
        Ok(self
            .basis
            .par_iter()
            .enumerate()
            .map(|(p, (t, r))| {
                let mut xp = Cols::<C>::zeros();
                for c in 0..C {
                    for a in 0..*r {
                        xp[(a, c)] = x[c * n + self.offset[p] + a];
                    }
                }
                t * xp
            })
            .collect())
    }
}
