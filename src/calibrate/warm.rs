//! The exact relaxed tensor with a warm start, for calibration loops.
//!
//! Same mathematics as [`crate::homogenize::relaxed`]: C = (H − GᵀQ − QᵀG + QᵀKQ)/V with
//! K Q = G solved by block-Jacobi preconditioned CG on the six load cases together. The
//! difference is the initial guess: a calibration changes the springs a little between
//! iterations, and Q (the fluctuation per unit strain) is invariant under a uniform scaling
//! of all springs, so the previous Q is an excellent start. The pruned network (which
//! particles carry load) depends only on the bonds, so Q keeps its layout across iterations.
//!
//! Proposed for `homogenize::relaxed` once merged: `relaxed_tensor_from(…, initial: &[Block6])`.

use crate::bonds::{BondSet, BondStiffness};
use crate::homogenize::network::{pinv_psd, Block6, Network};
use crate::homogenize::relaxed::{BlockSparse, RelaxedOptions};
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::{Error, Result};
use nalgebra::Vector6;
use rayon::prelude::*;

/// A relaxed solve with its fluctuation field.
#[derive(Clone, Debug)]
pub struct WarmSolution {
    /// Relaxed tensor (Pa).
    pub c: Stiffness6,
    /// Affine (Voigt) tensor H/V of the active network (Pa).
    pub c_affine: Stiffness6,
    /// CG iterations of this solve.
    pub iterations: usize,
    /// Largest final relative residual of the six load cases.
    pub relative_residual: f64,
    /// Q: generalised fluctuation (3 displacements, 3 rotations) of every active particle per
    /// unit engineering strain of each of the six load cases; the fluctuation under strain e
    /// is q = −Q·e.
    pub q: Vec<Block6>,
    /// Original particle index of every active particle (row of `q`).
    pub active: Vec<u32>,
}

/// Relaxed solver that remembers its last solution and starts the next solve from it.
pub struct WarmRelaxed<'a> {
    packing: &'a Packing,
    bonds: &'a BondSet,
    opts: RelaxedOptions,
    previous: Option<Vec<Block6>>,
    /// Total CG iterations over all solves.
    pub total_iterations: usize,
    /// Number of solves.
    pub solves: usize,
}

impl<'a> WarmRelaxed<'a> {
    /// A solver on a periodic bonded packing.
    pub fn new(packing: &'a Packing, bonds: &'a BondSet, opts: RelaxedOptions) -> Self {
        WarmRelaxed {
            packing,
            bonds,
            opts,
            previous: None,
            total_iterations: 0,
            solves: 0,
        }
    }

    /// Relaxed tensor for springs `k`, starting CG from the previous solution.
    pub fn solve(&mut self, k: &BondStiffness) -> Result<WarmSolution> {
        let sol = relaxed_with_start(
            self.packing,
            self.bonds,
            k,
            &self.opts,
            self.previous.as_deref(),
        )?;
        self.previous = Some(sol.q.clone());
        self.total_iterations += sol.iterations;
        self.solves += 1;
        Ok(sol)
    }
}

/// Per-column dot products Σ_p (a_p ∘ b_p), deterministic (fixed chunks, summed in order).
fn column_dots(a: &[Block6], b: &[Block6]) -> [f64; 6] {
    const CH: usize = 2048;
    let parts: Vec<[f64; 6]> = a
        .par_chunks(CH)
        .zip(b.par_chunks(CH))
        .map(|(ca, cb)| {
            let mut s = [0.0; 6];
            for (x, y) in ca.iter().zip(cb) {
                for (c, sc) in s.iter_mut().enumerate() {
                    *sc += x.column(c).dot(&y.column(c));
                }
            }
            s
        })
        .collect();
    let mut s = [0.0; 6];
    for part in parts {
        for c in 0..6 {
            s[c] += part[c];
        }
    }
    s
}

