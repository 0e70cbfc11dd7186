//! The many-body term of the relaxed solve at its reference state, in factored form
//! (docs/manybody.md, "Cost of the relaxed solve with the term").
//!
//! At the reference state (F_p = I, S_p = 0) the term's Hessian is K = Σ_p V_p B_pᵀ D B_p,
//! with B_p the map from the displacements of particle p's stencil to its engineering strain
//! (δF_p = Σ_n u_n ⊗ c_n, ε_p = sym δF_p). The CG applies it as one gather, one 6×6 product
//! and one scatter per particle, instead of multiplying ~37 assembled blocks per row. Its
//! load and affine tensor have closed forms: a uniform strain ε gives δF_p = ε (the fit
//! reproduces it, Σ_b L_b ⊗ a_b = I), so G_r = Σ_p V_p N(c_pr)ᵀ D and H = Σ_p V_p D.
//! A polycrystal's particles each load their grain's D (`ManyBody::tensor_of`): every
//! product by D above takes the owner's.

use super::network::Block6;
use super::sparse::mul6;
use crate::manybody::ManyBody;
use crate::tensor::Stiffness6;
use crate::{Error, Result, Vec3};
use nalgebra::{Matrix3x6, Matrix6x3};
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};

/// N(v): the engineering strain (Voigt) of δF = u ⊗ v per displacement u; the force that a
/// Voigt stress s puts on the node of coefficient v is N(v)ᵀ s.
pub(crate) fn strain_map(v: &Vec3) -> Matrix6x3<f64> {
    Matrix6x3::new(
        v.x, 0.0, 0.0, //
        0.0, v.y, 0.0, //
        0.0, 0.0, v.z, //
        0.0, v.z, v.y, //
        v.z, 0.0, v.x, //
        v.y, v.x, 0.0,
    )
}

/// e += N(c)·P_t, the engineering strain of the displacements (translation rows of `p`, one
/// column per coarse DOF) times the stencil coefficient `c`: [`strain_map`] written out, its
/// zero entries skipped.
#[inline(always)]
fn add_strain_of(e: &mut Block6, c: &Vec3, p: &Block6) {
    for j in 0..6 {
        let (px, py, pz) = (p[(0, j)], p[(1, j)], p[(2, j)]);
        e[(0, j)] += c.x * px;
        e[(1, j)] += c.y * py;
        e[(2, j)] += c.z * pz;
        e[(3, j)] += c.z * py + c.y * pz;
        e[(4, j)] += c.z * px + c.x * pz;
        e[(5, j)] += c.y * px + c.x * py;
    }
}

/// f += N(u)ᵀ·s on the translation rows of `f`: the forces that the stresses `s` (one column
/// per coarse DOF) put on the node of coefficient `u`, [`strain_map`]ᵀ written out.
#[inline(always)]
fn add_force_of(f: &mut Block6, u: &Vec3, s: &Block6) {
    for j in 0..6 {
        let c = s.column(j);
        f[(0, j)] += c[0] * u.x + c[5] * u.y + c[4] * u.z;
        f[(1, j)] += c[5] * u.x + c[1] * u.y + c[3] * u.z;
        f[(2, j)] += c[4] * u.x + c[3] * u.y + c[2] * u.z;
    }
}

/// The term at its reference state over the active particles of a relaxed solve.
pub(crate) struct TermOperator {
    /// The term's tensors D (one, or one per grain).
    d6: Vec<Stiffness6>,
    /// Per owner, its entry of `d6`; empty when there is one tensor.
    owner_tensor: Vec<u32>,
    /// Σ_p V_p over every particle, in particle order.
    total_volume: f64,
    /// Per entry of `d6`, Σ_p V_p of its particles, in particle order (several tensors only).
    tensor_volume: Vec<f64>,
    /// Per owner (a particle in the term, V_p > 0): V_p and its stencil (CSR: active node,
    /// coefficient c_n).
    volume: Vec<f64>,
    start: Vec<usize>,
    node: Vec<u32>,
    coef: Vec<Vec3>,
    /// Per active row r: the owners whose stencil holds r and r's coefficient there (CSR,
    /// owners ascending: the fixed order every row sums in).
    row_start: Vec<usize>,
    row_owner: Vec<u32>,
    row_coef: Vec<Vec3>,
    /// Work of [`Self::stresses`].
    work: Mutex<TermWork>,
}

