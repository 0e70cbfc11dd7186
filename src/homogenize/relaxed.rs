//! The exact fully relaxed (quasi-static) stiffness tensor of a bonded periodic assembly.
//!
//! With the network of [`super::network`] (six DOFs per particle, Kruyt 2014 Eqs. 10–14),
//! minimising the stored energy over the fluctuations gives
//! C_relaxed = (H − Gᵀ K⁺ G)/V, with C_affine = H/V the Voigt sum (docs/references.md).
//!
//! K is assembled once in 6×6 block-sparse form and the six load cases are solved together
//! by conjugate gradients with a block-Jacobi preconditioner. The tensor is evaluated in
//! the variational form C = (H − GᵀQ − QᵀG + QᵀKQ)/V (Q solving KQ = G), whose error is
//! quadratic in the solver's error and which is symmetric by construction; at equilibrium
//! it equals the Love-stress tensor σ = (1/V)Σ f⊗l.
//!
//! Singular modes are detected and reported ([`NullSpaceReport`]), not regularised away:
//! the right-hand sides are orthogonal to them, so CG converges in the range of K.

use super::amg::Amg;
use super::bond_springs::BondSprings;
use super::cholesky::BlockCholesky;
use super::fused::CaseRows;
use super::network::{pinv_psd, require_cell, Block6, LeverArm, Network, NullSpaceReport};
use super::sparse::{
    add_scaled_cols, copied, direction_cols, filled, mul6_cols, AsSix, BlockRows, BlockSparse,
    Cols, RowProducts, UpperBlocks,
};
use super::term_operator::TermOperator;
use super::term_preconditioner::StiffGroups;
use super::two_level::{HeldSpace, TwoLevel};
use crate::bonds::{BondSet, BondStiffness};
use crate::manybody::ManyBody;
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::{Error, Result};
use rayon::prelude::*;

/// Preconditioner of the relaxed CG.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CgPreconditioner {
    /// Pseudo-inverse of every particle's 6×6 diagonal block.
    #[default]
    BlockJacobi,
    /// Block-Jacobi plus an exact coarse solve on the rigid motions of spatial clusters of
    /// about `particles_per_aggregate` particles, more when that would make more than
    /// [`MAX_AGGREGATES`] clusters (`two_level.rs`): iterations nearly independent of N.
    TwoLevel {
        /// Target cluster size.
        particles_per_aggregate: usize,
    },
    /// Smoothed-aggregation algebraic multigrid seeded with the rigid-body modes
    /// (`amg.rs`): one V-cycle per iteration.
    Amg,
}

/// Linear solver of the relaxed equilibrium K Q = G.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RelaxedSolver {
    /// Preconditioned conjugate gradients to [`RelaxedOptions::tolerance`]; low memory.
    Cg {
        /// Preconditioner.
        preconditioner: CgPreconditioner,
    },
    /// faer's supernodal sparse Cholesky (AMD ordering) of K restricted to its range
    /// (`cholesky.rs`): exact up to rounding, memory grows faster than linearly.
    Cholesky,
}

impl Default for RelaxedSolver {
    fn default() -> Self {
        RelaxedSolver::Cg {
            preconditioner: CgPreconditioner::TwoLevel {
                particles_per_aggregate: DEFAULT_PARTICLES_PER_AGGREGATE,
            },
        }
    }
}

/// Default cluster size of the two-level preconditioner.
pub const DEFAULT_PARTICLES_PER_AGGREGATE: usize = 128;

/// The most clusters of the two-level preconditioner: its coarse Cholesky factor of the
/// clusters' periodic 3-D grid costs time as the square and memory as the 4/3 power of their
/// number (at 1,000,000 particles and 128 a cluster, 7,800 clusters: 53 CPU s and 2.2 GB,
/// half the solve; issue 35). Above it clusters grow instead, which costs iterations (at
/// 300,000 particles 43 with 128 a cluster, 49 with 245, 58 with 384). The grid's cells
/// are rounded, so the count is about this at most.
pub const MAX_AGGREGATES: usize = 4096;

/// The cluster size of `m` particles for a requested `per_aggregate`: at least the request,
/// and large enough for about [`MAX_AGGREGATES`] clusters at most.
pub(crate) fn aggregate_size(per_aggregate: usize, m: usize) -> usize {
    per_aggregate.max(m.div_ceil(MAX_AGGREGATES))
}

/// Options of the relaxed solver.
#[derive(Clone, Copy, Debug)]
pub struct RelaxedOptions {
    /// Contact point convention.
    pub lever_arm: LeverArm,
    /// Linear solver (CG with a preconditioner, or sparse Cholesky).
    pub solver: RelaxedSolver,
    /// CG stops when every load case's residual, relative to its right-hand side, is below
    /// this. The tensor's relative error is of the order of its square.
    pub tolerance: f64,
    /// Iteration limit; exceeding it is an error naming the residual reached.
    pub max_iterations: usize,
    /// `false` suppresses all fluctuations: the result is then the affine (Voigt) tensor.
    pub fluctuations: bool,
    /// `false` locks particle rotations (translations still relax): a tensor between the
    /// affine and the fully relaxed one.
    pub rotations: bool,
}

/// The range of [`RelaxedOptions::tolerance`]: above 1e-2 the tensor's error (~ its square)
/// exceeds 1e-4 and CG may stop before its first iteration, returning the affine tensor as
/// "relaxed"; below 1e-12 double-precision round-off in K·u of a large network stalls CG.
pub const TOLERANCE_RANGE: (f64, f64) = (1e-12, 1e-2);

