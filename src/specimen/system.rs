//! The boundary conditions of the specimen solve and the solve itself: prescribed DOFs,
//! frictionless platens' lateral supports, confining loads, the symmetric elimination and the
//! linear solve, and the field without its rigid turn.

use super::network::{Gauge, Groups, Network};
use super::surface::{self, SurfaceLoads};
use super::{
    Platens, SolverChoice, SpecimenOptions, SpecimenSolver, CG_TOLERANCE, CG_TOLERANCE_LARGE,
    DIRECT_LIMIT,
};
use crate::homogenize::amg::{Amg, HeldModes};
use crate::homogenize::cholesky::BlockCholesky;
use crate::homogenize::network::Block6;
use crate::homogenize::relaxed::{amg_cg, block_jacobi_cg, two_level_cg};
use crate::homogenize::sparse::BlockSparse;
use crate::homogenize::two_level::HeldSpace;
use crate::packing::Packing;
use crate::{Result, Vec3};
use rayon::prelude::*;

/// What the platens prescribe and what loads act, in two load cases of one matrix: case 0 the
/// moved group shortened by δ₀, case 1 the confining pressure with the groups held in place.
pub(super) struct Boundary {
    /// Shortening δ₀ of case 0 (m).
    pub delta0: f64,
    /// Value in case 0 of every node's prescribed DOFs (`None`: free; zero in case 1).
    pub prescribed: Vec<[Option<f64>; 6]>,
    /// The lateral supports of frictionless platens (node, DOF).
    pub supports: Vec<(usize, usize)>,
    /// The confining loads on the loaded particles.
    pub confining: Option<SurfaceLoads>,
    /// Load cases: 1, or 2 with a confining pressure.
    pub cases: usize,
    /// Loaded particles: the nodes that can carry an external force.
    loaded: usize,
}

impl Boundary {
    /// The platens' prescribed DOFs and supports and the confining loads of `opts` on the
    /// loaded network `net`; `mean_radius` (m) sets the supports' length scale.
    pub fn of(
        packing: &Packing,
        opts: &SpecimenOptions,
        groups: &Groups,
        net: &Network,
        gauge: &Gauge,
        mean_radius: f64,
    ) -> Result<Boundary> {
        let (ax, layer, m) = (opts.axis, &groups.layer, net.original.len());
        let delta0 = opts.load.trial_shortening(gauge.length);
        let mut prescribed: Vec<[Option<f64>; 6]> = vec![[None; 6]; net.nodes()];
        for (a, &p) in net.original.iter().enumerate() {
            let value = if layer[p] == 2 {
                -gauge.sign * delta0
            } else {
                0.0
            };
            match (layer[p], opts.platens) {
                (0, _) => {}
                (_, Platens::Frictionless) => prescribed[a][ax] = Some(value),
                (_, Platens::Bonded) => {
                    prescribed[a] = [Some(0.0); 6];
                    prescribed[a][ax] = Some(value);
                }
            }
        }
        if net.periods.is_some() {
            match opts.platens {
                Platens::Frictionless => {
                    prescribed[m][ax] = Some(0.0);
                    prescribed[m][3 + ax] = Some(0.0);
                }
                Platens::Bonded => prescribed[m] = [Some(0.0); 6],
            }
        }
        let supports = match opts.platens {
            Platens::Frictionless => {
                let length_scale = gauge.length.max(mean_radius);
                lateral_supports(&mut prescribed, packing, ax, layer, net, length_scale)
            }
            Platens::Bonded => Vec::new(),
        };
        let confining = match opts.confining_pressure {
            Some(p) => {
                let centres: Vec<Vec3> =
                    net.original.iter().map(|&q| packing.positions[q]).collect();
                let radii: Vec<f64> = net.original.iter().map(|&q| packing.radii[q]).collect();
                Some(surface::lateral_loads(&centres, &radii, ax, opts.shape, p)?)
            }
            None => None,
        };
        let cases = if confining.is_some() { 2 } else { 1 };
        Ok(Boundary {
            delta0,
            prescribed,
            supports,
            confining,
            cases,
            loaded: m,
        })
    }

    /// External force on DOF `d` of node `a` in load case `case`: the confining force (case 1).
    pub fn external(&self, a: usize, d: usize, case: usize) -> f64 {
        match (&self.confining, case) {
            (Some(c), 1) if a < self.loaded && d < 3 => c.force[a][d],
            _ => 0.0,
        }
    }
}