/// Work buffers of [`TermOperator::stresses`], lanes = load cases: X's translation rows per
/// active node ([i][c]) and V_p D ε_p per owner ([component][c]).
pub(crate) struct TermWork {
    xt: Vec<[[f64; 6]; 3]>,
    stress: Vec<[[f64; 6]; 6]>,
}

impl TermOperator {
    /// The operator of `term` on the `m` active particles, `index` mapping every particle to
    /// its active row (u32::MAX: inactive). Refuses ([`Error::Invalid`]) a stencil holding an
    /// inactive particle (the network must keep every bonded particle).
    pub(crate) fn new(term: &ManyBody, index: &[u32], m: usize) -> Result<TermOperator> {
        let volumes = term.particle_volumes();
        let (mut volume, mut start, mut node, mut coef) = (Vec::new(), vec![0], vec![], vec![]);
        let several = term.tensors().len() > 1;
        let mut owner_tensor = Vec::new();
        let mut tensor_volume = vec![0.0; if several { term.tensors().len() } else { 0 }];
        for (p, &v) in volumes.iter().enumerate() {
            if several {
                tensor_volume[term.tensor_index(p)] += v;
            }
            let (nodes, coefs) = term.stencil(p);
            if nodes.is_empty() || v == 0.0 {
                continue;
            }
            for (&n, c) in nodes.iter().zip(coefs) {
                let a = index[n as usize];
                if a == u32::MAX {
                    return Err(Error::Invalid(format!(
                        "relaxed solver: particle {n} is in the many-body stencil of particle \
                         {p} but not in the bond network"
                    )));
                }
                node.push(a);
                coef.push(*c);
            }
            volume.push(v);
            if several {
                owner_tensor.push(term.tensor_index(p) as u32);
            }
            start.push(node.len());
        }
        // Transpose: rows by active node, owners in increasing order.
        let mut row_start = vec![0usize; m + 1];
        for &a in &node {
            row_start[a as usize + 1] += 1;
        }
        for r in 0..m {
            row_start[r + 1] += row_start[r];
        }
        let mut fill = row_start.clone();
        let mut row_owner = vec![0u32; node.len()];
        let mut row_coef = vec![Vec3::zeros(); node.len()];
        for o in 0..volume.len() {
            for k in start[o]..start[o + 1] {
                let r = node[k] as usize;
                row_owner[fill[r]] = o as u32;
                row_coef[fill[r]] = coef[k];
                fill[r] += 1;
            }
        }
        let owners = volume.len();
        Ok(TermOperator {
            d6: term.tensors().to_vec(),
            owner_tensor,
            total_volume: volumes.iter().sum(),
            tensor_volume,
            volume,
            start,
            node,
            coef,
            row_start,
            row_owner,
            row_coef,
            work: Mutex::new(TermWork {
                xt: vec![[[0.0; 6]; 3]; m],
                stress: vec![[[0.0; 6]; 6]; owners],
            }),
        })
    }

    /// D of owner `o`.
    #[inline(always)]
    fn d_of(&self, o: usize) -> &Stiffness6 {
        if self.owner_tensor.is_empty() {
            &self.d6[0]
        } else {
            &self.d6[self.owner_tensor[o] as usize]
        }
    }

    /// Owners (particles in the term, V_p > 0).
    pub(crate) fn owners(&self) -> usize {
        self.volume.len()
    }

    /// Owner `o`'s V_p, D and stencil (active nodes and their coefficients c_n).
    pub(crate) fn owner(&self, o: usize) -> (f64, &Stiffness6, &[u32], &[Vec3]) {
        let span = self.start[o]..self.start[o + 1];
        (
            self.volume[o],
            self.d_of(o),
            &self.node[span.clone()],
            &self.coef[span],
        )
    }

    /// The owners whose stencil holds active row `r`, ascending.
    pub(crate) fn owners_of_row(&self, r: usize) -> &[u32] {
        &self.row_owner[self.row_start[r]..self.row_start[r + 1]]
    }

    /// The term's tensors D (one, or one per grain).
    pub(crate) fn tensors(&self) -> &[Stiffness6] {
        &self.d6
    }

    /// The term's share of H (Kruyt 2014 Eq. 14 with the term's energy), (Σ_p V_p)·D: the
    /// affine tensor times the volume (Σ_t (Σ_{p∈t} V_p)·D_t with a tensor per grain).
    pub(crate) fn affine(&self) -> Block6 {
        if self.d6.len() == 1 {
            return self.d6[0] * self.total_volume;
        }
        self.d6
            .iter()
            .zip(&self.tensor_volume)
            .fold(Block6::zeros(), |acc, (d, v)| acc + d * *v)
    }

