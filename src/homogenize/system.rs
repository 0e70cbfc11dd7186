//! The relaxed solve's linear system, handed out: K (the active network's 6m × 6m
//! stiffness, six DOFs per particle, Kruyt 2014 Eqs. 10–14), G (its six unit-strain loads), H
//! and V, so that C_relaxed = (H − Gᵀ K⁺ G)/V can be solved or checked by another code
//! (Python's `Assembly.relaxed_system`; scipy's CG in `benches/scale_relaxed.py`).
//!
//! K is the same matrix the relaxed CG and the sparse Cholesky use; with a many-body term
//! its Hessian is added in assembled form (second neighbours), as the Cholesky route does.

use super::network::Block6;
use super::relaxed::{network_with_term, with_term_hessian, RelaxedOptions};
use super::sparse::BlockSparse;
use crate::bonds::{BondSet, BondStiffness};
use crate::manybody::ManyBody;
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::Result;

/// K in compressed sparse rows over scalar DOFs (row 6p + k is DOF k of active particle p:
/// ux, uy, uz in m, then θx, θy, θz in rad), G as dense rows, H and V.
#[derive(Clone, Debug)]
pub struct RelaxedSystem {
    /// Number of scalar unknowns, 6 × active particles.
    pub unknowns: usize,
    /// CSR row starts (`unknowns + 1` entries).
    pub row_start: Vec<u64>,
    /// CSR column of every stored entry (increasing within a row).
    pub column: Vec<u32>,
    /// CSR value of every stored entry (N/m, N/rad or N·m/rad by the DOFs' kinds).
    pub value: Vec<f64>,
    /// G by rows: `g[6 * row + case]` is the load of the unit strain `case` (Voigt order
    /// 11, 22, 33, 23, 13, 12; engineering shears) on DOF `row`.
    pub g: Vec<f64>,
    /// H, the affine (Voigt) energy matrix: H/V is the Voigt sum (Pa · m³).
    pub h: Stiffness6,
    /// The cell volume V (m³).
    pub volume: f64,
    /// The packing's index of every active particle (row block p is particle `active[p]`).
    pub active: Vec<u32>,
}

impl RelaxedSystem {
    /// C = (H − Gᵀ Q)/V for a solution Q of K Q = G given by rows like `g` (Pa): the
    /// relaxed tensor of a solution computed elsewhere (symmetrised).
    pub fn tensor(&self, q: &[f64]) -> Stiffness6 {
        let mut gtq = Stiffness6::zeros();
        for (gr, qr) in self.g.chunks_exact(6).zip(q.chunks_exact(6)) {
            for a in 0..6 {
                for b in 0..6 {
                    gtq[(a, b)] += gr[a] * qr[b];
                }
            }
        }
        let c = (self.h - gtq) / self.volume;
        (c + c.transpose()) * 0.5
    }
}

/// The relaxed system of `packing`'s bonded network with springs `k` and the optional
/// many-body term (built on the same packing and bonds): the network `opts` describe (lever
/// arm, rotations); the solver options are not used. Refuses what the relaxed solve refuses
/// (no periodic cell, a term of another packing).
pub fn relaxed_system(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    term: Option<&ManyBody>,
    opts: &RelaxedOptions,
) -> Result<RelaxedSystem> {
    let (net, _, _) = network_with_term(packing, bonds, k, opts, None, term)?;
    let springs = BlockSparse::assemble(&net);
    let merged = match term {
        Some(t) => Some(with_term_hessian(&springs, t, &net.index)?),
        None => None,
    };
    let kmat = merged.as_ref().unwrap_or(&springs);
    let m = kmat.rows();
    let mut row_start = Vec::with_capacity(6 * m + 1);
    row_start.push(0u64);
    let (mut column, mut value) = (Vec::new(), Vec::new());
    for p in 0..m {
        let mut blocks: Vec<(usize, &Block6)> = kmat.row(p).collect();
        blocks.sort_by_key(|(q, _)| *q);
        for a in 0..6 {
            for (q, b) in &blocks {
                for c in 0..6 {
                    column.push((6 * q + c) as u32);
                    value.push(b[(a, c)]);
                }
            }
            row_start.push(column.len() as u64);
        }
    }
    let g = net
        .g
        .iter()
        .flat_map(|b| (0..6).flat_map(move |a| (0..6).map(move |c| b[(a, c)])))
        .collect();
    Ok(RelaxedSystem {
        unknowns: 6 * m,
        row_start,
        column,
        value,
        g,
        h: net.h,
        volume: net.volume,
        active: net.original,
    })
}