/// Frictionless platens leave the lateral translations and the turn about the axis free: per
/// loaded component, one held particle's lateral translations are held, and the turn by the
/// lateral translation of the held particle farthest from it across that offset (a particle's
/// own spin would not do: without bending springs a counter-rotating "gear" pattern of spins
/// lets the whole specimen turn at no cost); that spin only when no offset exists. Returns
/// the supports (node, DOF), prescribed zero in `prescribed`.
fn lateral_supports(
    prescribed: &mut [[Option<f64>; 6]],
    packing: &Packing,
    ax: usize,
    layer: &[u8],
    net: &Network,
    length_scale: f64,
) -> Vec<(usize, usize)> {
    let (original, roots) = (&net.original, &net.roots);
    let lateral = [(ax + 1) % 3, (ax + 2) % 3];
    let mut first: Vec<(u32, usize)> = Vec::new();
    for (a, &p) in original.iter().enumerate() {
        if layer[p] == 1 && !first.iter().any(|(r, _)| *r == roots[p]) {
            first.push((roots[p], a));
        }
    }
    let mut supports = Vec::new();
    for &(rt, a0) in &first {
        let x0 = packing.positions[original[a0]];
        for d in [lateral[0], lateral[1]] {
            prescribed[a0][d] = Some(0.0);
            supports.push((a0, d));
        }
        // Farthest held particle of the component along either lateral axis.
        let far = (0..original.len())
            .filter(|&a| layer[original[a]] == 1 && roots[original[a]] == rt)
            .flat_map(|a| {
                let x = packing.positions[original[a]];
                [(a, 0usize), (a, 1)].map(|(a, k)| (a, k, (x[lateral[k]] - x0[lateral[k]]).abs()))
            })
            .max_by(|p, q| p.2.total_cmp(&q.2));
        match far {
            Some((a, k, off)) if off > 1e-9 * length_scale => {
                let d = lateral[1 - k];
                prescribed[a][d] = Some(0.0);
                supports.push((a, d));
            }
            _ => {
                prescribed[a0][3 + ax] = Some(0.0);
                supports.push((a0, 3 + ax));
            }
        }
    }
    supports
}

/// The solved field: displacements and rotations (rad) of every node in every load case.
pub(super) struct Field {
    /// Column `case` of node a's block: its six DOFs (the period changes' node: a₀, a₁).
    pub u: Vec<Block6>,
    /// Unknowns after removing local mechanisms (Cholesky), or 6 per node (CG).
    pub unknowns: usize,
    /// How the equilibrium was solved.
    pub solver: SpecimenSolver,
}

/// The scale of DOF `d` of node `a` in the eliminated system: rotations in units of the mean
/// radius (R̄·ω, m) so that translational (N/m) and rotational (N·m/rad) stiffnesses are of
/// one size, and the null directions of each diagonal block are told from soft ones well
/// above rounding (with ω in rad and spheres of 1 mm the two differ by R̄² = 1e-6, and
/// rounding of the translational part polluted the rotational one). The period changes'
/// node (a ≥ `loaded`) holds lengths already.
fn dof_scale(a: usize, d: usize, loaded: usize, mean_radius: f64) -> f64 {
    if d < 3 || a >= loaded {
        1.0
    } else {
        1.0 / mean_radius
    }
}

