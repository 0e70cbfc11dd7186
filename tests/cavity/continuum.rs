//! The continuum cavity (`cavity::continuum`, linear triangles, generalized plane strain)
//! against Lamé's thick cylinder: isotropic, and transversely isotropic about the hole's axis
//! (in-plane isotropic with λ = C12, μ = C66); mesh convergence; refusals.

use anisobond::cavity::lame_wall_displacement;
use anisobond::cavity::{solve_annulus, AnnulusMesh};
use anisobond::tensor::Stiffness6;

/// Isotropic Voigt stiffness from λ, μ (Pa).
fn isotropic(lambda: f64, mu: f64) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            c[(i, j)] = lambda;
        }
        c[(i, i)] += 2.0 * mu;
        c[(i + 3, i + 3)] = mu;
    }
    c
}

#[test]
fn isotropic_annulus_is_lame() {
    let (lambda, mu, p, a, b) = (2.0e9, 1.5e9, 1e5, 0.01, 0.024);
    let exact = lame_wall_displacement(p, a, b, lambda, mu);
    let mut errors = Vec::new();
    for radial in [12, 24, 48] {
        let s = solve_annulus(
            &isotropic(lambda, mu),
            a,
            b,
            p,
            &AnnulusMesh { radial, around: 0 },
        )
        .unwrap();
        let err = s.wall_displacement / exact - 1.0;
        errors.push(err.abs());
        assert!(s.relative_residual < 1e-10);
        // no axial motion, the same radial displacement all round
        for d in [0.0, 45.0, 90.0, 200.0] {
            let (ur, uz) = s.wall_bin(d, 10.0);
            assert!(
                uz.abs() < 1e-9 * exact && (ur / exact - 1.0).abs() < 5e-3,
                "{ur} {uz}"
            );
        }
    }
    // second-order convergence of linear elements: halving h divides the error by 4
    // (measured 3.6e-3, 9.0e-4, 2.2e-4)
    assert!(errors[2] < 3e-4, "{errors:?}");
    assert!(
        errors[0] / errors[1] > 3.5 && errors[1] / errors[2] > 3.5,
        "{errors:?}"
    );
}

#[test]
fn transversely_isotropic_about_the_hole_is_lame_in_plane() {
    // C11 = C22 ≠ C33, C12 = C11 − 2 C66, axis along z (the hole): the plane problem is
    // isotropic with λ = C12, μ = C66, whatever C33, C13, C44.
    let mut c = Stiffness6::zeros();
    let (c11, c12, c13, c33, c44) = (30e9, 8e9, 5e9, 12e9, 3e9);
    c[(0, 0)] = c11;
    c[(1, 1)] = c11;
    c[(2, 2)] = c33;
    c[(0, 1)] = c12;
    c[(1, 0)] = c12;
    for k in 0..2 {
        c[(k, 2)] = c13;
        c[(2, k)] = c13;
    }
    c[(3, 3)] = c44;
    c[(4, 4)] = c44;
    c[(5, 5)] = 0.5 * (c11 - c12);
    let (p, a, b) = (1e5, 0.01, 0.03);
    let s = solve_annulus(&c, a, b, p, &AnnulusMesh::default()).unwrap();
    let exact = lame_wall_displacement(p, a, b, c12, 0.5 * (c11 - c12));
    // measured −3.9e-4 with the default 48 rings
    assert!((s.wall_displacement / exact - 1.0).abs() < 1e-3);
    assert!(s.displacement.iter().all(|u| u.z.abs() < 1e-12 * exact));
}

#[test]
fn bad_annulus_is_refused() {
    let c = isotropic(1e9, 1e9);
    for (a, b, p) in [(0.0, 1.0, 1.0), (2.0, 1.0, 1.0), (1.0, 2.0, f64::NAN)] {
        assert!(solve_annulus(&c, a, b, p, &AnnulusMesh::default()).is_err());
    }
    assert!(solve_annulus(
        &c,
        1.0,
        2.0,
        1.0,
        &AnnulusMesh {
            radial: 1,
            around: 0
        }
    )
    .is_err());
    // not positive definite: a material without shear stiffness
    let mut soft = c;
    soft[(5, 5)] = 0.0;
    soft[(3, 3)] = 0.0;
    soft[(4, 4)] = 0.0;
    match solve_annulus(&soft, 1.0, 2.0, 1.0, &AnnulusMesh::default()) {
        Err(e) => assert!(e.to_string().contains("not positive definite"), "{e}"),
        Ok(_) => panic!("a material without shear stiffness was solved"),
    }
}
