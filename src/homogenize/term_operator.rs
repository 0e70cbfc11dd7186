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
use crate::manybody::ManyBody;
use crate::tensor::Stiffness6;
use crate::{Error, Result, Vec3};
use nalgebra::{Matrix3x6, Matrix6x3};
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};

/// N(v): the engineering strain (Voigt) of δF = u ⊗ v per displacement u; the force that a
/// Voigt stress s puts on the node of coefficient v is N(v)ᵀ s.
fn strain_map(v: &Vec3) -> Matrix6x3<f64> {
    Matrix6x3::new(
        v.x, 0.0, 0.0, //
        0.0, v.y, 0.0, //
        0.0, 0.0, v.z, //
        0.0, v.z, v.y, //
        v.z, 0.0, v.x, //
        v.y, v.x, 0.0,
    )
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
    /// Work of [`Self::stresses`]: V_p D ε_p per owner, one column per load case.
    stress: Mutex<Vec<Block6>>,
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
            stress: Mutex::new(vec![Block6::zeros(); owners]),
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
    /// one column per load case), in the operator's work buffer; [`Self::add_row`] then adds
    /// each row's share.
    pub(crate) fn stresses(&self, x: &[Block6], cols: usize) -> MutexGuard<'_, Vec<Block6>> {
        let cols = cols.min(6);
        let mut stress = self.stress.lock().unwrap_or_else(|e| e.into_inner());
        stress.par_iter_mut().enumerate().for_each(|(o, so)| {
            let d: &[f64; 36] = self.d_of(o).as_slice().try_into().expect("6×6");
            let s: &mut [f64; 36] = so.as_mut_slice().try_into().expect("6×6");
            let v = self.volume[o];
            for c in 0..cols {
                let mut g = [[0.0f64; 3]; 3];
                for k in self.start[o]..self.start[o + 1] {
                    let xn: &[f64; 36] =
                        x[self.node[k] as usize].as_slice().try_into().expect("6×6");
                    let w = &self.coef[k];
                    for (i, gi) in g.iter_mut().enumerate() {
                        let xi = xn[i + 6 * c];
                        gi[0] += xi * w.x;
                        gi[1] += xi * w.y;
                        gi[2] += xi * w.z;
                    }
                }
                let e = [
                    g[0][0],
                    g[1][1],
                    g[2][2],
                    g[1][2] + g[2][1],
                    g[0][2] + g[2][0],
                    g[0][1] + g[1][0],
                ];
                for i in 0..6 {
                    let mut acc = 0.0;
                    for (j, ej) in e.iter().enumerate() {
                        acc += d[i + 6 * j] * ej;
                    }
                    s[i + 6 * c] = acc * v;
                }
            }
        });
        stress
    }

    /// Row r of K X added to `yr`: Σ_p N(c_pr)ᵀ σ_p over the row's owners in increasing
    /// order (the scatter as a gather in a fixed order: the same bits on any number of
    /// threads), with `stress` from [`Self::stresses`] of the same X.
    #[inline(always)]
    pub(crate) fn add_row(&self, r: usize, stress: &[Block6], yr: &mut Block6, cols: usize) {
        let cols = cols.min(6);
        let out: &mut [f64; 36] = yr.as_mut_slice().try_into().expect("6×6");
        for k in self.row_start[r]..self.row_start[r + 1] {
            let s: &[f64; 36] = stress[self.row_owner[k] as usize]
                .as_slice()
                .try_into()
                .expect("6×6");
            let u = &self.row_coef[k];
            for c in 0..cols {
                let sc = &s[6 * c..6 * c + 6];
                out[6 * c] += sc[0] * u.x + sc[5] * u.y + sc[4] * u.z;
                out[1 + 6 * c] += sc[5] * u.x + sc[1] * u.y + sc[3] * u.z;
                out[2 + 6 * c] += sc[4] * u.x + sc[3] * u.y + sc[2] * u.z;
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
                    let e = strain_map(&self.coef[k]) * prolongation[n].fixed_view::<3, 6>(0, 0);
                    let a = aggregate[n];
                    match acc.iter_mut().find(|(b, _)| *b == a) {
                        Some((_, s)) => *s += e,
                        None => acc.push((a, e)),
                    }
                }
                acc.sort_by_key(|(a, _)| *a);
                for (_, s) in acc.iter_mut() {
                    *s = self.d_of(o) * *s * self.volume[o];
                }
                acc
            })
            .collect();
        (0..self.row_start.len() - 1)
            .into_par_iter()
            .map(|r| {
                let mut acc: Vec<(u32, Block6)> = Vec::new();
                for k in self.row_start[r]..self.row_start[r + 1] {
                    let nt = strain_map(&self.row_coef[k]).transpose();
                    for (a, s) in &per_owner[self.row_owner[k] as usize] {
                        let mut blk = Block6::zeros();
                        blk.fixed_view_mut::<3, 6>(0, 0).copy_from(&(nt * s));
                        match acc.iter_mut().find(|(b, _)| b == a) {
                            Some((_, t)) => *t += blk,
                            None => acc.push((*a, blk)),
                        }
                    }
                }
                acc.sort_by_key(|(a, _)| *a);
                acc
            })
            .collect()
    }
}
