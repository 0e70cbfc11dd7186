//! Christoffel phase velocities against closed forms (isotropic, cubic [100] and [110],
//! transversely isotropic along and across its axis) and symmetries.

use crate::common::transverse;
use anisobond::tensor::{isotropic_stiffness, phase_velocities, rotate, rotation_x, rotation_z};
use anisobond::{Mat3, Vec3};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs()
}

#[test]
fn isotropic_speeds_are_longitudinal_and_shear() {
    let (e, nu, rho) = (70e9, 0.3, 2700.0);
    let c = isotropic_stiffness(e, nu).unwrap();
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let vp = ((lambda + 2.0 * mu) / rho).sqrt();
    let vs = (mu / rho).sqrt();
    for d in [
        Vec3::x(),
        Vec3::new(1.0, 2.0, -3.0),
        Vec3::new(0.3, -0.1, 0.9),
    ] {
        let w = phase_velocities(&c, rho, &d).unwrap();
        assert!(
            close(w.modes[2].speed, vp, 1e-12),
            "{} vs {vp}",
            w.modes[2].speed
        );
        assert!(close(w.modes[0].speed, vs, 1e-12));
        assert!(close(w.modes[1].speed, vs, 1e-12));
        // the fast mode is polarised along the direction
        assert!(close(
            w.modes[2].polarisation.dot(&d.normalize()).abs(),
            1.0,
            1e-10
        ));
        assert_eq!(w.quasi_longitudinal().speed, w.modes[2].speed);
    }
}

fn cubic(c11: f64, c12: f64, c44: f64) -> anisobond::tensor::Stiffness6 {
    crate::common::transverse(c11, c11, c12, c12, c44) + {
        // transverse() sets C66 = (C11 − C12)/2; a cubic crystal has C66 = C44
        let mut d = anisobond::tensor::Stiffness6::zeros();
        d[(5, 5)] = c44 - (c11 - c12) / 2.0;
        d
    }
}

#[test]
fn cubic_crystal_along_100_and_110() {
    // copper (GPa), density 8960 kg/m³
    let (c11, c12, c44, rho) = (168.4e9, 121.4e9, 75.4e9, 8960.0);
    let c = cubic(c11, c12, c44);
    let w = phase_velocities(&c, rho, &Vec3::x()).unwrap();
    assert!(close(w.modes[2].speed, (c11 / rho).sqrt(), 1e-12));
    assert!(close(w.modes[0].speed, (c44 / rho).sqrt(), 1e-12));
    assert!(close(w.modes[1].speed, (c44 / rho).sqrt(), 1e-12));
    let w = phase_velocities(&c, rho, &Vec3::new(1.0, 1.0, 0.0)).unwrap();
    let vl = ((c11 + c12 + 2.0 * c44) / (2.0 * rho)).sqrt();
    let vt1 = (c44 / rho).sqrt(); // polarised along [001]
    let vt2 = ((c11 - c12) / (2.0 * rho)).sqrt(); // polarised along [1-10]
    assert!(vt2 < vt1 && vt1 < vl);
    assert!(close(w.modes[0].speed, vt2, 1e-12));
    assert!(close(w.modes[1].speed, vt1, 1e-12));
    assert!(close(w.modes[2].speed, vl, 1e-12));
    let s = 0.5f64.sqrt();
    assert!(close(
        w.modes[0].polarisation.dot(&Vec3::new(s, -s, 0.0)).abs(),
        1.0,
        1e-10
    ));
    assert!(close(w.modes[1].polarisation.z.abs(), 1.0, 1e-10));
    assert!(close(
        w.modes[2].polarisation.dot(&Vec3::new(s, s, 0.0)).abs(),
        1.0,
        1e-10
    ));
}

#[test]
fn transversely_isotropic_along_and_across_the_axis() {
    // Šmilauer's prescribed microplane tensor (MPa), axis z
    let (c11, c33, c13, c12, c44) = (130e6, 55e6, 28e6, 40e6, 32.2e6);
    let c = transverse(c11, c33, c13, c12, c44);
    let rho = 2000.0;
    let along = phase_velocities(&c, rho, &Vec3::z()).unwrap();
    assert!(close(along.fastest(), (c33 / rho).sqrt(), 1e-12));
    assert!(close(along.modes[0].speed, (c44 / rho).sqrt(), 1e-12));
    let across = phase_velocities(&c, rho, &Vec3::y()).unwrap();
    assert!(close(across.fastest(), (c11 / rho).sqrt(), 1e-12));
    // SH polarised in the isotropic plane: C66; SV polarised along the axis: C44
    assert!(close(across.modes[0].speed, (c44 / rho).sqrt(), 1e-12));
    assert!(close(
        across.modes[1].speed,
        ((c11 - c12) / 2.0 / rho).sqrt(),
        1e-12
    ));
    // isotropic plane: every in-plane direction is the same
    let oblique = phase_velocities(&c, rho, &Vec3::new(0.6, 0.8, 0.0)).unwrap();
    for k in 0..3 {
        assert!(close(oblique.modes[k].speed, across.modes[k].speed, 1e-12));
    }
}

#[test]
fn speeds_are_invariant_under_rotating_medium_and_direction_together() {
    let c = cubic(168.4e9, 121.4e9, 75.4e9) + transverse(5e9, 1e9, 0.0, 0.0, 0.0);
    let q: Mat3 = rotation_z(0.7) * rotation_x(-0.4);
    let cr = rotate(&c, &q);
    let rho = 5000.0;
    for d in [Vec3::new(1.0, 0.2, 0.3), Vec3::new(-0.2, 0.5, 1.0)] {
        let a = phase_velocities(&c, rho, &d).unwrap();
        let b = phase_velocities(&cr, rho, &(q * d)).unwrap();
        let back = phase_velocities(&c, rho, &(-d)).unwrap();
        for k in 0..3 {
            assert!(close(a.modes[k].speed, b.modes[k].speed, 1e-10));
            assert!(close(a.modes[k].speed, back.modes[k].speed, 1e-12));
            // polarisations rotate with the medium
            let pa = q * a.modes[k].polarisation;
            assert!(close(pa.dot(&b.modes[k].polarisation).abs(), 1.0, 1e-8));
        }
    }
}

#[test]
fn bad_inputs_are_refused() {
    let c = isotropic_stiffness(1e9, 0.25).unwrap();
    assert!(phase_velocities(&c, 1000.0, &Vec3::zeros()).is_err());
    assert!(phase_velocities(&c, 0.0, &Vec3::x()).is_err());
    assert!(phase_velocities(&c, f64::NAN, &Vec3::x()).is_err());
    let mut bad = c;
    bad[(0, 0)] = -1e9;
    let e = phase_velocities(&bad, 1000.0, &Vec3::x())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not positive definite"), "{e}");
}