impl RelaxedOptions {
    /// Refuse a tolerance outside `TOLERANCE_RANGE` (or NaN) and a zero iteration limit.
    pub fn validate(&self) -> Result<()> {
        let (lo, hi) = TOLERANCE_RANGE;
        if !(self.tolerance >= lo && self.tolerance <= hi) {
            return Err(Error::Invalid(format!(
                "relaxed solver tolerance (--cg-tolerance) must be in [{lo:e}, {hi:e}] (relative \
                 residual of the equilibrium equations), got {}",
                self.tolerance
            )));
        }
        if self.max_iterations == 0 {
            return Err(Error::Invalid(
                "relaxed solver iteration limit must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

impl Default for RelaxedOptions {
    fn default() -> Self {
        RelaxedOptions {
            lever_arm: LeverArm::MidGap,
            solver: RelaxedSolver::default(),
            tolerance: 1e-6,
            max_iterations: 50_000,
            fluctuations: true,
            rotations: true,
        }
    }
}

/// Result of [`relaxed_tensor`].
#[derive(Clone, Debug)]
pub struct RelaxedResult {
    /// The relaxed stiffness tensor (Pa).
    pub c: Stiffness6,
    /// The affine (Voigt) tensor of the same active network, H/V (Pa).
    pub c_affine: Stiffness6,
    /// CG iterations used (0 for Cholesky).
    pub iterations: usize,
    /// Largest final relative residual over the six load cases (for Cholesky, of the
    /// computed solution).
    pub relative_residual: f64,
    /// Particles that take part.
    pub active_particles: usize,
    /// Bonds that take part.
    pub active_bonds: usize,
    /// Singular modes found.
    pub null_space: NullSpaceReport,
}

/// Per-column dot products Σ_p (a_p ∘ b_p) summed over rows, deterministic (fixed chunks).
fn column_dots<const C: usize>(a: &[Cols<C>], b: &[Cols<C>]) -> [f64; C] {
    let parts: Vec<[f64; C]> = a
        .par_chunks(DOT_ROWS)
        .zip(b.par_chunks(DOT_ROWS))
        .map(|(ca, cb)| {
            let mut s = [0.0; C];
            for (x, y) in ca.iter().zip(cb) {
                add_row_dots(&mut s, x, y);
            }
            s
        })
        .collect();
    sum_chunks(parts)
}

/// Rows per chunk of [`column_dots`]' sums (fixed: the same bits on any thread count).
const DOT_ROWS: usize = 2048;

/// One row's terms of [`column_dots`] added to `s`.
#[inline(always)]
fn add_row_dots<const C: usize>(s: &mut [f64; C], x: &Cols<C>, y: &Cols<C>) {
    for (c, sc) in s.iter_mut().enumerate() {
        *sc += x.column(c).dot(&y.column(c));
    }
}

/// The chunks' sums added in chunk order.
fn sum_chunks<const C: usize>(parts: Vec<[f64; C]>) -> [f64; C] {
    let mut s = [0.0; C];
    for part in parts {
        for c in 0..C {
            s[c] += part[c];
        }
    }
    s
}

/// Rows per chunk of [`curvatures`]' sums (fixed: the same bits on any thread count).
const CURVATURE_ROWS: usize = 2048;

/// [`column_dots`] of p and K p (the same bits) together with pᵀ diag(K) p per column, the
/// scale of the rounding error of pᵀKp in [`pcg`].
fn curvatures<const C: usize>(
    p: &[Cols<C>],
    kp: &[Cols<C>],
    diag: &[[f64; 6]],
) -> ([f64; C], [f64; C]) {
    const CH: usize = CURVATURE_ROWS;
    let parts: Vec<([f64; C], [f64; C])> = p
        .par_chunks(CH)
        .zip(kp.par_chunks(CH))
        .zip(diag.par_chunks(CH))
        .map(|((cp, ck), cd)| curvature_chunk(cp, ck, cd))
        .collect();
    sum_curvatures(parts)
}

/// One chunk's sums of [`curvatures`], rows in order.
fn curvature_chunk<const C: usize>(
    cp: &[Cols<C>],
    ck: &[Cols<C>],
    cd: &[[f64; 6]],
) -> ([f64; C], [f64; C]) {
    let (mut s, mut t) = ([0.0; C], [0.0; C]);
    for ((x, y), d) in cp.iter().zip(ck).zip(cd) {
        for c in 0..C {
            s[c] += x.column(c).dot(&y.column(c));
            for (i, di) in d.iter().enumerate() {
                t[c] += di * x[(i, c)] * x[(i, c)];
            }
        }
    }
    (s, t)
}

/// The chunks' sums of [`curvatures`] added in chunk order.
fn sum_curvatures<const C: usize>(parts: Vec<([f64; C], [f64; C])>) -> ([f64; C], [f64; C]) {
    let (mut s, mut t) = ([0.0; C], [0.0; C]);
    for (ps, pt) in parts {
        for c in 0..C {
            s[c] += ps[c];
            t[c] += pt[c];
        }
    }
    (s, t)
}

/// A relaxed solve together with its fluctuation field.
#[derive(Clone, Debug)]
pub struct RelaxedSolution {
    /// Tensor, iterations, residual, null space.
    pub result: RelaxedResult,
    /// Q: generalised fluctuation (3 displacements, 3 rotations) of every active particle per
    /// unit engineering strain of each of the six load cases; the fluctuation under strain e
    /// is q = −Q·e.
    pub q: Vec<Block6>,
    /// Original particle index of every active particle (row of `q`).
    pub active: Vec<u32>,
}

/// The exact relaxed 6×6 stiffness (Pa) of a periodic bonded packing.
pub fn relaxed_tensor(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
) -> Result<RelaxedResult> {
    crate::packing::PeriodicCell::require_fully_periodic(packing.cell.as_ref(), "relaxed tensor")?;
    Ok(relaxed_solve(packing, bonds, k, opts, None)?.result)
}

/// The relaxed tensor and its fluctuation field, with CG started from `initial` (used when it
/// has one block per active particle, e.g. the previous solution of a calibration loop: Q is
/// invariant under a uniform scaling of all springs, so it is an excellent start).
pub fn relaxed_solve(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
    initial: Option<&[Block6]>,
) -> Result<RelaxedSolution> {
    relaxed_solve_full(packing, bonds, k, opts, initial, None, None)
}

/// The exact relaxed 6×6 stiffness (Pa) of the springs together with the many-body term
/// `term` (built on the same packing and bonds, [`crate::manybody::ManyBodySpec::build`]):
/// the term's Hessian joins K, its mixed block joins G and its affine tensor joins H, so the
/// result is the minimum over the fluctuations of the total energy (docs/manybody.md,
/// "Relaxed solve"). `None` is [`relaxed_tensor`]. `c_affine` carries the term's
/// (Σ V_p/V)·D too.
pub fn relaxed_tensor_with_term(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    term: Option<&ManyBody>,
    opts: &RelaxedOptions,
) -> Result<RelaxedResult> {
    crate::packing::PeriodicCell::require_fully_periodic(packing.cell.as_ref(), "relaxed tensor")?;
    Ok(relaxed_solve_full(packing, bonds, k, opts, None, None, term)?.result)
}

/// [`relaxed_solve`] in full: with `axial_force`, the network linearised about a state where
/// every bond carries the axial force `axial_force[b]` (N, tension positive;
/// [`super::prestress`]), so K, G and H gain the geometric terms and the result is the energy
/// (first Piola–Kirchhoff) tangent; with the many-body term `term` (as
/// [`relaxed_tensor_with_term`]), the fluctuation field of the springs and the term together
/// ([`super::local`]), and dangling particles stay in the network (a term couples them to
/// their neighbour's fitted strain).
pub(crate) fn relaxed_solve_full(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
    initial: Option<&[Block6]>,
    axial_force: Option<&[f64]>,
    term: Option<&ManyBody>,
) -> Result<RelaxedSolution> {
    let (mut net, term_op, term_scale) =
        network_with_term(packing, bonds, k, opts, axial_force, term)?;
    let c_affine = net.h / net.volume;
    let m = net.n_active;
    if !opts.fluctuations || m == 0 {
        return Ok(RelaxedSolution {
            result: RelaxedResult {
                c: c_affine,
                c_affine,
                iterations: 0,
                relative_residual: 0.0,
                active_particles: m,
                active_bonds: net.ends.len(),
                null_space: net.null_space,
            },
            q: vec![Block6::zeros(); m],
            active: net.original,
        });
    }
    // The two-level and block-Jacobi CG of the springs alone only read K's rows and multiply
    // by it: K applied bond by bond serves ([`BondSprings`]: its off-diagonal blocks never
    // formed; issue 35).
    // With a term: the CG applies it in factored form (term_operator.rs) beside the springs'
    // assembled K; only the sparse Cholesky assembles it (below).
    let products_only = term.is_none()
        && matches!(opts.solver, RelaxedSolver::Cg { preconditioner } if preconditioner != CgPreconditioner::Amg);
    let stored = StoredSprings::assemble(&net, products_only);
    // K holds the springs from here on: free the network's copy before the solve's vectors.
    net.release_springs();
    let (pre, diag) = jacobi_pieces(&stored.springs(), term_op.as_ref());
    net.null_space.other_singular_particles = (0..m)
        .filter(|&p| {
            let full = if net.degree[p] == 2 { 5 } else { 6 };
            let full = if opts.rotations { full } else { 3 };
            pre[p].1 < full
        })
        .count();
    let mut scale = load_scales(&net);
    if let Some(term_scale) = &term_scale {
        for (s, t) in scale.iter_mut().zip(term_scale) {
            *s = s.hypot(*t);
        }
    }
    let (q, iterations, residual, (gtq, qtkq)) = match (opts.solver, stored) {
        (RelaxedSolver::Cholesky, stored) => {
            let springs = stored.springs().full()?;
            let merged = match term {
                Some(t) => Some(with_term_hessian(springs, t, &net.index)?),
                None => None,
            };
            let kmat = merged.as_ref().unwrap_or(springs);
            let (q, it, res) = cholesky_fluctuations(kmat, &net.g, &scale, opts.tolerance)?;
            let terms = kmat.fluctuation_terms(&net.g, &q);
            (q, it, res, terms)
        }
        (RelaxedSolver::Cg { preconditioner }, stored) => {
            let start = initial.filter(|x| x.len() == m);
            // The CG on K = `k` (+ the term) with its preconditioner's pieces; every path
            // below ends here once.
            let solve =
                |k: Springs, groups, coarse: (Option<&TwoLevel>, Option<&Amg<'_>>)| -> Result<_> {
                    let op = Stiffness {
                        k,
                        term: term_op.as_ref(),
                        diag,
                        groups,
                    };
                    let (q, it, res) = pcg(&op, &net.g, &pre, coarse, &scale, opts, start)?;
                    let terms = op.fluctuation_terms(&net.g, &q);
                    Ok((q, it, res, terms))
                };
            if preconditioner == CgPreconditioner::Amg {
                // The multigrid hierarchy is built on the assembled matrix: the springs',
                // plus the term's Hessian when there is one.
                let full = stored.springs().full()?;
                let merged = match term {
                    Some(t) => Some(with_term_hessian(full, t, &net.index)?),
                    None => None,
                };
                let kmat = merged.as_ref().unwrap_or(full);
                let amg = Amg::of_network(kmat, packing, &net.original, opts.rotations)?;
                // Without a term, the V-cycle's finest level and the CG multiply by the
                // springs' upper triangle from here on, the full matrix freed. The V-cycle
                // carries the term's stiff stencils itself: no groups.
                let upper = match merged {
                    None => UpperBlocks::of(full),
                    Some(_) => None,
                };
                match upper {
                    Some(u) => {
                        let amg = amg.on_upper(&u);
                        drop(stored);
                        solve(Springs::Upper(&u), None, (None, Some(&amg)))?
                    }
                    None => solve(stored.springs(), None, (None, Some(&amg)))?,
                }
            } else {
                let springs = stored.springs();
                let two_level = coarse_space(
                    packing,
                    &net,
                    (springs, term_op.as_ref()),
                    preconditioner,
                    opts.rotations,
                )?;
                // With a term, K is the full matrix (`products_only` is false).
                let groups = match term_op.as_ref() {
                    Some(t) => StiffGroups::new(springs.full()?, t),
                    None => None,
                };
                solve(springs, groups, (two_level.as_ref(), None))?
            }
        }
    };
    let c = net.h - gtq - gtq.transpose() + qtkq;
    let c = (c + c.transpose()) * (0.5 / net.volume);
    Ok(RelaxedSolution {
        result: RelaxedResult {
            c,
            c_affine,
            iterations,
            relative_residual: residual,
            active_particles: m,
            active_bonds: net.ends.len(),
            null_space: net.null_space,
        },
        q,
        active: net.original,
    })
}

/// The checked, linearised network of the springs, with the many-body term's load and
/// affine tensor added to G and H when there is one (then dangling particles stay: the term
/// couples them): what the relaxed solve and the exported system (`system.rs`) share. Also
/// the term in factored form and its load scales.
pub(super) fn network_with_term(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &RelaxedOptions,
    axial_force: Option<&[f64]>,
    term: Option<&ManyBody>,
) -> Result<(Network, Option<TermOperator>, Option<[f64; 6]>)> {
    opts.validate()?;
    require_cell(packing)?;
    if let Some(t) = term {
        if t.len() != packing.len() || t.reference_branches().len() != bonds.len() {
            return Err(Error::Invalid(format!(
                "relaxed solver: the many-body term has {} particles and {} bonds, the packing {} particles and {} bonds (build it from the same packing and bonds)",
                t.len(),
                t.reference_branches().len(),
                packing.len(),
                bonds.len()
            )));
        }
    }
    let mut net = Network::build_with(
        packing,
        bonds,
        k,
        opts.lever_arm,
        opts.rotations,
        axial_force,
        term.is_some(),
    )?;
    let term_op = match term {
        Some(t) => Some(TermOperator::new(t, &net.index, net.n_active)?),
        None => None,
    };
    let term_scale = term_op.as_ref().map(|op| add_term(&mut net, op));
    Ok((net, term_op, term_scale))
}

/// The springs' assembled K plus the many-body term's Hessian restricted to the active
/// particles (`index`: packing → row): K in assembled form (second neighbours), for the
/// sparse Cholesky, the multigrid and the exported system.
pub(super) fn with_term_hessian(
    springs: &BlockSparse,
    term: &ManyBody,
    index: &[u32],
) -> Result<BlockSparse> {
    springs.add(
        &term
            .hessian(term.reference_branches())?
            .restrict(index, 1.0),
    )
}

/// K of the CG: the springs' assembled 6×6 blocks, plus a many-body term in factored form,
/// with the diagonal entries of the sum (per row, the six DOFs).
struct Stiffness<'a> {
    k: Springs<'a>,
    term: Option<&'a TermOperator>,
    diag: Vec<[f64; 6]>,
    /// Dense diagonal blocks of the preconditioner: over the term's stiff stencils, or a
    /// held structure's loose patches ([`LOOSE_BONDS`]).
    groups: Option<StiffGroups>,
}

/// The springs' assembled K as the solve stores it: in full, or by its upper triangle
/// ([`UpperBlocks`]: the same products bit for bit, half the memory).
enum StoredSprings {
    Full(BlockSparse),
    Upper(UpperBlocks),
    Bonds(BondSprings),
}

impl StoredSprings {
    /// K of the network, applied bond by bond when `products_only` ([`BondSprings`]: its
    /// off-diagonal blocks never formed), else assembled in full.
    fn assemble(net: &Network, products_only: bool) -> StoredSprings {
        if products_only {
            StoredSprings::Bonds(BondSprings::of(net))
        } else {
            StoredSprings::Full(BlockSparse::assemble(net))
        }
    }

    /// `k`, by its upper triangle when `products_only` and its mirrored blocks are
    /// transposes bit for bit (compacted in its own storage, the rest freed).
    fn of(k: BlockSparse, products_only: bool) -> StoredSprings {
        if !products_only {
            return StoredSprings::Full(k);
        }
        match UpperBlocks::of_owned(k) {
            Ok(u) => StoredSprings::Upper(u),
            Err(k) => StoredSprings::Full(k),
        }
    }

    fn springs(&self) -> Springs<'_> {
        match self {
            StoredSprings::Full(k) => Springs::Full(k),
            StoredSprings::Upper(k) => Springs::Upper(k),
            StoredSprings::Bonds(k) => Springs::Bonds(k),
        }
    }
}

/// The springs' K as the solvers read it, borrowed: in full or by its upper triangle.
#[derive(Clone, Copy)]
enum Springs<'a> {
    Full(&'a BlockSparse),
    Upper(&'a UpperBlocks),
    Bonds(&'a BondSprings),
}

impl<'a> Springs<'a> {
    /// The full matrix (the sparse Cholesky and the multigrid setup need it).
    fn full(self) -> Result<&'a BlockSparse> {
        match self {
            Springs::Full(k) => Ok(k),
            Springs::Upper(_) | Springs::Bonds(_) => Err(Error::Invalid(
                "relaxed solver: the full stiffness matrix was freed".into(),
            )),
        }
    }

    /// The bound's width w of [`judge_curvature`]: 6 scalars per block of a row; applied
    /// bond by bond, thrice that, as each end's terms (k_s u, (k_n − k_s)(n·u) n, the arms'
    /// cross products) reach up to thrice its block's entries.
    fn row_width(self) -> usize {
        match self {
            Springs::Full(k) => 6 * k.max_row_blocks(),
            Springs::Upper(k) => 6 * k.max_row_blocks(),
            Springs::Bonds(k) => 18 * k.max_row_blocks(),
        }
    }

    /// The longest chain of roundings in one entry of K x: 6 per stored block; applied bond
    /// by bond, 6 for the diagonal block and 10 per bond end (its dot or cross product, its
    /// scaling, and its three terms added).
    fn entry_depth(self) -> usize {
        match self {
            Springs::Full(k) => 6 * k.max_row_blocks(),
            Springs::Upper(k) => 6 * k.max_row_blocks(),
            Springs::Bonds(k) => 6 + 10 * (k.max_row_blocks() - 1),
        }
    }

    fn apply_cols<const C: usize>(self, x: &[Cols<C>], y: &mut [Cols<C>], cols: usize) {
        match self {
            Springs::Full(k) => k.apply_cols(x, y, cols),
            Springs::Upper(k) => k.apply_cols(x, y, cols),
            Springs::Bonds(k) => k.apply_cols(x, y, cols),
        }
    }

    #[inline(always)]
    fn row_times<const C: usize>(self, p: usize, x: &[Cols<C>], cols: usize) -> Cols<C> {
        match self {
            Springs::Full(k) => k.row_times(p, x, cols),
            Springs::Upper(k) => k.row_times(p, x, cols),
            Springs::Bonds(k) => k.row_times(p, x, cols),
        }
    }
}

impl BlockRows for Springs<'_> {
    fn rows(&self) -> usize {
        match *self {
            Springs::Full(k) => k.rows(),
            Springs::Upper(k) => BlockRows::rows(k),
            Springs::Bonds(k) => BlockRows::rows(k),
        }
    }
    fn each_in_row(&self, p: usize, f: impl FnMut(usize, &Block6)) {
        match *self {
            Springs::Full(k) => BlockRows::each_in_row(k, p, f),
            Springs::Upper(k) => k.each_in_row(p, f),
            Springs::Bonds(k) => k.each_in_row(p, f),
        }
    }
    fn diagonal(&self, p: usize) -> Block6 {
        match *self {
            Springs::Full(k) => k.diagonal(p),
            Springs::Upper(k) => BlockRows::diagonal(k, p),
            Springs::Bonds(k) => BlockRows::diagonal(k, p),
        }
    }
}

impl Stiffness<'_> {
    /// The most scalars in one row of K: the springs' ([`Springs::row_width`]), plus 6 per
    /// node the term couples ([`TermOperator::coupling_width`]).
    fn row_width(&self) -> usize {
        self.k.row_width() + 6 * self.term.map_or(0, |t| t.coupling_width())
    }

    /// The longest chain of additions in one computed x_cᵀ K x_c: one entry of K x (the
    /// springs', [`Springs::entry_depth`], plus the term's, [`TermOperator::rounding_depth`]) and the dot
    /// product of [`column_dots`] (6 within a row, one per row of a chunk, one per chunk).
    fn rounding_depth(&self, rows: usize) -> usize {
        let entry = self.k.entry_depth() + self.term.map_or(0, |t| t.rounding_depth());
        entry + 6 + rows.min(2048) + rows.div_ceil(2048)
    }

    /// Y = K X on the first `cols` load cases, row by row in a fixed order.
    /// With a term, one pass over the rows after the term's per-owner stresses: the springs'
    /// row, then the term's (the bits of the two applied one after the other). The term
    /// takes six load cases ([`pcg`] refuses fewer with it).
    fn apply_cols<const C: usize>(&self, x: &[Cols<C>], y: &mut [Cols<C>], cols: usize)
    where
        Cols<C>: AsSix,
    {
        let Some(t) = self.term else {
            return self.k.apply_cols(x, y, cols);
        };
        let (Some(x), Some(y)) = (AsSix::six(x), AsSix::six_mut(y)) else {
            unreachable!("pcg refuses the many-body term on fewer than six load cases");
        };
        let work = t.stresses(x, cols);
        y.par_iter_mut().enumerate().for_each(|(r, yr)| {
            *yr = self.k.row_times(r, x, cols);
            t.add_row(r, &work, yr, cols);
        });
    }

    /// K p into `ap` and the curvatures of [`curvatures`] (the same bits), in one pass over
    /// the rows when K is the springs' alone, as an upper triangle or bond by bond (their
    /// [`RowProducts`]): each chunk's sums are taken as
    /// soon as its rows of K p are computed, while p and K p are in cache.
    /// `pt`: p transposed, when the CG keeps it so ([`Self::takes_transposed`]).
    fn apply_curvatures<const C: usize>(
        &self,
        p: &[Cols<C>],
        pt: Option<&[CaseRows]>,
        ap: &mut [Cols<C>],
        cols: usize,
    ) -> ([f64; C], [f64; C])
    where
        Cols<C>: AsSix,
    {
        match (self.k, self.term) {
            (Springs::Upper(k), None) => self.product_curvatures(k, p, pt, ap, cols),
            (Springs::Bonds(k), None) => self.product_curvatures(k, p, pt, ap, cols),
            _ => {
                self.apply_cols(p, ap, cols);
                curvatures(p, ap, &self.diag)
            }
        }
    }

    /// [`Self::apply_curvatures`] by the row products of `k`, chunk by chunk.
    fn product_curvatures<const C: usize>(
        &self,
        k: &impl RowProducts,
        p: &[Cols<C>],
        pt: Option<&[CaseRows]>,
        ap: &mut [Cols<C>],
        cols: usize,
    ) -> ([f64; C], [f64; C]) {
        let then = |first: usize, ys: &[Cols<C>]| {
            let rows = first..first + ys.len();
            curvature_chunk(&p[rows.clone()], ys, &self.diag[rows])
        };
        sum_curvatures(match pt {
            Some(pt) => k.apply_transposed_then(p, pt, ap, cols, CURVATURE_ROWS, then),
            None => k.apply_cols_then(p, ap, cols, CURVATURE_ROWS, then),
        })
    }

    /// Whether [`Self::apply_curvatures`] reads p transposed on `C` load cases (the springs'
    /// alone, as an upper triangle or bond by bond, by the fused kernels): then the CG keeps p
    /// so as it updates it.
    fn takes_transposed<const C: usize>(&self) -> bool {
        matches!(
            (self.k, self.term),
            (Springs::Upper(_) | Springs::Bonds(_), None)
        ) && super::fused::runs::<C>()
    }

    /// Gᵀq and qᵀKq (as [`BlockSparse::fluctuation_terms`], summed particle by particle in
    /// order) with the term's share of K.
    fn fluctuation_terms(&self, g: &[Block6], q: &[Block6]) -> (Block6, Block6) {
        let mut kq = filled(q.len(), Block6::zeros());
        self.apply_cols(q, &mut kq, 6);
        super::sparse::fluctuation_sums(g, q, &kq)
    }
}

/// The six diagonal entries of a 6×6 block.
/// Block-Jacobi pieces of K (the springs' K plus the term's diagonal blocks): each
/// particle's pseudo-inverse with its rank, and its diagonal entries for [`pcg`]'s
/// rounding bound on pᵀKp.
#[allow(clippy::type_complexity)]
fn jacobi_pieces(
    k: &impl BlockRows,
    term: Option<&TermOperator>,
) -> (Vec<(Block6, usize)>, Vec<[f64; 6]>) {
    (0..k.rows())
        .into_par_iter()
        .map(|p| {
            let block = match term {
                Some(op) => k.diagonal(p) + op.diagonal(p),
                None => k.diagonal(p),
            };
            (pinv_psd(&block), diagonal_entries(&block))
        })
        .unzip()
}

fn diagonal_entries(block: &Block6) -> [f64; 6] {
    std::array::from_fn(|i| block[(i, i)])
}

/// Add the many-body term at its reference state to the network (Kruyt 2014 Eqs. 10–14 with
/// the term's energy): its affine tensor to H, its mixed block to G; returns the norm of its
/// load per load case (for [`load_scales`]). Particles without bonds are in no particle's
/// stencil, so nothing of the term falls on an inactive particle.
fn add_term(net: &mut Network, term: &TermOperator) -> [f64; 6] {
    net.h += term.affine();
    let g = term.load();
    for (gn, gp) in net.g.iter_mut().zip(&g) {
        *gn += gp;
    }
    column_dots(&g, &g).map(f64::sqrt)
}

/// Scale of each load case before the cancellation of bond contributions at a particle
/// (√Σ over the bonds of ‖G_i‖² + ‖G_j‖²): a right-hand side below 1e-10 of it is zero up
/// to rounding (e.g. a perfect lattice).
fn load_scales(net: &Network) -> [f64; 6] {
    net.load_norms2.map(f64::sqrt)
}

/// Q with K Q = G by the sparse Cholesky of K (dead load cases zero), with its relative
/// residual; refuses a residual above `tolerance` (ill-conditioned K or a mechanism).
fn cholesky_fluctuations(
    kmat: &BlockSparse,
    g: &[Block6],
    scale: &[f64; 6],
    tolerance: f64,
) -> Result<(Vec<Block6>, usize, f64)> {
    let chol = BlockCholesky::factor(kmat)?;
    let (live, bnorm) = live_columns(g, scale);
    let mut q = chol.solve(g)?;
    for qp in q.iter_mut() {
        for (c, &alive) in live.iter().enumerate() {
            if !alive {
                qp.column_mut(c).fill(0.0);
            }
        }
    }
    let mut kq = vec![Block6::zeros(); g.len()];
    kmat.apply(&q, &mut kq);
    kq.par_iter_mut()
        .zip(g.par_iter())
        .for_each(|(r, g)| *r = g - *r);
    let residual = worst_residual(&kq, &live, &bnorm);
    if residual > tolerance {
        return Err(Error::Invalid(format!(
            "relaxed solver (Cholesky): relative residual {residual:.3e} > tolerance \
             {tolerance:.1e}; the stiffness matrix is too ill-conditioned or the bond network \
             contains a mechanism"
        )));
    }
    Ok((q, 0, residual))
}

/// The two-level coarse space of the CG ([`super::two_level`], aggregates on a grid over
/// the periodic cell; with a many-body term, its K P from the term's factored form), or
/// `None` for block-Jacobi. A coarse space that cannot be factored
/// (e.g. a single aggregate, whose translations are all null) only weakens the
/// preconditioner: `None` then too; the solution and its accuracy are unchanged.
fn coarse_space(
    packing: &Packing,
    net: &Network,
    (k, term): (Springs, Option<&TermOperator>),
    preconditioner: CgPreconditioner,
    rotations: bool,
) -> Result<Option<TwoLevel>> {
    let CgPreconditioner::TwoLevel {
        particles_per_aggregate,
    } = preconditioner
    else {
        return Ok(None);
    };
    let lengths = packing
        .cell
        .map(|c| c.lengths)
        .ok_or_else(|| Error::Invalid("relaxed solver: no periodic cell".into()))?;
    let positions: Vec<crate::Vec3> = net
        .original
        .iter()
        .map(|&p| packing.positions[p as usize])
        .collect();
    let particles_per_aggregate = aggregate_size(particles_per_aggregate, positions.len());
    let space = match term {
        Some(t) => super::term_preconditioner::coarse_space(
            k.full()?,
            t,
            &positions,
            lengths,
            rotations,
            particles_per_aggregate,
        ),
        None => TwoLevel::with_extra(
            &k,
            &positions,
            lengths,
            rotations,
            particles_per_aggregate,
            |_, _| None,
        ),
    };
    Ok(space.ok())
}

/// X with K X = B by block-Jacobi preconditioned CG to the relative residual `tolerance` on
/// every non-zero column: for a held structure whose K is only semi-definite (zero-energy
/// modes such as counter-rotating "gear" particles, which a consistent load never excites),
/// where the Cholesky factorisation meets a zero pivot.
pub(crate) fn block_jacobi_cg(
    k: &BlockSparse,
    b: &[Block6],
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<Block6>, usize, f64)> {
    held_cg(k, b, (None, None), tolerance, max_iterations)
}

/// Nodes with fewer bonds than this get a dense block-Jacobi patch with their bonded
/// neighbours in [`two_level_cg`] ([`StiffGroups::loose`]): the slow modes of a free
/// specimen's CG are the lateral surface's particles kept by one to three bonds. Measured on
/// the free 100,000-sphere cluster (docs/specimens.md): 223 iterations without patches,
/// 117 below 3 bonds, 88 below 4 (4,504 nodes in patches), 78 below 5 (13,693 nodes, slower).
const LOOSE_BONDS: usize = 4;

/// [`block_jacobi_cg`] with the two-level preconditioner of [`super::two_level`] (aggregates
/// of about [`DEFAULT_PARTICLES_PER_AGGREGATE`] nodes on a grid over `box_lengths`, `positions`
/// inside [0, box_lengths); the coarse space of the held structure, [`TwoLevel::held`]):
/// iterations nearly independent of the size, for a held structure too large for the direct
/// solve. Falls back to block-Jacobi when the coarse space cannot be built (only the
/// preconditioner is weaker; the last value returned says whether the two-level one was
/// used). The loosely held nodes' patches ([`LOOSE_BONDS`]) are dense blocks of the
/// block-Jacobi step. Once the preconditioner is set up, `k` is kept by its upper triangle
/// ([`StoredSprings`]: the same bits, half the memory).
pub(crate) fn two_level_cg(
    k: BlockSparse,
    b: &[Block6],
    (positions, box_lengths): (&[crate::Vec3], crate::Vec3),
    held: &HeldSpace,
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<Block6>, usize, f64, bool)> {
    let two_level = TwoLevel::held(
        &k,
        positions,
        box_lengths,
        aggregate_size(DEFAULT_PARTICLES_PER_AGGREGATE, k.rows()),
        held,
    )
    .ok();
    let pieces = jacobi_pieces(&k, None);
    let groups = StiffGroups::loose(&k, LOOSE_BONDS);
    let stored = StoredSprings::of(k, true);
    let (x, iterations, residual) = held_cg_with(
        (stored.springs(), pieces, groups),
        b,
        (two_level.as_ref(), None),
        tolerance,
        max_iterations,
    )?;
    Ok((x, iterations, residual, two_level.is_some()))
}

/// [`block_jacobi_cg`] preconditioned by one multigrid V-cycle of `amg` per iteration (built
/// on `k`, e.g. by [`Amg::of_held`]): the specimen's `cg-amg` solve (issue 35).
pub(crate) fn amg_cg(
    k: &BlockSparse,
    b: &[Block6],
    amg: &Amg,
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<Block6>, usize, f64)> {
    held_cg(k, b, (None, Some(amg)), tolerance, max_iterations)
}

/// The CG of a held structure shared by [`block_jacobi_cg`], [`two_level_cg`] and
/// [`amg_cg`]: block-Jacobi blocks, column scales of `b`, and the two-level correction or
/// the multigrid V-cycle when given.
fn held_cg(
    k: &BlockSparse,
    b: &[Block6],
    coarse: (Option<&TwoLevel>, Option<&Amg>),
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<Block6>, usize, f64)> {
    let pieces = jacobi_pieces(k, None);
    held_cg_with(
        (Springs::Full(k), pieces, None),
        b,
        coarse,
        tolerance,
        max_iterations,
    )
}

/// The block-Jacobi pieces of K ([`jacobi_pieces`]): pseudo-inverted diagonal blocks and
/// their diagonal entries.
type JacobiPieces = (Vec<(Block6, usize)>, Vec<[f64; 6]>);

/// [`held_cg`] on the springs `k` with their block-Jacobi pieces, on as many load cases as
/// `b` has up to its last non-zero one (a specimen's one or two: the CG's vectors, products
/// and coarse solves carry no dead columns; issue 35), six with the multigrid.
fn held_cg_with(
    (k, (pre, diag), groups): (Springs, JacobiPieces, Option<StiffGroups>),
    b: &[Block6],
    coarse: (Option<&TwoLevel>, Option<&Amg>),
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<Block6>, usize, f64)> {
    let scale = column_dots(b, b).map(f64::sqrt);
    let opts = RelaxedOptions {
        tolerance,
        max_iterations,
        ..Default::default()
    };
    let op = Stiffness {
        k,
        term: None,
        diag,
        groups,
    };
    let cols = scale.iter().rposition(|&s| s > 0.0).map_or(1, |c| c + 1);
    match (cols, coarse.1) {
        (1, None) => narrow_pcg::<1>(&op, b, &pre, coarse, &scale, &opts),
        (2, None) => narrow_pcg::<2>(&op, b, &pre, coarse, &scale, &opts),
        _ => pcg(&op, b, &pre, coarse, &scale, &opts, None),
    }
}

/// [`pcg`] on the first `C` load cases of `b` (the others zero), its solution widened back
/// to six (zero past `C`).
fn narrow_pcg<const C: usize>(
    op: &Stiffness,
    b: &[Block6],
    pre: &[(Block6, usize)],
    coarse: (Option<&TwoLevel>, Option<&Amg>),
    scale: &[f64; 6],
    opts: &RelaxedOptions,
) -> Result<(Vec<Block6>, usize, f64)>
where
    Cols<C>: AsSix,
{
    let narrow: Vec<Cols<C>> = b
        .par_iter()
        .map(|b| b.fixed_columns::<C>(0).into_owned())
        .collect();
    let scale: [f64; C] = std::array::from_fn(|c| scale[c]);
    let (x, iterations, residual) = pcg(op, &narrow, pre, coarse, &scale, opts, None)?;
    let wide = x
        .par_iter()
        .map(|x| {
            let mut w = Block6::zeros();
            w.fixed_columns_mut::<C>(0).copy_from(x);
            w
        })
        .collect();
    Ok((wide, iterations, residual))
}

/// Right-hand-side columns that are not rounding noise (norm above 1e-10 of the load case's
/// scale before cancellation), and the column norms.
fn live_columns<const C: usize>(b: &[Cols<C>], scale: &[f64; C]) -> ([bool; C], [f64; C]) {
    let bnorm = column_dots(b, b).map(f64::sqrt);
    (std::array::from_fn(|c| bnorm[c] > 1e-10 * scale[c]), bnorm)
}

/// Largest relative residual ‖r_c‖/‖b_c‖ over the live columns.
fn worst_residual<const C: usize>(r: &[Cols<C>], live: &[bool; C], bnorm: &[f64; C]) -> f64 {
    column_residuals(r, live, bnorm)
        .iter()
        .fold(0.0, |a: f64, &b| a.max(b))
}

/// Relative residual ‖r_c‖/‖b_c‖ of every live column (0 for the others).
fn column_residuals<const C: usize>(r: &[Cols<C>], live: &[bool; C], bnorm: &[f64; C]) -> [f64; C] {
    residuals_of(&column_dots(r, r), live, bnorm)
}

/// [`column_residuals`] from the squared norms ‖r_c‖² (`rr`).
fn residuals_of<const C: usize>(rr: &[f64; C], live: &[bool; C], bnorm: &[f64; C]) -> [f64; C] {
    std::array::from_fn(|c| {
        if live[c] {
            rr[c].sqrt() / bnorm[c]
        } else {
            0.0
        }
    })
}

/// γ_n = n u / (1 − n u) (u = 2⁻⁵³, the unit roundoff): a computed sum of products with at
/// most n additions in a chain differs from the exact one by at most γ_n times the sum of
/// their absolute values (Higham 2002, "Accuracy and Stability of Numerical Algorithms",
/// Eq. 3.5 and Lemma 3.1).
fn unit_rounding_bound(n: usize) -> f64 {
    let nu = n as f64 * f64::EPSILON / 2.0;
    nu / (1.0 - nu)
}

/// The verdict on the curvatures pᵀKp of the CG's search directions in the `judged` load
/// cases (`bound`: γ_n w pᵀdiag(K)p, the rounding error each can carry: a computed sum of
/// products errs by at most γ_n times the sum of their absolute values, and |p|ᵀ|K||p| ≤
/// w pᵀdiag(K)p for a positive semi-definite K of w scalars per row, as |K_ij| ≤
/// √(K_ii K_jj)). A curvature below −bound is a negative one, which only a
/// preload (geometric stiffness) can give: the network buckles ([`Error::Degenerate`]). One
/// within ±bound carries no sign: the direction has no energy that the arithmetic can see.
/// Its load case is then done if its residual meets the tolerance (marked in `done`: no
/// further steps), and otherwise stalled at rounding level ([`Error::NotConverged`]): a step
/// rz/pᵀKp would be a quotient of rounding errors, and stopping would return an answer
/// above the tolerance asked for.
fn judge_curvature<const C: usize>(
    pap: &[f64; C],
    bound: &[f64; C],
    judged: &[bool; C],
    residual: &[f64; C],
    tolerance: f64,
    done: &mut [bool; C],
) -> Result<()> {
    if let Some(c) = (0..C).find(|&c| judged[c] && pap[c] < -bound[c]) {
        return Err(Error::Degenerate(format!(
            "relaxed solver: the stiffness matrix is not positive (pᵀKp = {:.3e} < 0 in load \
             case {}, beyond its rounding error {:.1e}): under this preload the network is \
             unstable (buckles)",
            pap[c],
            c + 1,
            bound[c]
        )));
    }
    for c in (0..C).filter(|&c| judged[c] && pap[c].abs() <= bound[c]) {
        if residual[c] > tolerance {
            return Err(Error::NotConverged(format!(
                "relaxed solver: stalled at rounding level in load case {}: the search \
                 direction's curvature pᵀKp = {:.3e} is within its rounding error {:.1e} while \
                 the relative residual is {:.3e} > tolerance {tolerance:.1e}; loosen the \
                 tolerance (--cg-tolerance) or use the sparse Cholesky solver",
                c + 1,
                pap[c],
                bound[c],
                residual[c]
            )));
        }
        done[c] = true;
    }
    Ok(())
}

/// Preconditioned conjugate gradients on `C` load cases together (the relaxed tensor's six,
/// a specimen's one or two), K X = B, from
/// X₀ = `start` (or 0); block-Jacobi, or the balancing two-level preconditioner
/// z = Q r + (I − QK) M (I − KQ) r with M = block-Jacobi when `two_level` is given, or one
/// multigrid V-cycle when `amg` is. The many-body term and the multigrid take six load cases:
/// refused with fewer.
fn pcg<const C: usize>(
    k: &Stiffness,
    b: &[Cols<C>],
    pre: &[(Block6, usize)],
    (two_level, amg): (Option<&TwoLevel>, Option<&Amg>),
    scale: &[f64; C],
    opts: &RelaxedOptions,
    start: Option<&[Cols<C>]>,
) -> Result<(Vec<Cols<C>>, usize, f64)>
where
    Cols<C>: AsSix,
{
    let m = b.len();
    if C != 6 && (k.term.is_some() || amg.is_some()) {
        return Err(Error::Invalid(format!(
            "relaxed solver: the many-body term and the multigrid take six load cases, not {C}"
        )));
    }
    let (live, bnorm) = live_columns(b, scale);
    // Load cases past the last live one are zero throughout: not computed.
    let cols = live.iter().rposition(|&l| l).map_or(1, |c| c + 1);
    let mut precondition = Preconditioner::new(pre, two_level, cols, m);
    precondition.amg = amg;
    precondition.groups = k.groups.as_ref();
    // z and K p, first the scratch of the start's coarse correction.
    let (mut z, mut ap) = (filled(m, Cols::<C>::zeros()), filled(m, Cols::<C>::zeros()));
    let (mut x, mut r) = cg_start(k, b, start, &live, two_level, (&mut z, &mut ap))?;
    precondition.apply(&r, &mut z)?;
    let mut p = copied(&z);
    // With the coarse space after the block-Jacobi step alone, z = (I − QK) w has rᵀz = rᵀw
    // (Pᵀr = 0, see [`Preconditioner::apply`]): the CG takes rᵀw, and each step's z goes
    // straight into the next direction ([`TwoLevel::deflated_direction`]), never stored.
    let deflated = precondition.jacobi_alone() && precondition.two_level.is_some();
    let mut rz = if deflated {
        z = Vec::new();
        column_dots(&r, &precondition.w)
    } else {
        column_dots(&r, &z)
    };
    // p transposed for the products with K, kept by the deflated direction update.
    let mut pt: Option<Vec<CaseRows>> = (deflated && k.takes_transposed::<C>())
        .then(|| p.par_iter().map(|q| CaseRows::of(q, cols)).collect());
    let mut worst = 0.0;
    // |fl(pᵀKp) − pᵀKp| ≤ γ_n |p|ᵀ|K||p| ≤ γ_n w pᵀdiag(K)p ([`judge_curvature`]).
    let rounding = unit_rounding_bound(k.rounding_depth(m)) * k.row_width() as f64;
    // Load cases whose search direction reached the rounding level after their residual met
    // the tolerance: no further steps (their residual stays as it is).
    let mut done = [false; C];
    // ‖r_c‖² from the last step, when it computed them with the block-Jacobi step.
    let mut rr: Option<[f64; C]> = None;
    for it in 0..=opts.max_iterations {
        let residual = match rr.take() {
            Some(rr) => residuals_of(&rr, &live, &bnorm),
            None => column_residuals(&r, &live, &bnorm),
        };
        worst = residual.iter().fold(0.0, |a: f64, &b| a.max(b));
        if worst <= opts.tolerance {
            return Ok((x, it, worst));
        }
        if it == opts.max_iterations {
            break;
        }
        let (pap, pdp) = k.apply_curvatures(&p, pt.as_deref(), &mut ap, cols);
        let judged: [bool; C] = std::array::from_fn(|c| live[c] && !done[c]);
        let bound: [f64; C] = std::array::from_fn(|c| rounding * pdp[c]);
        judge_curvature(&pap, &bound, &judged, &residual, opts.tolerance, &mut done)?;
        let alpha: [f64; C] = std::array::from_fn(|c| {
            if live[c] && !done[c] && pap[c] > 0.0 {
                rz[c] / pap[c]
            } else {
                0.0
            }
        });
        // z = M r and rᵀz; without the multigrid or dense groups in fewer passes over the
        // rows (the same bits).
        let rz_new = if precondition.jacobi_alone() {
            let w = match precondition.two_level {
                Some(_) => &mut precondition.w,
                None => &mut z,
            };
            let cols = precondition.cols;
            // The deflated direction update takes x += α p itself (it reads p anyway).
            let step = (&alpha, !deflated);
            let (rr_new, rw) = cg_step_jacobi(&mut x, &mut r, &p, &ap, step, pre, cols, w);
            rr = Some(rr_new);
            rw
        } else {
            cg_step(&mut x, &mut r, &p, &ap, &alpha);
            precondition.apply(&r, &mut z)?;
            column_dots(&r, &z)
        };
        let beta: [f64; C] = std::array::from_fn(|c| {
            if rz[c] > 0.0 && !done[c] {
                rz_new[c] / rz[c]
            } else {
                0.0
            }
        });
        match precondition.two_level {
            Some(tl) if deflated => {
                let step = (&mut x[..], &alpha);
                tl.deflated_direction(
                    &precondition.w,
                    &mut p,
                    pt.as_deref_mut(),
                    step,
                    &beta,
                    cols,
                )?
            }
            _ => p
                .par_iter_mut()
                .zip(z.par_iter())
                .for_each(|(p, z)| direction_cols(p, z, &beta)),
        }
        rz = rz_new;
    }
    Err(Error::NotConverged(format!(
        "relaxed solver: no convergence in {} iterations (relative residual {worst:.3e} > tolerance {:.1e}); the bond network may contain a mechanism",
        opts.max_iterations, opts.tolerance
    )))
}

/// The preconditioner of [`pcg`] on its first `cols` load cases: block-Jacobi M, or with
/// the two-level coarse space (I − QK) M, with its work vectors.
struct Preconditioner<'a, const C: usize> {
    /// Pseudo-inverses of the diagonal blocks.
    pre: &'a [(Block6, usize)],
    /// The coarse space, when used.
    two_level: Option<&'a TwoLevel>,
    /// Load cases computed.
    cols: usize,
    /// M r (two-level only).
    w: Vec<Cols<C>>,
    /// The multigrid V-cycle, when used instead.
    amg: Option<&'a Amg<'a>>,
    /// Dense blocks of M (term_preconditioner.rs): the term's stiff stencils, or a held
    /// structure's loose patches.
    groups: Option<&'a StiffGroups>,
}

impl<'a, const C: usize> Preconditioner<'a, C>
where
    Cols<C>: AsSix,
{
    /// The preconditioner of `m` nodes.
    fn new(
        pre: &'a [(Block6, usize)],
        two_level: Option<&'a TwoLevel>,
        cols: usize,
        m: usize,
    ) -> Self {
        let w = match two_level {
            Some(_) => filled(m, Cols::<C>::zeros()),
            None => Vec::new(),
        };
        Preconditioner {
            pre,
            two_level,
            cols,
            w,
            amg: None,
            groups: None,
        }
    }

    /// z = M r, the block-Jacobi step.
    fn jacobi(pre: &[(Block6, usize)], cols: usize, r: &[Cols<C>], z: &mut [Cols<C>]) {
        const CH: usize = 512;
        z.par_chunks_mut(CH)
            .zip(r.par_chunks(CH))
            .zip(pre.par_chunks(CH))
            .for_each(|((z, r), pre)| {
                if super::fused::runs::<C>() {
                    // SAFETY: the fused kernels run here (checked above).
                    return unsafe { Self::jacobi_fused(pre, cols, r, z) };
                }
                super::sparse::avx2!({
                    for ((z, r), (p, _)) in z.iter_mut().zip(r).zip(pre) {
                        *z = mul6_cols(p, r, cols);
                    }
                })
            });
    }

    /// [`Self::jacobi`] on one chunk by the fused kernel ([`super::fused::straight_sum`]).
    ///
    /// # Safety
    /// Only where [`super::fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn jacobi_fused(pre: &[(Block6, usize)], cols: usize, r: &[Cols<C>], z: &mut [Cols<C>]) {
        for ((z, r), (p, _)) in z.iter_mut().zip(r).zip(pre) {
            *z = super::fused::straight_sum(std::iter::once((p, r)), cols);
        }
    }