/// The relaxed tensor with CG started from `initial` (ignored unless it has one block per
/// active particle).
pub fn relaxed_with_start(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
    initial: Option<&[Block6]>,
) -> Result<WarmSolution> {
    let net = Network::build(packing, bonds, k, opts.lever_arm, opts.rotations)?;
    let c_affine = net.h / net.volume;
    let m = net.n_active;
    if !opts.fluctuations || m == 0 {
        return Ok(WarmSolution {
            c: c_affine,
            c_affine,
            iterations: 0,
            relative_residual: 0.0,
            q: vec![Block6::zeros(); m],
            active: net.original.clone(),
        });
    }
    let kmat = BlockSparse::assemble(&net);
    let pre: Vec<Block6> = (0..m)
        .into_par_iter()
        .map(|p| pinv_psd(&kmat.diagonal(p)).0)
        .collect();
    let mut scale = [0.0f64; 6];
    for e in &net.elements {
        for (c, sc) in scale.iter_mut().enumerate() {
            *sc += e.gi.column(c).norm_squared() + e.gj.column(c).norm_squared();
        }
    }
    let scale = scale.map(f64::sqrt);
    let start = initial.filter(|x| x.len() == m);
    let (q, iterations, residual) = pcg(&kmat, &net.g, &pre, &scale, opts, start)?;
    let mut kq = vec![Block6::zeros(); m];
    kmat.apply(&q, &mut kq);
    let mut gtq = Block6::zeros();
    let mut qtkq = Block6::zeros();
    for p in 0..m {
        gtq += net.g[p].transpose() * q[p];
        qtkq += q[p].transpose() * kq[p];
    }
    let c = net.h - gtq - gtq.transpose() + qtkq;
    let c = (c + c.transpose()) * (0.5 / net.volume);
    Ok(WarmSolution {
        c,
        c_affine,
        iterations,
        relative_residual: residual,
        q,
        active: net.original,
    })
}

/// Preconditioned CG for K X = B from X₀ = `start` (or 0).
fn pcg(
    k: &BlockSparse,
    b: &[Block6],
    pre: &[Block6],
    scale: &[f64; 6],
    opts: &RelaxedOptions,
    start: Option<&[Block6]>,
) -> Result<(Vec<Block6>, usize, f64)> {
    let m = b.len();
    let precondition = |r: &[Block6], z: &mut [Block6]| {
        z.par_iter_mut()
            .zip(r.par_iter())
            .zip(pre.par_iter())
            .for_each(|((z, r), p)| *z = p * r);
    };
    let bnorm = column_dots(b, b).map(f64::sqrt);
    let live: [bool; 6] = std::array::from_fn(|c| bnorm[c] > 1e-10 * scale[c]);
    let mut x = match start {
        Some(s) => {
            let mut x = s.to_vec();
            // Dead columns (zero load up to rounding) are solved as zero.
            for xp in x.iter_mut() {
                for (c, &alive) in live.iter().enumerate() {
                    if !alive {
                        xp.column_mut(c).fill(0.0);
                    }
                }
            }
            x
        }
        None => vec![Block6::zeros(); m],
    };
    let mut r = b.to_vec();
    if start.is_some() {
        let mut kx = vec![Block6::zeros(); m];
        k.apply(&x, &mut kx);
        r.par_iter_mut()
            .zip(kx.par_iter())
            .for_each(|(r, kx)| *r -= kx);
    }
    let mut z = vec![Block6::zeros(); m];
    precondition(&r, &mut z);
    let mut p = z.clone();
    let mut ap = vec![Block6::zeros(); m];
    let mut rz = column_dots(&r, &z);
    let mut worst = 0.0;
    for it in 0..=opts.max_iterations {
        let rr = column_dots(&r, &r);
        worst = (0..6)
            .map(|c| {
                if live[c] {
                    rr[c].sqrt() / bnorm[c]
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        if worst <= opts.tolerance {
            return Ok((x, it, worst));
        }
        if it == opts.max_iterations {
            break;
        }
        k.apply(&p, &mut ap);
        let pap = column_dots(&p, &ap);
        let alpha = Block6::from_diagonal(&Vector6::from_fn(|c, _| {
            if live[c] && pap[c] > 0.0 {
                rz[c] / pap[c]
            } else {
                0.0
            }
        }));
        x.par_iter_mut()
            .zip(r.par_iter_mut())
            .zip(p.par_iter().zip(ap.par_iter()))
            .for_each(|((x, r), (p, ap))| {
                *x += p * alpha;
                *r -= ap * alpha;
            });
        precondition(&r, &mut z);
        let rz_new = column_dots(&r, &z);
        let beta = Block6::from_diagonal(&Vector6::from_fn(|c, _| {
            if rz[c] > 0.0 {
                rz_new[c] / rz[c]
            } else {
                0.0
            }
        }));
        p.par_iter_mut()
            .zip(z.par_iter())
            .for_each(|(p, z)| *p = z + *p * beta);
        rz = rz_new;
    }
    Err(Error::Invalid(format!(
        "relaxed solver: no convergence in {} iterations (relative residual {worst:.3e} > tolerance {:.1e}); the bond network may contain a mechanism",
        opts.max_iterations, opts.tolerance
    )))
}