/// The symmetric elimination of the prescribed DOFs in place: their rows and columns keep
/// only their diagonal, and the right-hand side moves the prescribed values' coupling to the
/// free rows; both scaled by [`dof_scale`]. Rows in parallel, the same bits on any thread
/// count.
fn eliminate(mut k: BlockSparse, bc: &Boundary, mean_radius: f64) -> (BlockSparse, Vec<Block6>) {
    let (prescribed, cases, nodes) = (&bc.prescribed, bc.cases, bc.prescribed.len());
    debug_assert_eq!(k.rows(), nodes, "one block row per node");
    let scale = |a: usize, d: usize| dof_scale(a, d, bc.loaded, mean_radius);
    let value_block = |a: usize| {
        let mut v = Block6::zeros();
        for d in 0..6 {
            v[(d, 0)] = prescribed[a][d].unwrap_or(0.0);
        }
        v
    };
    // A node without prescribed DOFs adds exact zeros to acc below: skipped, the same bits.
    let any_prescribed: Vec<bool> = prescribed
        .iter()
        .map(|p| p.iter().any(Option::is_some))
        .collect();
    let mut rhs = vec![Block6::zeros(); nodes];
    rhs.par_iter_mut().enumerate().for_each(|(a, r)| {
        let mut acc = Block6::zeros();
        for (c, blk) in k.row(a).filter(|&(c, _)| any_prescribed[c]) {
            acc -= blk * value_block(c);
        }
        let diag = k.diagonal(a);
        for d in 0..6 {
            for case in 0..cases {
                r[(d, case)] = match (prescribed[a][d], case) {
                    (Some(v), 0) => diag[(d, d)] * v,
                    (Some(_), _) => 0.0,
                    (None, 0) => acc[(d, 0)],
                    (None, _) => bc.external(a, d, case),
                };
                r[(d, case)] *= scale(a, d);
            }
        }
    });
    k.map_blocks(|a, c, b| {
        for r in 0..6 {
            for s in 0..6 {
                let fixed = prescribed[a][r].is_some() || prescribed[c][s].is_some();
                let v = if fixed && !(a == c && r == s) {
                    0.0
                } else {
                    b[(r, s)]
                };
                b[(r, s)] = v * scale(a, r) * scale(c, s);
            }
        }
    });
    (k, rhs)
}

/// Solve K u = f for the free DOFs with the prescribed ones eliminated ([`eliminate`]), back in
/// radians with the prescribed DOFs at their values exactly, less the rigid turn about the axis
/// that frictionless platens leave free ([`remove_turn`]). `kfull` is eliminated in place.
pub(super) fn solve_field(
    kfull: BlockSparse,
    bc: &Boundary,
    net: &Network,
    packing: &Packing,
    opts: &SpecimenOptions,
    mean_radius: f64,
) -> Result<Field> {
    let (kmod, rhs) = eliminate(kfull, bc, mean_radius);
    let (mut u, unknowns, solver) = solve_system(kmod, &rhs, opts, packing, net, bc, mean_radius)?;
    for (a, ua) in u.iter_mut().enumerate() {
        for d in 0..6 {
            for case in 0..bc.cases {
                ua[(d, case)] *= dof_scale(a, d, bc.loaded, mean_radius);
            }
            if let Some(v) = bc.prescribed[a][d] {
                ua[(d, 0)] = v;
                if bc.cases > 1 {
                    ua[(d, 1)] = 0.0;
                }
            }
        }
    }
    remove_turn(&mut u, bc, net, packing, opts.axis);
    Ok(Field {
        u,
        unknowns,
        solver,
    })
}

/// Frictionless platens leave the turn about the axis free (a zero-energy mode); the supports
/// only fix it somehow. Remove from the field its least-squares rigid turn about the axis
/// through the first support (no force changes); the period changes' node turns with it.
fn remove_turn(u: &mut [Block6], bc: &Boundary, net: &Network, packing: &Packing, ax: usize) {
    let Some(&(_, a0)) = bc.supports.first() else {
        return;
    };
    let (original, m) = (&net.original, net.original.len());
    let lateral = [(ax + 1) % 3, (ax + 2) % 3];
    let xa = packing.positions[original[a0]];
    let turn = |a: usize| -> Vec3 {
        let d = packing.positions[original[a]] - xa;
        let mut t = Vec3::zeros();
        t[lateral[0]] = -d[lateral[1]];
        t[lateral[1]] = d[lateral[0]];
        t
    };
    let den: f64 = (0..m).map(|a| turn(a).norm_squared()).sum();
    for case in 0..bc.cases {
        let num: f64 = (0..m)
            .map(|a| {
                let t = turn(a);
                (0..3).map(|d| t[d] * u[a][(d, case)]).sum::<f64>()
            })
            .sum();
        let w = if den > 0.0 { num / den } else { 0.0 };
        for (a, ua) in u.iter_mut().enumerate().take(m) {
            let t = turn(a);
            for d in 0..3 {
                ua[(d, case)] -= w * t[d];
            }
            ua[(3 + ax, case)] -= w;
        }
        if let Some(l) = net.periods {
            // The image across lateral face k moves by w e_axis × (L_k e_k).
            for (kk, &d) in lateral.iter().enumerate() {
                let mut t = Vec3::zeros();
                t[lateral[(kk + 1) % 2]] = if kk == 0 { l[d] } else { -l[d] };
                for c in 0..3 {
                    u[m][(3 * kk + c, case)] -= w * t[c];
                }
            }
        }
    }
}

