//! Kruyt's local-adjustment-field (LAF) estimate of the stiffness (Kruyt 2014, Sec. 4).
//!
//! For every particle c, the shell of order m holds the particles within graph distance m
//! of c; those at distance < m are free, those at distance m follow the uniform strain
//! (zero fluctuation). The shell's equilibrium K_II Q_I = G_I is solved densely and only the
//! centre's fluctuation Q_c is kept. From the field Q two estimates follow (Kruyt 2014
//! Sec. 4.1): the **stress-based** C_σ = (H − GᵀQ)/V (Love stress of the LAF field), and the
//! **energy-based** C_W = (H − GᵀQ − QᵀG + QᵀKQ)/V, an upper bound of the relaxed tensor
//! since the field is kinematically admissible.
//!
//! The local systems can be singular (a free rotation of a two-bond particle inside a shell,
//! with a right-hand side orthogonal to it); they are solved with a Cholesky factorisation
//! shifted by 1e-12 × the largest diagonal entry. On a well-posed shell this changes the
//! kept fluctuation by a relative O(1e-12); a shell holding a near-mechanism amplifies it
//! (a relative change of up to ~2e-7 was measured on such shells). A shell the shifted
//! factorisation still cannot solve is refused as degenerate, never given a zero field.

use super::network::{csr, Block6, LeverArm, Network, NullSpaceReport};
use super::sparse::BlockSparse;
use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::tensor::Stiffness6;
use crate::{Error, Result};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Result of [`laf_tensor`].
#[derive(Clone, Debug)]
pub struct LafResult {
    /// Shell order m.
    pub shell: usize,
    /// Stress-based estimate (Pa), as Kruyt 2014 Sec. 4.1 defines it: not symmetrised. The
    /// LAF field only approximates the relaxed one, so GᵀQ and with it C_σ lack major
    /// symmetry in general; [`LafResult::stress_asymmetry`] says by how much.
    pub c_stress: Stiffness6,
    /// Energy-based estimate (Pa), ≥ the relaxed tensor.
    pub c_energy: Stiffness6,
    /// The affine (Voigt) tensor of the same network (Pa).
    pub c_affine: Stiffness6,
    /// Mean number of free particles per shell.
    pub mean_free_particles: f64,
    /// The stress-based estimate's departure from major symmetry, max|C_σ − C_σᵀ| /
    /// max|C_σ| (0 for exact shells, e.g. a lattice whose relaxed field is affine).
    pub stress_asymmetry: f64,
    /// Singular modes of the network.
    pub null_space: NullSpaceReport,
}

/// Free particles of the shell of order `m` around `c`: graph distance < m, centre first.
fn shell_interior(
    c: usize,
    m: usize,
    start: &[usize],
    nb: &[u32],
    mark: &mut [u32],
    stamp: u32,
) -> Vec<usize> {
    let mut inner = vec![c];
    mark[c] = stamp;
    let mut frontier = 0;
    for _depth in 1..m {
        let end = inner.len();
        for k in frontier..end {
            let p = inner[k];
            for &q in &nb[start[p]..start[p + 1]] {
                let q = q as usize;
                if mark[q] != stamp {
                    mark[q] = stamp;
                    inner.push(q);
                }
            }
        }
        frontier = end;
    }
    inner
}

/// Refuse a shell order whose shells cover most of the network: the LAF estimate then costs
/// one dense solve of nearly the whole network per particle (hours where the relaxed solve,
/// which it approximates, takes seconds), and its dense matrices may not fit in memory.
/// The shell size is measured on up to 32 evenly spaced centres.
fn check_shell_size(m: usize, shell: usize, start: &[usize], nb: &[u32]) -> Result<()> {
    if m == 0 {
        return Ok(());
    }
    let samples = m.min(32);
    let mut mark = vec![u32::MAX; m];
    let sizes: Vec<usize> = (0..samples)
        .map(|i| {
            let c = i * m / samples;
            shell_interior(c, shell, start, nb, &mut mark, i as u32).len()
        })
        .collect();
    let mean = sizes.iter().sum::<usize>() as f64 / samples as f64;
    if m >= 8 && mean > 0.5 * m as f64 {
        return Err(Error::Invalid(format!(
            "--shell {shell}: the shells hold {mean:.0} of the {m} load-bearing particles on \
             average, most of the network, so the local estimate is no longer local and costs a \
             dense solve of nearly the whole network per particle; use a smaller shell or \
             --method relaxed (exact)"
        )));
    }
    let largest = sizes.iter().copied().max().unwrap_or(0) as f64;
    let threads = rayon::current_num_threads() as f64;
    // Stiffness and right-hand side (6n × 6n and 6n × 6) plus the factor, per thread.
    let bytes = threads * 2.0 * (6.0 * largest) * (6.0 * largest + 6.0) * 8.0;
    crate::io::check_memory(&format!("LAF with --shell {shell}"), bytes)
}