    /// Whether M starts with the block-Jacobi step alone (no multigrid, no dense groups):
    /// then [`cg_step_jacobi`] takes that step and [`TwoLevel::deflated_direction`] the rest.
    fn jacobi_alone(&self) -> bool {
        self.amg.is_none() && self.groups.is_none()
    }

    /// z = M r, or with the coarse space z = (I − QK) M r: with r ⟂ range(P) (arranged by
    /// [`cg_start`]), the balancing preconditioner reduces to this, and every later residual
    /// stays ⟂ range(P) since Pᵀ K (I − QK) = 0 (Tang et al. 2009, A-DEF2 ≡ BNN with this
    /// start).
    fn apply(&mut self, r: &[Cols<C>], z: &mut [Cols<C>]) -> Result<()> {
        if let Some(amg) = self.amg {
            let (Some(r), Some(z)) = (AsSix::six(r), AsSix::six_mut(z)) else {
                unreachable!("pcg refuses the multigrid on fewer than six load cases");
            };
            return amg.apply_cols(r, z, self.cols);
        }
        let Some(tl) = self.two_level else {
            Self::jacobi(self.pre, self.cols, r, z);
            Self::stiff_groups(self.groups, r, z, self.cols);
            return Ok(());
        };
        Self::jacobi(self.pre, self.cols, r, &mut self.w); // w = M r
        Self::stiff_groups(self.groups, r, &mut self.w, self.cols);
        tl.deflate_cols(&self.w, z, self.cols)?; // z = w − Q K w
        Ok(())
    }

