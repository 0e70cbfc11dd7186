//! The exact relaxed tensor with a warm start, for calibration loops.
//!
//! Same mathematics as [`crate::homogenize::relaxed`]: C = (H − GᵀQ − QᵀG + QᵀKQ)/V with
//! K Q = G solved by block-Jacobi preconditioned CG on the six load cases together. The
//! difference is the initial guess: a calibration changes the springs a little between
//! iterations, and Q (the fluctuation per unit strain) is invariant under a uniform scaling
//! of all springs, so the previous Q is an excellent start. The pruned network (which
//! particles carry load) depends only on the bonds, so Q keeps its layout across iterations.

use crate::bonds::{assign_stiffness, BondSet, BondStiffness};
use crate::homogenize::network::Block6;
use crate::homogenize::relaxed::{relaxed_solve, RelaxedOptions, RelaxedResult};
use crate::packing::Packing;
use crate::schemes::{Geometry, StiffnessScheme};
use crate::Result;

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

    /// Relaxed tensor for springs `k`, starting CG from the previous solution (whose
    /// fluctuation field Q it keeps for the next solve).
    pub fn solve(&mut self, k: &BondStiffness) -> Result<RelaxedResult> {
        let sol = relaxed_solve(
            self.packing,
            self.bonds,
            k,
            &self.opts,
            self.previous.as_deref(),
        )?;
        self.previous = Some(sol.q);
        self.total_iterations += sol.result.iterations;
        self.solves += 1;
        Ok(sol.result)
    }

    /// [`Self::solve`] with the springs `scheme` assigns to the bonds under `geometry`.
    pub fn solve_scheme(
        &mut self,
        scheme: &dyn StiffnessScheme,
        geometry: &Geometry,
    ) -> Result<RelaxedResult> {
        let k = assign_stiffness(self.packing, self.bonds, scheme, geometry)?;
        self.solve(&k)
    }
}
