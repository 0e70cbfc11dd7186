//! The smoothed-aggregation multigrid preconditioner of the relaxed CG (issue 35): the same
//! tensor as faer's sparse Cholesky on disordered networks (small gaps, locked spins,
//! rotational springs), the SC/FCC closed forms (docs/references.md, "Relaxed (static)
//! stiffness"), the same bits on 1 and 2 threads, and the iterations at 2,048 and 16,384
//! particles (printed, and bounded by 2×).

use crate::common::lattice::*;
use crate::relaxed_solvers::solve;
use anisobond::homogenize::{CgPreconditioner, RelaxedSolver};

const AMG: RelaxedSolver = RelaxedSolver::Cg {
    preconditioner: CgPreconditioner::Amg,
};

#[test]
fn amg_cg_equals_sparse_cholesky_on_disordered_networks() {
    // 500 particles: above the 256-node coarsest level, so the V-cycle has two levels.
    for (gap, kr, rotations) in [
        (0.25, 0.0, true),
        (0.09, 0.0, true),
        (0.09, 0.25, true),
        (0.25, 0.0, false),
    ] {
        let (p, b) = disordered_fcc(5, 11, gap);
        let k = uniform_springs(b.len(), 1e6, 0.7e6, kr, 2.0 * kr);
        let amg = solve(&p, &b, &k, AMG, 1e-11, rotations);
        let chol = solve(&p, &b, &k, RelaxedSolver::Cholesky, 1e-6, rotations);
        let diff = max_abs(&(amg.c - chol.c)) / max_abs(&chol.c);
        assert!(
            diff < 1e-9,
            "gap {gap} kr {kr} rotations {rotations}: {diff:.2e}"
        );
        assert!(amg.relative_residual <= 1e-11);
        // The relaxed tensor is well below the affine one (the test is not trivial).
        assert!(chol.c[(3, 3)] < 0.99 * chol.c_affine[(3, 3)]);
    }
}

#[test]
fn amg_cg_gives_the_simple_cubic_and_fcc_closed_forms() {
    let r = 1e-3;
    let (kn, kt) = (2e6, 0.8e6);
    let tol = 1e-9 * kn / r;
    // Simple cubic, 10³ spheres, bond length 2R: C11 = kn/(2R), C12 = 0, C44 = kt/(4R).
    let p = lattice(&[[0.0; 3]], 10, 2.0 * r, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    assert_eq!(b.len(), 3 * 1000);
    let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
    let c = solve(&p, &b, &k, AMG, 1e-10, true).c;
    assert!((c[(0, 0)] - kn / (2.0 * r)).abs() < tol, "{c}");
    assert!(c[(0, 1)].abs() < tol, "{c}");
    assert!((c[(3, 3)] - kt / (4.0 * r)).abs() < tol, "{c}");
    // FCC, 6³ cells (864 spheres): C11 = (kn+kt)/(√2R), C12 = (kn−kt)/(2√2R),
    // C44 = (kn+kt)/(2√2R).
    let a = 2.0 * std::f64::consts::SQRT_2 * r;
    let p = lattice(&FCC, 6, a, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    assert_eq!(b.len(), 6 * p.len());
    let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
    let s2r = std::f64::consts::SQRT_2 * r;
    let c = solve(&p, &b, &k, AMG, 1e-10, true).c;
    assert!((c[(0, 0)] - (kn + kt) / s2r).abs() < tol, "{c}");
    assert!((c[(0, 1)] - (kn - kt) / (2.0 * s2r)).abs() < tol, "{c}");
    assert!((c[(3, 3)] - (kn + kt) / (2.0 * s2r)).abs() < tol, "{c}");
}

#[test]
fn amg_cg_is_thread_count_independent() {
    let (p, b) = disordered_fcc(8, 2, 0.2);
    let k = uniform_springs(b.len(), 1e6, 0.5e6, 0.0, 0.0);
    let run = |t: usize| crate::common::on_threads(t, || solve(&p, &b, &k, AMG, 1e-8, true));
    let (one, two) = (run(1), run(2));
    assert_eq!(one.c, two.c);
    assert_eq!(one.iterations, two.iterations);
    assert_eq!(one.relative_residual, two.relative_residual);
}

/// Two-level preconditioner as the default solver uses it.
const TWO_LEVEL: RelaxedSolver = RelaxedSolver::Cg {
    preconditioner: CgPreconditioner::TwoLevel {
        particles_per_aggregate: anisobond::homogenize::DEFAULT_PARTICLES_PER_AGGREGATE,
    },
};

#[test]
fn amg_iterations_grow_little_from_2k_to_16k_particles() {
    let _alone = crate::common::alone();
    let mut amg_iterations = Vec::new();
    for cells in [8, 16] {
        let (p, b) = disordered_fcc(cells, 5, 0.2);
        let k = uniform_springs(b.len(), 1e6, 0.6e6, 0.0, 0.0);
        let amg = solve(&p, &b, &k, AMG, 1e-8, true);
        let two = solve(&p, &b, &k, TWO_LEVEL, 1e-8, true);
        let diff = max_abs(&(amg.c - two.c)) / max_abs(&two.c);
        println!(
            "{} particles, {} bonds: multigrid CG {} iterations, two-level CG {}; tensors \
             differ by {diff:.2e}",
            p.len(),
            b.len(),
            amg.iterations,
            two.iterations
        );
        // Both at 1e-8: the tensors agree to about its square.
        assert!(diff < 1e-10, "{diff:.2e}");
        amg_iterations.push(amg.iterations);
    }
    // 8× the particles (one more level): at most 2× the iterations. The counts are
    // deterministic; issue 35 asks 1.3× from 30,700 to 1,000,000, not reached yet.
    assert!(
        amg_iterations[1] as f64 <= 2.0 * amg_iterations[0] as f64,
        "{amg_iterations:?}"
    );
}