    /// The dense groups' blocks into z = M r, when there are any (the term's stiff
    /// stencils, on six load cases; a held structure's loose patches, on any).
    fn stiff_groups(groups: Option<&StiffGroups>, r: &[Cols<C>], z: &mut [Cols<C>], cols: usize) {
        if let Some(g) = groups {
            g.apply(r, z, cols);
        }
    }
}

/// The start of [`pcg`]: X₀ = `start` (its dead load cases zeroed) or 0, R₀ = B − K X₀,
/// then with the coarse space x += Q r, r −= K Q r on the live load cases, so that Pᵀ r = 0
/// (Q r and K Q r computed into `q` and `kq`, the caller's scratch).
fn cg_start<const C: usize>(
    k: &Stiffness,
    b: &[Cols<C>],
    start: Option<&[Cols<C>]>,
    live: &[bool; C],
    two_level: Option<&TwoLevel>,
    (q, kq): (&mut [Cols<C>], &mut [Cols<C>]),
) -> Result<(Vec<Cols<C>>, Vec<Cols<C>>)>
where
    Cols<C>: AsSix,
{
    let m = b.len();
    let mut x = match start {
        Some(s) => {
            let mut x = s.to_vec();
            for xp in x.iter_mut() {
                for (c, &alive) in live.iter().enumerate() {
                    if !alive {
                        xp.column_mut(c).fill(0.0);
                    }
                }
            }
            x
        }
        None => filled(m, Cols::<C>::zeros()),
    };
    let mut r = copied(b);
    if start.is_some() {
        let mut kx = filled(m, Cols::<C>::zeros());
        k.apply_cols(&x, &mut kx, C);
        r.par_iter_mut()
            .zip(kx.par_iter())
            .for_each(|(r, kx)| *r -= kx);
    }
    if let Some(tl) = two_level {
        tl.coarse_correction(&r, q, kq)?;
        x.par_iter_mut()
            .zip(r.par_iter_mut())
            .zip(q.par_iter().zip(kq.par_iter()))
            .for_each(|((x, r), (q, kq))| {
                for (c, &alive) in live.iter().enumerate() {
                    if alive {
                        for i in 0..6 {
                            x[(i, c)] += q[(i, c)];
                            r[(i, c)] -= kq[(i, c)];
                        }
                    }
                }
            });
    }
    Ok((x, r))
}

