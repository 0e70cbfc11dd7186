//! The relaxed (static equilibrium) tensor: closed forms on lattices, the bounds and
//! orderings of docs/references.md "Relaxed (static) stiffness: properties to test", and Kruyt's
//! LAF estimates between them.

use crate::common::lattice::*;
use anisobond::homogenize::laf_tensor;
use anisobond::homogenize::voigt_tensor;
use anisobond::homogenize::LeverArm;
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};
use anisobond::tensor::Stiffness6;

#[test]
fn simple_cubic_and_fcc_relaxed_equal_closed_forms() {
    let r = 1e-3;
    let (kn, kt) = (2e6, 0.8e6);
    // Simple cubic, bond length 2R: C11 = kn/(2R), C12 = 0, C44 = kt/(4R).
    let (p, b) = simple_cubic_bonded(r);
    assert_eq!(b.len(), 3 * 64);
    let res = relaxed_tensor(
        &p,
        &b,
        &uniform_springs(b.len(), kn, kt, 0.0, 0.0),
        &RelaxedOptions::default(),
    )
    .unwrap();
    let tol = 1e-9 * kn / r;
    assert!((res.c[(0, 0)] - kn / (2.0 * r)).abs() < tol);
    assert!(res.c[(0, 1)].abs() < tol);
    assert!(
        (res.c[(3, 3)] - kt / (4.0 * r)).abs() < tol,
        "{}",
        res.c[(3, 3)]
    );
    // FCC: C11 = (kn+kt)/(√2R), C12 = (kn−kt)/(2√2R), C44 = (kn+kt)/(2√2R).
    let (p, b) = fcc_bonded(r);
    assert_eq!(b.len(), 6 * p.len());
    let res = relaxed_tensor(
        &p,
        &b,
        &uniform_springs(b.len(), kn, kt, 0.0, 0.0),
        &RelaxedOptions::default(),
    )
    .unwrap();
    let s2r = std::f64::consts::SQRT_2 * r;
    assert!((res.c[(0, 0)] - (kn + kt) / s2r).abs() < tol);
    assert!((res.c[(0, 1)] - (kn - kt) / (2.0 * s2r)).abs() < tol);
    assert!((res.c[(3, 3)] - (kn + kt) / (2.0 * s2r)).abs() < tol);
}

#[test]
fn relaxed_is_below_voigt_symmetric_and_exact_without_fluctuations() {
    let (p, b) = disordered_fcc(5, 1, 0.25);
    let k = uniform_springs(b.len(), 1e6, 0.8e6, 0.0, 0.0);
    let voigt = voigt_tensor(&b, &k, p.volume());
    let opts = RelaxedOptions::default();
    let res = relaxed_tensor(&p, &b, &k, &opts).unwrap();
    let scale = max_abs(&voigt);
    // symmetric to 1e-10 relative
    assert!(max_abs(&(res.c - res.c.transpose())) < 1e-10 * scale);
    // voigt − relaxed positive semi-definite, and strictly softer
    assert!(min_eigenvalue(&(voigt - res.c)) > -1e-10 * scale);
    assert!(res.c[(3, 3)] < 0.99 * voigt[(3, 3)]);
    // suppressing fluctuations returns the Voigt sum (all bonds active here)
    if res.null_space.removed_bonds == 0 {
        let affine = relaxed_tensor(
            &p,
            &b,
            &k,
            &RelaxedOptions {
                fluctuations: false,
                ..opts
            },
        )
        .unwrap();
        assert!(max_abs(&(affine.c - voigt)) < 1e-12 * scale);
    }
    // locking rotations or adding rotational springs lands between the two
    let locked = relaxed_tensor(
        &p,
        &b,
        &k,
        &RelaxedOptions {
            rotations: false,
            ..opts
        },
    )
    .unwrap();
    assert!(min_eigenvalue(&(locked.c - res.c)) > -1e-10 * scale);
    assert!(min_eigenvalue(&(voigt - locked.c)) > -1e-10 * scale);
    let kb = uniform_springs(b.len(), 1e6, 0.8e6, 1e6 * 1e-6 * 0.25, 1e6 * 1e-6 * 0.5);
    let bent = relaxed_tensor(&p, &b, &kb, &opts).unwrap();
    assert!(min_eigenvalue(&(bent.c - res.c)) > -1e-10 * scale);
    assert!(min_eigenvalue(&(voigt - bent.c)) > -1e-10 * scale);
}

#[test]
fn relaxed_is_thread_count_independent_and_lever_arms_agree_for_equal_spheres() {
    let (p, b) = disordered_fcc(5, 2, 0.25);
    let k = uniform_springs(b.len(), 1e6, 0.5e6, 0.0, 0.0);
    let run = |t: usize, arm| {
        crate::common::on_threads(t, || {
            relaxed_tensor(
                &p,
                &b,
                &k,
                &RelaxedOptions {
                    lever_arm: arm,
                    ..Default::default()
                },
            )
            .unwrap()
            .c
        })
    };
    let c1 = run(1, LeverArm::MidGap);
    assert_eq!(c1, run(2, LeverArm::MidGap));
    let c3 = run(2, LeverArm::Proportional);
    assert!(max_abs(&(c1 - c3)) < 1e-9 * max_abs(&c1));
}

#[test]
fn laf_energy_bounds_relaxed_and_decreases_with_shell_order() {
    let (p, b) = disordered_fcc(5, 3, 0.2);
    let k = uniform_springs(b.len(), 1e6, 0.8e6, 0.0, 0.0);
    let relaxed = relaxed_tensor(&p, &b, &k, &RelaxedOptions::default())
        .unwrap()
        .c;
    let scale = max_abs(&relaxed);
    let mut previous: Option<Stiffness6> = None;
    for m in 1..=3 {
        let laf = laf_tensor(&p, &b, &k, LeverArm::MidGap, m).unwrap();
        // energy-based ≥ relaxed (PSD difference), and ≤ affine
        assert!(
            min_eigenvalue(&(laf.c_energy - relaxed)) > -1e-9 * scale,
            "m = {m}"
        );
        assert!(min_eigenvalue(&(laf.c_affine - laf.c_energy)) > -1e-9 * scale);
        if let Some(prev) = previous {
            // trace decreases toward the relaxed one
            assert!(
                laf.c_energy.trace() <= prev.trace() + 1e-9 * scale,
                "m = {m}"
            );
        }
        let rel_err = (laf.c_stress[(3, 3)] - relaxed[(3, 3)]).abs() / relaxed[(3, 3)];
        eprintln!(
            "m = {m}: energy C44/relaxed = {:.4}, stress C44/relaxed = {:.4} (|err| {rel_err:.3}), free particles per shell {:.1}",
            laf.c_energy[(3, 3)] / relaxed[(3, 3)],
            laf.c_stress[(3, 3)] / relaxed[(3, 3)],
            laf.mean_free_particles
        );
        previous = Some(laf.c_energy);
    }
}
