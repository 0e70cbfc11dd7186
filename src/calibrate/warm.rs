//! The exact relaxed tensor with a warm start, for calibration loops.
//!
//! Same mathematics as [`crate::homogenize::relaxed`]: C = (H − GᵀQ − QᵀG + QᵀKQ)/V with
//! K Q = G solved by block-Jacobi preconditioned CG on the six load cases together. The
//! difference is the initial guess: a calibration changes the springs a little between
//! iterations, and Q (the fluctuation per unit strain) is invariant under a uniform scaling
//! of all springs, so the previous Q is an excellent start. The pruned network (which
//! particles carry load) depends only on the bonds, so Q keeps its layout across iterations.

use crate::bonds::{BondSet, BondStiffness};
use crate::homogenize::network::Block6;
use crate::homogenize::relaxed::{relaxed_solve, RelaxedOptions};
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::Result;

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

/// The relaxed tensor with CG started from `initial` (ignored unless it has one block per
/// active particle): [`crate::homogenize::relaxed::relaxed_solve`] as a [`WarmSolution`].
pub fn relaxed_with_start(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
    initial: Option<&[Block6]>,
) -> Result<WarmSolution> {
    let s = relaxed_solve(packing, bonds, k, opts, initial)?;
    Ok(WarmSolution {
        c: s.result.c,
        c_affine: s.result.c_affine,
        iterations: s.result.iterations,
        relative_residual: s.result.relative_residual,
        q: s.q,
        active: s.active,
    })
}
