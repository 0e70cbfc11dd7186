//! The relaxed tensor's linear solvers agree: faer's sparse Cholesky, block-Jacobi CG and the
//! two-level CG give the same tensor; closed forms on SC/FCC lattices (docs/references.md,
//! "Relaxed (static) stiffness") through each; thread-count independence.

use crate::common::lattice::*;
use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::homogenize::{
    relaxed_tensor, CgPreconditioner, RelaxedOptions, RelaxedResult, RelaxedSolver,
};
use anisobond::packing::Packing;
use anisobond::Vec3;

const JACOBI: RelaxedSolver = RelaxedSolver::Cg {
    preconditioner: CgPreconditioner::BlockJacobi,
};
const TWO_LEVEL: RelaxedSolver = RelaxedSolver::Cg {
    preconditioner: CgPreconditioner::TwoLevel {
        particles_per_aggregate: 16,
    },
};
const SOLVERS: [RelaxedSolver; 3] = [JACOBI, TWO_LEVEL, RelaxedSolver::Cholesky];

/// The relaxed tensor by `solver` at `tolerance`, with or without rotations (also used by
/// `amg.rs`).
pub fn solve(
    p: &Packing,
    b: &BondSet,
    k: &BondStiffness,
    solver: RelaxedSolver,
    tolerance: f64,
    rotations: bool,
) -> RelaxedResult {
    relaxed_tensor(
        p,
        b,
        k,
        &RelaxedOptions {
            solver,
            tolerance,
            rotations,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn simple_cubic_and_fcc_closed_forms_by_every_solver() {
    let r = 1e-3;
    let (kn, kt) = (2e6, 0.8e6);
    let tol = 1e-9 * kn / r;
    // Simple cubic, bond length 2R: C11 = kn/(2R), C12 = 0, C44 = kt/(4R).
    let (p, b) = simple_cubic_bonded(r);
    assert_eq!(b.len(), 3 * 64);
    let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
    for solver in SOLVERS {
        let c = solve(&p, &b, &k, solver, 1e-10, true).c;
        assert!((c[(0, 0)] - kn / (2.0 * r)).abs() < tol, "{solver:?} {c}");
        assert!(c[(0, 1)].abs() < tol, "{solver:?}");
        assert!((c[(3, 3)] - kt / (4.0 * r)).abs() < tol, "{solver:?} {c}");
    }
    // FCC: C11 = (kn+kt)/(√2R), C12 = (kn−kt)/(2√2R), C44 = (kn+kt)/(2√2R).
    let (p, b) = fcc_bonded(r);
    assert_eq!(b.len(), 6 * p.len());
    let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
    let s2r = std::f64::consts::SQRT_2 * r;
    for solver in SOLVERS {
        let c = solve(&p, &b, &k, solver, 1e-10, true).c;
        assert!((c[(0, 0)] - (kn + kt) / s2r).abs() < tol, "{solver:?} {c}");
        assert!(
            (c[(0, 1)] - (kn - kt) / (2.0 * s2r)).abs() < tol,
            "{solver:?}"
        );
        assert!(
            (c[(3, 3)] - (kn + kt) / (2.0 * s2r)).abs() < tol,
            "{solver:?}"
        );
    }
}

/// Adds a particle bonded to exactly two others (a free rotation about the line through its
/// contact points when there are no rotational springs) and one bonded to a single other
/// (pruned): the local singular modes the solvers must remove.
fn with_low_degree_particles(p: &Packing, b: &BondSet) -> (Packing, BondSet) {
    let cell = p.cell.unwrap();
    let mut pos = p.positions.clone();
    let mut rad = p.radii.clone();
    let n = pos.len() as u32;
    let r = rad[0];
    pos.push((p.positions[0] + p.positions[1]) * 0.5 + Vec3::new(0.3, -0.2, 0.25) * r);
    rad.push(0.5 * r);
    pos.push(p.positions[2] + Vec3::new(0.2, 0.9, -0.3) * r);
    rad.push(0.4 * r);
    let q = Packing::new(pos, rad, Some(cell)).unwrap();
    let mut bonds = b.clone();
    for (i, j) in [(n, 0), (1, n), (n + 1, 2)] {
        let (l, img) = cell.minimum_image(q.positions[j as usize] - q.positions[i as usize]);
        bonds.push(i, j, l, img);
    }
    (q, bonds)
}

#[test]
fn cholesky_equals_cg_on_disordered_networks_with_local_mechanisms() {
    for (gap, kr, rotations) in [
        (0.25, 0.0, true),
        (0.09, 0.0, true),
        (0.09, 0.25, true),
        (0.25, 0.0, false),
    ] {
        let (p, b) = disordered_fcc(5, 11, gap);
        let (p, b) = with_low_degree_particles(&p, &b);
        let k = uniform_springs(b.len(), 1e6, 0.7e6, kr, 2.0 * kr);
        let cg = solve(&p, &b, &k, JACOBI, 1e-11, rotations);
        let chol = solve(&p, &b, &k, RelaxedSolver::Cholesky, 1e-6, rotations);
        let scale = max_abs(&cg.c);
        let diff = max_abs(&(cg.c - chol.c)) / scale;
        assert!(
            diff < 1e-9,
            "gap {gap} kr {kr} rotations {rotations}: {diff:.2e}"
        );
        assert!(chol.relative_residual < 1e-9, "{}", chol.relative_residual);
        // The relaxed tensor is well below the affine one (the test is not trivial).
        assert!(chol.c[(3, 3)] < 0.99 * chol.c_affine[(3, 3)]);
        assert_eq!(cg.null_space.removed_particles, 1, "{:?}", cg.null_space);
        assert_eq!(cg.null_space.two_bond_particles, 1, "{:?}", cg.null_space);
    }
}

#[test]
fn two_level_cg_equals_block_jacobi_cg_in_fewer_iterations() {
    let (p, b) = disordered_fcc(8, 5, 0.2);
    let k = uniform_springs(b.len(), 1e6, 0.6e6, 0.0, 0.0);
    let jacobi = solve(&p, &b, &k, JACOBI, 1e-10, true);
    let two = solve(&p, &b, &k, TWO_LEVEL, 1e-10, true);
    let diff = max_abs(&(jacobi.c - two.c)) / max_abs(&jacobi.c);
    assert!(diff < 1e-9, "{diff:.2e}");
    assert!(
        2 * two.iterations < jacobi.iterations,
        "two-level {} vs block-Jacobi {}",
        two.iterations,
        jacobi.iterations
    );
    // Default tolerance: the tensor to 1e-8 of the tight solve (error quadratic in residual).
    let loose = solve(&p, &b, &k, TWO_LEVEL, 1e-6, true);
    assert!(max_abs(&(loose.c - jacobi.c)) < 1e-8 * max_abs(&jacobi.c));
}

#[test]
fn every_solver_is_thread_count_independent() {
    let (p, b) = disordered_fcc(5, 2, 0.2);
    let k = uniform_springs(b.len(), 1e6, 0.5e6, 0.0, 0.0);
    for solver in SOLVERS {
        let run = |t: usize| crate::common::on_threads(t, || solve(&p, &b, &k, solver, 1e-8, true));
        let (one, two) = (run(1), run(2));
        assert_eq!(one.c, two.c, "{solver:?}");
        assert_eq!(one.iterations, two.iterations, "{solver:?}");
    }
}