/// The CG update x += α p, r −= α K p, per load case.
fn cg_step<const C: usize>(
    x: &mut [Cols<C>],
    r: &mut [Cols<C>],
    p: &[Cols<C>],
    ap: &[Cols<C>],
    alpha: &[f64; C],
) {
    x.par_iter_mut()
        .zip(r.par_iter_mut())
        .zip(p.par_iter().zip(ap.par_iter()))
        .for_each(|((x, r), (p, ap))| step_row(x, r, p, ap, alpha));
}

/// One row of [`cg_step`].
#[inline(always)]
fn step_row<const C: usize>(
    x: &mut Cols<C>,
    r: &mut Cols<C>,
    p: &Cols<C>,
    ap: &Cols<C>,
    alpha: &[f64; C],
) {
    add_scaled_cols(x, p, alpha);
    residual_row(r, ap, alpha);
}

/// r −= α K p on one row (the r half of [`step_row`]).
#[inline(always)]
fn residual_row<const C: usize>(r: &mut Cols<C>, ap: &Cols<C>, alpha: &[f64; C]) {
    for (c, &a) in alpha.iter().enumerate() {
        for i in 0..6 {
            r[(i, c)] -= ap[(i, c)] * a;
        }
    }
}

/// [`cg_step`] with, in the same pass over the rows (each while it is in cache), the
/// block-Jacobi step w = M r into `w` ([`Preconditioner::jacobi`]'s bits) and the column
/// sums (rᵀr, rᵀw) of the new residual (those of [`column_dots`]: the same chunks and order,
/// so the same bits): two or three passes over r fewer per iteration.
#[allow(clippy::too_many_arguments)]
fn cg_step_jacobi<const C: usize>(
    x: &mut [Cols<C>],
    r: &mut [Cols<C>],
    p: &[Cols<C>],
    ap: &[Cols<C>],
    (alpha, update_x): (&[f64; C], bool),
    pre: &[(Block6, usize)],
    cols: usize,
    w: &mut [Cols<C>],
) -> ([f64; C], [f64; C]) {
    let fused = super::fused::runs::<C>();
    let parts: Vec<([f64; C], [f64; C])> = x
        .par_chunks_mut(DOT_ROWS)
        .zip(r.par_chunks_mut(DOT_ROWS))
        .zip(p.par_chunks(DOT_ROWS).zip(ap.par_chunks(DOT_ROWS)))
        .zip(pre.par_chunks(DOT_ROWS).zip(w.par_chunks_mut(DOT_ROWS)))
        .map(|(((x, r), (p, ap)), (pre, w))| {
            let rows = StepRows {
                x: update_x.then_some(x),
                r,
                p,
                ap,
                pre,
                w,
            };
            if fused {
                // SAFETY: the fused kernels run here (checked above).
                unsafe { rows.run_fused(alpha, cols) }
            } else {
                super::sparse::avx2!(rows.run(alpha, |a, b| mul6_cols(a, b, cols)))
            }
        })
        .collect();
    let (rr, rw) = parts.into_iter().unzip();
    (sum_chunks(rr), sum_chunks(rw))
}

