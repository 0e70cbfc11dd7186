//! The relaxed solve's linear system handed out (`homogenize::relaxed_system`, Python's
//! `Assembly.relaxed_system`): K in CSR is symmetric, the rigid translations are its null
//! vectors and orthogonal to G, and C = (H − Gᵀ K⁺ G)/V solved by a dense SVD pseudo-inverse
//! (nalgebra, independent of the library's solvers) is the relaxed tensor of faer's sparse
//! Cholesky, with and without a many-body term.

use super::common::lattice::{disordered_fcc, max_abs, uniform_springs};
use anisobond::homogenize::{
    relaxed_system, relaxed_tensor_with_term, RelaxedOptions, RelaxedSolver, RelaxedSystem,
};
use anisobond::manybody::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions};
use anisobond::tensor::{rotation_x, rotation_z, Stiffness6};
use nalgebra::DMatrix;

/// K as a dense matrix from its CSR arrays.
fn dense_k(s: &RelaxedSystem) -> DMatrix<f64> {
    let n = s.unknowns;
    let mut k = DMatrix::zeros(n, n);
    for r in 0..n {
        for e in s.row_start[r] as usize..s.row_start[r + 1] as usize {
            k[(r, s.column[e] as usize)] += s.value[e];
        }
    }
    k
}

/// C = (H − Gᵀ K⁺ G)/V with K⁺ by the SVD pseudo-inverse of the Jacobi-scaled K (singular
/// values below 1e-11 dropped), and the checks on K's structure; returns C.
fn dense_relaxed(s: &RelaxedSystem) -> Stiffness6 {
    let n = s.unknowns;
    assert_eq!(s.row_start.len(), n + 1);
    assert_eq!(s.g.len(), 6 * n);
    assert_eq!(6 * s.active.len(), n);
    let k = dense_k(s);
    let scale = k.amax();
    // Symmetric, columns increasing within a row.
    assert!((&k - k.transpose()).amax() <= 1e-12 * scale);
    for r in 0..n {
        let cols = &s.column[s.row_start[r] as usize..s.row_start[r + 1] as usize];
        assert!(cols.windows(2).all(|w| w[0] < w[1]), "row {r}");
    }
    // The three rigid translations: K t = 0 and Gᵀ t = 0.
    let g = DMatrix::from_row_slice(n, 6, &s.g);
    for axis in 0..3 {
        let t = DMatrix::from_fn(n, 1, |r, _| if r % 6 == axis { 1.0 } else { 0.0 });
        assert!(
            (&k * &t).amax() <= 1e-10 * scale * (n as f64).sqrt(),
            "K t{axis}"
        );
        assert!((g.transpose() * &t).amax() <= 1e-10 * g.amax() * (n as f64).sqrt());
    }
    // Jacobi-scaled (the DOFs mix m and rad), then the pseudo-inverse: Q = D (DKD)⁺ D G.
    let d = DMatrix::from_fn(n, 1, |r, _| {
        if k[(r, r)] > 0.0 {
            1.0 / k[(r, r)].sqrt()
        } else {
            0.0
        }
    });
    let ks = DMatrix::from_fn(n, n, |r, c| d[r] * k[(r, c)] * d[c]);
    let gs = DMatrix::from_fn(n, 6, |r, c| d[r] * g[(r, c)]);
    let q = ks.pseudo_inverse(1e-11).unwrap() * gs;
    let q = DMatrix::from_fn(n, 6, |r, c| d[r] * q[(r, c)]);
    // The library's own C of a solution computed elsewhere.
    let mut q_rows = vec![0.0; 6 * n];
    for r in 0..n {
        for c in 0..6 {
            q_rows[6 * r + c] = q[(r, c)];
        }
    }
    s.tensor(&q_rows)
}

#[test]
fn the_exported_system_solved_densely_is_the_relaxed_tensor() {
    // 108 particles (648 unknowns): a disordered network with two-bond particles and pruned
    // ones (gap 0.09), and a denser one.
    for (gap, kr, rotations) in [(0.25, 0.0, true), (0.09, 0.25, true), (0.25, 0.0, false)] {
        let (p, b) = disordered_fcc(3, 5, gap);
        let k = uniform_springs(b.len(), 1e6, 0.7e6, kr, 2.0 * kr);
        let opts = RelaxedOptions {
            rotations,
            ..Default::default()
        };
        let s = relaxed_system(&p, &b, &k, None, &opts).unwrap();
        let c = dense_relaxed(&s);
        let chol = relaxed_tensor_with_term(
            &p,
            &b,
            &k,
            None,
            &RelaxedOptions {
                solver: RelaxedSolver::Cholesky,
                ..opts
            },
        )
        .unwrap();
        let diff = max_abs(&(c - chol.c)) / max_abs(&chol.c);
        println!("gap {gap} kr {kr} rotations {rotations}: {diff:.1e}");
        assert!(
            diff < 1e-12,
            "gap {gap} kr {kr} rotations {rotations}: {diff:e}"
        );
        // H/V is the affine tensor, and relaxing lowers it (the test is not trivial).
        assert!(max_abs(&(s.h / s.volume - chol.c_affine)) <= 1e-12 * max_abs(&chol.c_affine));
        assert!(chol.c[(3, 3)] < 0.99 * chol.c_affine[(3, 3)]);
    }
}

#[test]
fn the_exported_system_carries_the_many_body_term() {
    let (p, b) = disordered_fcc(3, 7, 0.25);
    let k = uniform_springs(b.len(), 1e6, 0.7e6, 0.0, 0.0);
    let d = LocalTensor::Cubic {
        c11: 2e8,
        c12: 1.2e8,
        c44: 0.5e8,
        rotation: rotation_z(0.3) * rotation_x(1.1),
    };
    let term = ManyBody::new(
        &p,
        &b,
        &d,
        &ManyBodyOptions {
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        },
    )
    .unwrap();
    let opts = RelaxedOptions::default();
    let with = relaxed_system(&p, &b, &k, Some(&term), &opts).unwrap();
    let without = relaxed_system(&p, &b, &k, None, &opts).unwrap();
    // Second neighbours join K.
    assert!(with.value.len() > without.value.len());
    let c = dense_relaxed(&with);
    let chol = relaxed_tensor_with_term(
        &p,
        &b,
        &k,
        Some(&term),
        &RelaxedOptions {
            solver: RelaxedSolver::Cholesky,
            ..opts
        },
    )
    .unwrap();
    let diff = max_abs(&(c - chol.c)) / max_abs(&chol.c);
    println!("with the term: {diff:.1e}");
    assert!(diff < 1e-12, "{diff:e}");
    let c0 = dense_relaxed(&without);
    assert!(max_abs(&(c - c0)) > 1e-3 * max_abs(&c0));
}