    /// The term's load G_r = Σ_p V_p N(c_pr)ᵀ D of every active row (translation rows; the
    /// rotation rows are zero).
    pub(crate) fn load(&self) -> Vec<Block6> {
        (0..self.row_start.len() - 1)
            .into_par_iter()
            .map(|r| {
                let mut g = Matrix3x6::<f64>::zeros();
                for k in self.row_start[r]..self.row_start[r + 1] {
                    let o = self.row_owner[k] as usize;
                    g += strain_map(&self.row_coef[k]).transpose() * self.d_of(o) * self.volume[o];
                }
                let mut blk = Block6::zeros();
                blk.fixed_view_mut::<3, 6>(0, 0).copy_from(&g);
                blk
            })
            .collect()
    }

    /// The diagonal block of row `r`, Σ_p V_p N(c_pr)ᵀ D N(c_pr).
    pub(crate) fn diagonal(&self, r: usize) -> Block6 {
        let mut blk = Block6::zeros();
        for k in self.row_start[r]..self.row_start[r + 1] {
            let n = strain_map(&self.row_coef[k]);
            let o = self.row_owner[k] as usize;
            let mut top = blk.fixed_view_mut::<3, 3>(0, 0);
            top += n.transpose() * self.d_of(o) * n * self.volume[o];
        }
        blk
    }