/// The LAF fluctuation of active particle `c` (Kruyt 2014 Sec. 4): the equilibrium of the
/// free particles `inner` of its shell (`mark[p] == c`, local numbers `local`) under the
/// loads G with the shell's boundary held, K_shell Q = G, shifted by 1e-12 × the largest
/// diagonal entry; returns Q's block of `c` (the first of `inner`). `adjacency` gives every
/// particle's incident elements (CSR).
fn shell_solve(
    net: &Network,
    (start, inc): (&[usize], &[u32]),
    (inner, c): (&[usize], usize),
    (mark, local): (&[u32], &[usize]),
    shell: usize,
) -> Result<Block6> {
    let n = 6 * inner.len();
    let mut kk = DMatrix::<f64>::zeros(n, n);
    let mut rhs = DMatrix::<f64>::zeros(n, 6);
    for (li, &p) in inner.iter().enumerate() {
        rhs.view_mut((6 * li, 0), (6, 6)).copy_from(&net.g[p]);
        for &ei in &inc[start[p]..start[p + 1]] {
            let e = &net.element(ei as usize);
            let (a, b) = net.ends[ei as usize];
            let (diag, off, other) = if a as usize == p {
                (e.kii, e.kij, b as usize)
            } else {
                (e.kjj, e.kij.transpose(), a as usize)
            };
            let mut d = kk.view_mut((6 * li, 6 * li), (6, 6));
            d += diag;
            if mark[other] == c as u32 {
                let lo = local[other];
                let mut o = kk.view_mut((6 * li, 6 * lo), (6, 6));
                o += off;
            }
        }
    }
    let shift = 1e-12 * (0..n).map(|i| kk[(i, i)]).fold(0.0, f64::max);
    for i in 0..n {
        kk[(i, i)] += shift;
    }
    let Some(factor) = kk.cholesky() else {
        return Err(Error::Degenerate(format!(
            "LAF shell of order {shell} around active particle {c} ({} free \
             particles) is not positive definite even shifted by 1e-12 × its \
             largest diagonal entry; use --method relaxed",
            inner.len()
        )));
    };
    let q = factor.solve(&rhs);
    Ok(Block6::from_fn(|r, col| q[(r, col)]))
}

/// LAF estimates with shells of order `shell` (1 ≤ m ≤ 6).
pub fn laf_tensor(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    lever_arm: LeverArm,
    shell: usize,
) -> Result<LafResult> {
    if !(1..=6).contains(&shell) {
        return Err(Error::Invalid(format!(
            "--shell must be between 1 and 6, got {shell}"
        )));
    }
    super::network::require_cell(packing)?;
    let net = Network::build(packing, bonds, k, lever_arm, true, None)?;
    let m = net.n_active;
    let (start, nb) = net.adjacency();
    // Incident elements of every particle (same CSR layout as `adjacency`).
    let (_, inc) = csr(m, net.end_pairs(), |e, _| e as u32);
    check_shell_size(m, shell, &start, &nb)?;
    const CH: usize = 256;
    let chunks: Vec<Result<(Vec<Block6>, usize)>> = (0..m.div_ceil(CH))
        .into_par_iter()
        .map(|ch| {
            let mut mark = vec![u32::MAX; m];
            let mut local = vec![usize::MAX; m];
            let mut out = Vec::with_capacity(CH);
            let mut free_total = 0usize;
            for c in ch * CH..((ch + 1) * CH).min(m) {
                let inner = shell_interior(c, shell, &start, &nb, &mut mark, c as u32);
                free_total += inner.len();
                for (li, &p) in inner.iter().enumerate() {
                    local[p] = li;
                }
                out.push(shell_solve(
                    &net,
                    (&start, &inc),
                    (&inner, c),
                    (&mark, &local),
                    shell,
                )?);
                for &p in &inner {
                    local[p] = usize::MAX;
                }
            }
            Ok((out, free_total))
        })
        .collect();
    let mut q = Vec::with_capacity(m);
    let mut free_total = 0usize;
    for chunk in chunks {
        let (c, f) = chunk?;
        q.extend(c);
        free_total += f;
    }
    let (gtq, qtkq) = BlockSparse::assemble(&net).fluctuation_terms(&net.g, &q);
    let v = net.volume;
    let c_energy = (net.h - gtq - gtq.transpose() + qtkq) / v;
    let c_stress = (net.h - gtq) / v;
    let stress_asymmetry = (c_stress - c_stress.transpose()).amax() / c_stress.amax();
    Ok(LafResult {
        shell,
        stress_asymmetry,
        c_stress,
        c_energy: (c_energy + c_energy.transpose()) * 0.5,
        c_affine: net.h / v,
        mean_free_particles: free_total as f64 / m.max(1) as f64,
        null_space: net.null_space,
    })
}