/// One chunk of [`cg_step_jacobi`].
struct StepRows<'a, const C: usize> {
    /// x, when this pass takes x += α p.
    x: Option<&'a mut [Cols<C>]>,
    r: &'a mut [Cols<C>],
    p: &'a [Cols<C>],
    ap: &'a [Cols<C>],
    pre: &'a [(Block6, usize)],
    w: &'a mut [Cols<C>],
}

impl<const C: usize> StepRows<'_, C> {
    /// The chunk's rows in order, `jacobi(M_p, r_p)` the block-Jacobi product; the chunk's
    /// (rᵀr, rᵀw) per column.
    #[inline(always)]
    fn run(
        self,
        alpha: &[f64; C],
        jacobi: impl Fn(&Block6, &Cols<C>) -> Cols<C>,
    ) -> ([f64; C], [f64; C]) {
        let (mut rr, mut rw) = ([0.0; C], [0.0; C]);
        let StepRows {
            mut x,
            r,
            p,
            ap,
            pre,
            w,
        } = self;
        let with = ap.iter().zip(pre.iter().zip(w.iter_mut()));
        for (q, (r, (ap, ((m, _), w)))) in r.iter_mut().zip(with).enumerate() {
            match x.as_deref_mut() {
                Some(x) => step_row(&mut x[q], r, &p[q], ap, alpha),
                None => residual_row(r, ap, alpha),
            }
            add_row_dots(&mut rr, r, r);
            *w = jacobi(m, r);
            add_row_dots(&mut rw, r, w);
        }
        (rr, rw)
    }

    /// [`Self::run`] with the fused block-Jacobi kernel.
    ///
    /// # Safety
    /// Only where [`super::fused::available`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx512f"))]
    unsafe fn run_fused(self, alpha: &[f64; C], cols: usize) -> ([f64; C], [f64; C]) {
        self.run(alpha, |m, r| unsafe {
            super::fused::straight_sum(std::iter::once((m, r)), cols)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type V6 = nalgebra::Vector6<f64>;
    /// What [`pcg`] returns.
    type Solve = Result<(Vec<Block6>, usize, f64)>;

    /// A ring of `n` nodes joined by the block A (K_ii = 2A, K_i,i±1 = −A): K = L ⊗ A with L
    /// the ring's Laplacian, null on equal displacements of every node.
    fn ring(n: usize, a: &Block6) -> BlockSparse {
        let ends: Vec<(u32, u32)> = (0..n).map(|i| (i as u32, ((i + 1) % n) as u32)).collect();
        BlockSparse::assemble_blocks(n, &ends, |_| (*a, *a, -a))
    }

    /// A symmetric positive definite block with entries that are not round numbers.
    fn spd_block() -> Block6 {
        let b = Block6::from_fn(|i, j| ((i * 7 + j * 3) % 11) as f64 / 7.0 + 0.1 * (i + j) as f64);
        b * b.transpose() + Block6::identity() * 3.1
    }

    /// CG on the ring with block-Jacobi: load case 1 the alternating load (−1)^i A e, an
    /// eigenvector of L ⊗ A (λ = 4: x_i = (−1)^i e / 4), plus δ times a load equal on every
    /// node, in K's null space, of `floor` times the alternating one's norm (the relative
    /// residual CG cannot go below); load case 2 a load orthogonal to the null space, which
    /// takes several iterations.
    fn ring_solve(floor: f64, tolerance: f64) -> (Solve, Vec<Block6>) {
        let n = 16;
        let a = spd_block();
        let k = ring(n, &a);
        let e = V6::from_fn(|i, _| 1.0 + 0.3 * i as f64);
        let null = V6::from_fn(|i, _| (i as f64 * 1.3).sin() + 0.2);
        let delta = floor * (a * e).norm() / null.norm();
        let mut b = vec![Block6::zeros(); n];
        let mut want = vec![Block6::zeros(); n];
        let mut h: Vec<V6> = (0..n)
            .map(|i| V6::from_fn(|j, _| ((i * 5 + j * 3) % 7) as f64 - 3.0))
            .collect();
        let mean = h.iter().sum::<V6>() / n as f64;
        h.iter_mut().for_each(|v| *v -= mean);
        for i in 0..n {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            b[i].set_column(0, &(a * e * sign + null * delta));
            b[i].set_column(1, &(a * h[i]));
            want[i].set_column(0, &(e * (sign / 4.0)));
        }
        (held_cg(&k, &b, (None, None), tolerance, 200), want)
    }

    /// A load case whose residual met the tolerance while another iterates on: its search
    /// direction lies in K's null space, where the computed pᵀKp is rounding of either sign.
    /// It is done, not called buckling, and its solution keeps no null component that a step
    /// rz/pᵀKp (a quotient of rounding errors) would add.
    #[test]
    fn rounding_level_curvature_after_convergence_ends_the_load_case() {
        let (res, want) = ring_solve(1e-7, 1e-6);
        let (x, iterations, residual) = res.expect("converged");
        assert!(
            residual <= 1e-6 && iterations > 2,
            "{iterations} {residual:e}"
        );
        let n = x.len() as f64;
        let mean: V6 = x.iter().map(|b| b.column(0).into_owned()).sum::<V6>() / n;
        let scale = want[0].column(0).norm();
        // The first step's own null component is of the order of the floor (1.6e-6 measured);
        // a step rz/pᵀKp on a rounding-level curvature would add one many orders larger.
        assert!(
            mean.norm() < 1e-4 * scale,
            "null component {:e}",
            mean.norm()
        );
        for (got, want) in x.iter().zip(&want) {
            let err = (got.column(0) - mean - want.column(0)).norm();
            assert!(err < 1e-7 * scale, "{err:e}");
        }
    }

    /// The same load case with a tolerance below the null component's residual: stalled at
    /// rounding level ([`Error::NotConverged`]), not a buckling network.
    #[test]
    fn rounding_level_curvature_above_the_tolerance_is_a_stall_not_buckling() {
        match ring_solve(1e-7, 1e-8).0 {
            Err(Error::NotConverged(m)) => {
                assert!(
                    m.contains("rounding level") && m.contains("load case 1"),
                    "{m}"
                )
            }
            other => panic!("expected a stall at rounding level, got {other:?}"),
        }
    }

    /// The CG on one or two live load cases runs on blocks of that many columns
    /// ([`narrow_pcg`]: a specimen's solve) and gives the six-column CG's solution on them
    /// bit for bit, in as many iterations: every column's operations are the same. Where the
    /// six columns run the fused kernels and the narrow ones do not ([`super::super::fused::runs`]),
    /// the same up to their rounding, in as many iterations.
    #[test]
    fn narrow_load_cases_give_the_six_column_solution() {
        let n = 16;
        let a = spd_block();
        let k = ring(n, &a);
        for live in [1, 2] {
            let mut h: Vec<Block6> = (0..n)
                .map(|i| Block6::from_fn(|j, c| ((i * 5 + j * 3 + c) % 7) as f64 - 3.0))
                .collect();
            // Loads of zero sum: consistent with the ring's null space.
            let mean = h.iter().sum::<Block6>() / n as f64;
            let b: Vec<Block6> = h
                .iter_mut()
                .map(|hi| {
                    let mut bi = a * (*hi - mean);
                    bi.columns_mut(live, 6 - live).fill(0.0);
                    bi
                })
                .collect();
            let (narrow, it_narrow, _) =
                held_cg(&k, &b, (None, None), 1e-10, 200).expect("converged");
            let (pre, diag) = jacobi_pieces(&k, None);
            let op = Stiffness {
                k: Springs::Full(&k),
                term: None,
                diag,
                groups: None,
            };
            let opts = RelaxedOptions {
                tolerance: 1e-10,
                max_iterations: 200,
                ..Default::default()
            };
            let scale = column_dots(&b, &b).map(f64::sqrt);
            let (wide, it_wide, _) =
                pcg(&op, &b, &pre, (None, None), &scale, &opts, None).expect("converged");
            assert!(it_narrow > 2, "{it_narrow}");
            if super::super::fused::runs::<6>() {
                assert_eq!(it_narrow, it_wide, "{live} load cases");
                let scale = wide.iter().map(|w| w.amax()).fold(0.0, f64::max);
                for (n, w) in narrow.iter().zip(&wide) {
                    assert!(
                        (n - w).amax() <= 1e-12 * scale,
                        "{live} load cases: {n} {w}"
                    );
                }
            } else {
                assert_eq!((narrow, it_narrow), (wide, it_wide), "{live} load cases");
            }
        }
    }

    /// A K with a negative direction (the ring's K less 1.2 λ_min(A) times the identity,
    /// whose diagonal blocks stay positive: equal displacements of every node have curvature
    /// −1.2 λ_min(A) per node) loaded along it: refused as buckling, far beyond rounding.
    #[test]
    fn a_truly_negative_curvature_is_still_buckling() {
        let n = 8;
        let a = spd_block();
        let shift = 1.2 * a.symmetric_eigenvalues().min();
        let ends: Vec<(u32, u32)> = (0..n).map(|i| (i as u32, ((i + 1) % n) as u32)).collect();
        // Half the shift on each end of every edge: −shift·I on every diagonal block.
        let half = Block6::identity() * (0.5 * shift);
        let k = BlockSparse::assemble_blocks(n, &ends, |_| (a - half, a - half, -a));
        let mut b = vec![Block6::zeros(); n];
        for bi in b.iter_mut() {
            bi.set_column(0, &V6::from_fn(|j, _| 1.0 + 0.1 * j as f64));
        }
        let opts = RelaxedOptions::default();
        match held_cg(&k, &b, (None, None), opts.tolerance, opts.max_iterations) {
            Err(Error::Degenerate(m)) => assert!(m.contains("buckles"), "{m}"),
            other => panic!("expected buckling, got {other:?}"),
        }
    }
}