    /// K X on the first `cols` load cases, first part: V_p D ε_p of every owner (gather;
    /// one lane per load case), in the operator's work buffers; [`Self::add_row`] then adds
    /// each row's share. X's translation rows are first copied with the load cases
    /// innermost, so that the steps below run on two load cases at once (vector lanes, the
    /// 3×3 δF_p of both in registers) and the scatter on six; each lane's operations and
    /// their order are those of one load case alone, so the bits are those of a column-by-
    /// column product.
    pub(crate) fn stresses(&self, x: &[Block6], cols: usize) -> MutexGuard<'_, TermWork> {
        let cols = cols.min(6);
        let mut work = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let TermWork { xt, stress } = &mut *work;
        xt.par_iter_mut().zip(x.par_iter()).for_each(|(t, xn)| {
            let xn = xn.as_slice();
            for (i, ti) in t.iter_mut().enumerate() {
                for (c, tc) in ti.iter_mut().enumerate() {
                    *tc = if c < cols { xn[i + 6 * c] } else { 0.0 };
                }
            }
        });
        let xt = &*xt;
        stress.par_iter_mut().enumerate().for_each(|(o, so)| {
            let d: &[f64; 36] = self.d_of(o).as_slice().try_into().expect("6×6");
            let v = self.volume[o];
            let stencil = self.start[o]..self.start[o + 1];
            // Two load cases at a time: their 3×3 δF_p stays in registers.
            for l in (0..cols).step_by(2) {
                // g[i][j] = Σ_n u_n,i c_n,j (δF_p), per lane.
                let mut g = [[[0.0f64; 2]; 3]; 3];
                for k in stencil.clone() {
                    let xn = &xt[self.node[k] as usize];
                    let w = [self.coef[k].x, self.coef[k].y, self.coef[k].z];
                    for (gi, xi) in g.iter_mut().zip(xn) {
                        let x2 = [xi[l], xi[l + 1]];
                        for (gij, wj) in gi.iter_mut().zip(&w) {
                            gij[0] += x2[0] * wj;
                            gij[1] += x2[1] * wj;
                        }
                    }
                }
                let sum = |a: [f64; 2], b: [f64; 2]| [a[0] + b[0], a[1] + b[1]];
                let e = [
                    g[0][0],
                    g[1][1],
                    g[2][2],
                    sum(g[1][2], g[2][1]),
                    sum(g[0][2], g[2][0]),
                    sum(g[0][1], g[1][0]),
                ];
                for (i, si) in so.iter_mut().enumerate() {
                    let mut acc = [0.0f64; 2];
                    for (j, ej) in e.iter().enumerate() {
                        let dij = d[i + 6 * j];
                        acc[0] += dij * ej[0];
                        acc[1] += dij * ej[1];
                    }
                    si[l] = acc[0] * v;
                    si[l + 1] = acc[1] * v;
                }
            }
        });
        work
    }

    /// Row r of K X added to `yr`: Σ_p N(c_pr)ᵀ σ_p over the row's owners in increasing
    /// order (the scatter as a gather in a fixed order: the same bits on any number of
    /// threads), with `work` from [`Self::stresses`] of the same X.
    #[inline(always)]
    pub(crate) fn add_row(&self, r: usize, work: &TermWork, yr: &mut Block6, cols: usize) {
        let cols = cols.min(6);
        let out = yr.as_mut_slice();
        let mut acc = [[0.0f64; 6]; 3];
        for (i, ai) in acc.iter_mut().enumerate() {
            for (c, a) in ai.iter_mut().enumerate().take(cols) {
                *a = out[i + 6 * c];
            }
        }
        for k in self.row_start[r]..self.row_start[r + 1] {
            let s = &work.stress[self.row_owner[k] as usize];
            let u = &self.row_coef[k];
            for c in 0..6 {
                acc[0][c] += s[0][c] * u.x + s[5][c] * u.y + s[4][c] * u.z;
                acc[1][c] += s[5][c] * u.x + s[1][c] * u.y + s[3][c] * u.z;
                acc[2][c] += s[4][c] * u.x + s[3][c] * u.y + s[2][c] * u.z;
            }
        }
        for (i, ai) in acc.iter().enumerate() {
            for (c, a) in ai.iter().enumerate().take(cols) {
                out[i + 6 * c] = *a;
            }
        }
    }

    /// The most nodes one row couples to through the term (Σ over the row's owners of their
    /// stencils' sizes, an upper bound of the row's blocks in the assembled Hessian).
    pub(crate) fn coupling_width(&self) -> usize {
        (0..self.row_start.len() - 1)
            .map(|r| {
                (self.row_start[r]..self.row_start[r + 1])
                    .map(|k| {
                        let o = self.row_owner[k] as usize;
                        self.start[o + 1] - self.start[o]
                    })
                    .sum::<usize>()
            })
            .max()
            .unwrap_or(0)
    }

    /// The longest chain of additions in one entry of [`Self::add_row`]: 3 per stencil
    /// entry and one for the symmetric part (ε_p), 6 (D ε_p), 3 per owner of the row.
    pub(crate) fn rounding_depth(&self) -> usize {
        let stencil = self.start.windows(2).map(|w| w[1] - w[0]).max();
        let owners = self.row_start.windows(2).map(|w| w[1] - w[0]).max();
        3 * stencil.unwrap_or(0) + 1 + 6 + 3 * owners.unwrap_or(0)
    }

    /// K P of the two-level coarse space, per active row: (aggregate, Σ_q∈aggregate K_rq P_q)
    /// sorted by aggregate, for the nodes' `aggregate` and rigid-mode `prolongation`; per
    /// owner first V_p D Σ_n∈aggregate N(c_n) P_n (translation rows of P_n), then per row
    /// N(c_pr)ᵀ of it, owners in a fixed order.
    pub(crate) fn times_prolongation(
        &self,
        aggregate: &[u32],
        prolongation: &[Block6],
    ) -> Vec<Vec<(u32, Block6)>> {
        let per_owner: Vec<Vec<(u32, Block6)>> = (0..self.volume.len())
            .into_par_iter()
            .map(|o| {
                let mut acc: Vec<(u32, Block6)> = Vec::new();
                for k in self.start[o]..self.start[o + 1] {
                    let n = self.node[k] as usize;
                    let a = aggregate[n];
                    let i = match acc.iter().position(|(b, _)| *b == a) {
                        Some(i) => i,
                        None => {
                            acc.push((a, Block6::zeros()));
                            acc.len() - 1
                        }
                    };
                    add_strain_of(&mut acc[i].1, &self.coef[k], &prolongation[n]);
                }
                acc.sort_by_key(|(a, _)| *a);
                let d = self.d_of(o);
                for (_, s) in acc.iter_mut() {
                    *s = mul6(d, s) * self.volume[o];
                }
                acc
            })
            .collect();
        (0..self.row_start.len() - 1)
            .into_par_iter()
            .map(|r| {
                let mut acc: Vec<(u32, Block6)> = Vec::new();
                for k in self.row_start[r]..self.row_start[r + 1] {
                    let u = &self.row_coef[k];
                    for (a, s) in &per_owner[self.row_owner[k] as usize] {
                        let i = match acc.iter().position(|(b, _)| b == a) {
                            Some(i) => i,
                            None => {
                                acc.push((*a, Block6::zeros()));
                                acc.len() - 1
                            }
                        };
                        add_force_of(&mut acc[i].1, u, s);
                    }
                }
                acc.sort_by_key(|(a, _)| *a);
                acc
            })
            .collect()
    }
}