/// Solve the eliminated system `k x = b` by `opts.solver` (see [`SolverChoice`]); returns x,
/// the unknowns and the method (`kmod` is given up to the two-level CG, which keeps only its
/// upper triangle).
fn solve_system(
    kmod: BlockSparse,
    b: &[Block6],
    opts: &SpecimenOptions,
    packing: &Packing,
    net: &Network,
    bc: &Boundary,
    mean_radius: f64,
) -> Result<(Vec<Block6>, usize, SpecimenSolver)> {
    let k = &kmod;
    let (choice, original, nodes) = (opts.solver, &net.original, net.nodes());
    let held: Vec<[bool; 6]> = bc
        .prescribed
        .iter()
        .map(|p| p.map(|v| v.is_some()))
        .collect();
    let m = original.len();
    let context = "specimen: the bonded specimen held by its platens has a mechanism that the \
                   load excites, or the solve did not converge";
    let large = m > DIRECT_LIMIT;
    let tolerance = if large {
        CG_TOLERANCE_LARGE
    } else {
        CG_TOLERANCE
    };
    if choice == SolverChoice::CgAmg {
        let positions: Vec<Vec3> = (0..nodes)
            .map(|a| {
                original
                    .get(a)
                    .map_or(Vec3::zeros(), |&p| packing.positions[p])
            })
            .collect();
        // Arms by minimum image across the lateral faces only (the axis is cut).
        let cell = match net.periods {
            Some(l) => {
                let mut periodic = [true; 3];
                periodic[opts.axis] = false;
                Some(crate::packing::PeriodicCell::with_periodic(l, periodic)?)
            }
            None => None,
        };
        let modes = HeldModes {
            positions: &positions,
            cell,
            spin_scale: mean_radius,
            held: &held,
            apart: net.periods.map(|_| m),
        };
        let amg = Amg::of_held(k, &modes)?;
        let (x, iterations, _) =
            amg_cg(k, b, &amg, tolerance, 20_000 + 2 * nodes).map_err(|e| e.in_context(context))?;
        let solver = SpecimenSolver::CgAmg {
            iterations,
            levels: amg.levels(),
        };
        return Ok((x, 6 * nodes, solver));
    }
    let direct = match choice {
        SolverChoice::Cholesky => true,
        SolverChoice::Cg | SolverChoice::CgAmg => false,
        SolverChoice::Auto => !large,
    };
    if direct {
        if let Ok(chol) = BlockCholesky::factor_definite(k) {
            return Ok((chol.solve(b)?, chol.unknowns(), SpecimenSolver::Cholesky));
        }
    }
    if !large && choice != SolverChoice::Cg {
        // Small and semi-definite: block-Jacobi CG to the tight tolerance.
        let (x, iterations, _) = block_jacobi_cg(k, b, CG_TOLERANCE, 2 * nodes + 1000)
            .map_err(|e| e.in_context(context))?;
        let solver = SpecimenSolver::Cg {
            iterations,
            two_level: false,
        };
        return Ok((x, 6 * nodes, solver));
    }
    // Two-level CG: aggregates on a grid over the loaded particles' bounding box (the
    // period-change node sits at its centre).
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for &p in original {
        lo = lo.inf(&packing.positions[p]);
        hi = hi.sup(&packing.positions[p]);
    }
    let extent = hi - lo;
    let pad = 1e-9 * extent.max().max(f64::MIN_POSITIVE);
    let lengths = extent.map(|e| e * (1.0 + 1e-9) + pad);
    let mut positions: Vec<Vec3> = original
        .iter()
        .map(|&p| packing.positions[p] - lo)
        .collect();
    positions.resize(nodes, extent * 0.5);
    let space = HeldSpace {
        held: &held,
        apart: net.periods.map(|_| m),
        spin_scale: mean_radius,
    };
    // Block-Jacobi alone where the coarse space could not be built: the report says which.
    let (x, iterations, _, two_level) =
        two_level_cg(kmod, b, (&positions, lengths), &space, tolerance, 20_000)
            .map_err(|e| e.in_context(context))?;
    let solver = SpecimenSolver::Cg {
        iterations,
        two_level,
    };
    Ok((x, 6 * nodes, solver))
}
