//! Šmilauer's cross-anisotropic elliptic scheme against the exact 1/35 matrix
//! and its inverse (docs/references.md), the paper's worked example, closed-form lattice scalings
//! and the mean-field orientation integral.

use crate::common::reference::{rotate4, voigt4};
use crate::common::transverse;
use std::f64::consts::PI;

use anisobond::bonds::lattice_scaling;
use anisobond::bonds::BondSet;
use anisobond::homogenize::{mean_field, orientation_average, SphereQuadrature, DEFAULT_ORDER};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::schemes::StiffnessScheme;
use anisobond::schemes::{
    axis_from_strike_dip, dependent_c44, inverse_block, microplane_matrix, CrossAnisotropic,
};
use anisobond::{Mat3, Vec3};

/// The 1/35 matrix of docs/references.md / Šmilauer Eq. 10, times 35.
const A35: [[i64; 4]; 5] = [
    [36, 6, 20, 8],
    [12, 30, 16, 12],
    [8, 6, -8, -6],
    [12, 2, -12, -2],
    [8, 6, 13, 8],
];
/// C66 = (C11 − C12)/2 row, times 35 (docs/references.md).
const C66_35: [i64; 4] = [12, 2, 16, 5];

#[test]
fn microplane_matrix_is_the_exact_1_over_35_matrix() {
    let a = microplane_matrix();
    for (row, want) in a.iter().zip(A35.iter()) {
        for (x, &k) in row.iter().zip(want.iter()) {
            assert_eq!(*x, k as f64 / 35.0);
        }
    }
}

#[test]
fn own_quadrature_reproduces_the_1_over_35_matrix() {
    // Column k of A is the microplane response C_micro = 6·T to a unit entry of 𝓔
    // (Šmilauer Eq. 3: (3/2π)·∫dΩ = 6·⟨⟩).
    let quad = SphereQuadrature::new(&[], DEFAULT_ORDER);
    for k in 0..4 {
        let mut e = [0.0; 4];
        e[k] = 1.0;
        let scheme = CrossAnisotropic::from_moduli(e, Vec3::z()).expect("unit moduli");
        let c = orientation_average(&scheme, &quad) * 6.0;
        let a = |r: usize| A35[r][k] as f64 / 35.0;
        let want = transverse(a(0), a(1), a(2), a(3), a(4));
        // C66 from the matrix rows must also be the independent row (12, 2, 16, 5)/35.
        assert!((want[(5, 5)] - C66_35[k] as f64 / 35.0).abs() < 1e-15);
        for x in 0..6 {
            for y in 0..6 {
                assert!(
                    (c[(x, y)] - want[(x, y)]).abs() < 1e-14,
                    "E unit {k}: C[{x}][{y}] = {} vs {}",
                    c[(x, y)],
                    want[(x, y)]
                );
            }
        }
    }
}

#[test]
fn c66_row_is_half_the_difference_of_c11_and_c12_rows() {
    for k in 0..4 {
        assert_eq!(A35[0][k] - A35[3][k], 2 * C66_35[k]);
    }
}

#[test]
fn isotropic_limits_are_exact() {
    // E_N^a = E_N^b = E_N, E_T^a = E_T^b = E_T (Šmilauer Eq. 7), in 35ths.
    for (en, et) in [(1i64, 0i64), (0, 1), (7, 3)] {
        let e = [en, en, et, et];
        let dot = |row: &[i64; 4]| row.iter().zip(e.iter()).map(|(a, b)| a * b).sum::<i64>();
        assert_eq!(dot(&A35[0]) * 5, 35 * (6 * en + 4 * et)); // C11
        assert_eq!(dot(&A35[1]) * 5, 35 * (6 * en + 4 * et)); // C33
        assert_eq!(dot(&A35[2]) * 5, 35 * (2 * en - 2 * et)); // C13
        assert_eq!(dot(&A35[3]) * 5, 35 * (2 * en - 2 * et)); // C12
        assert_eq!(dot(&A35[4]) * 5, 35 * (2 * en + 3 * et)); // C44
        assert_eq!(dot(&C66_35) * 5, 35 * (2 * en + 3 * et)); // C66
    }
}

#[test]
fn inverse_times_matrix_is_identity_exactly() {
    let inv = inverse_block();
    let a = microplane_matrix();
    // Integer form: (4·A⁻¹)(35·A) = 140·I.
    let inv4: Vec<Vec<i64>> = inv
        .iter()
        .map(|r| {
            r.iter()
                .map(|x| {
                    assert_eq!((4.0 * x).fract(), 0.0, "entry {x} is not a multiple of 1/4");
                    (4.0 * x) as i64
                })
                .collect()
        })
        .collect();
    for i in 0..4 {
        for j in 0..4 {
            let p: i64 = (0..4).map(|k| inv4[i][k] * A35[k][j]).sum();
            assert_eq!(p, if i == j { 140 } else { 0 }, "entry ({i},{j})");
            let f: f64 = (0..4).map(|k| inv[i][k] * a[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((f - want).abs() < 1e-15, "f64 entry ({i},{j}) = {f}");
        }
    }
}

#[test]
fn dependent_c44_is_the_fifth_row() {
    // (C11 + C33)/4 − C13/2 applied to each column of A gives the C44 row, exactly.
    let a = microplane_matrix();
    for k in 0..4 {
        assert_eq!(
            dependent_c44(a[0][k] * 35.0, a[1][k] * 35.0, a[2][k] * 35.0),
            A35[4][k] as f64
        );
    }
}

#[test]
fn worked_example_of_the_paper() {
    // C = (130, 55, 28, 40) MPa → A⁻¹C = (120.75, 12, 5.75, 2) MPa, C44 = 32.25 MPa.
    let c = [130.0, 55.0, 28.0, 40.0];
    let inv = inverse_block();
    let e: Vec<f64> = inv
        .iter()
        .map(|r| r.iter().zip(c.iter()).map(|(x, y)| x * y).sum())
        .collect();
    assert_eq!(e, vec![120.75, 12.0, 5.75, 2.0]);
    assert_eq!(dependent_c44(130.0, 55.0, 28.0), 32.25);

    // The paper's printed E′ = (59.7, 5.94, 2.84, 0.989) MPa with μ = 2.0215.
    let mu = 2.0215;
    let s = CrossAnisotropic::from_target(130e6, 55e6, 28e6, 40e6, Vec3::z(), mu)
        .expect("the paper's target");
    let printed = [(59.7, 0.05), (5.94, 0.005), (2.84, 0.005), (0.989, 0.0005)];
    for (got, (want, half)) in s.e_prime.iter().zip(printed) {
        assert!(
            (got / 1e6 - want).abs() <= half,
            "E' = {} MPa vs printed {want}",
            got / 1e6
        );
    }
    // Forward again: μ·A·E′ = (C11, C33, C13, C12, C44).
    let back = s.microplane_constants(mu);
    for (got, want) in back.iter().zip([130e6, 55e6, 28e6, 40e6, 32.25e6]) {
        assert!((got - want).abs() < 1e-8 * want, "{got} vs {want}");
    }
}

#[test]
fn mean_field_with_six_mu_reproduces_a_tilted_target() {
    // prefactor = N⟨l·π̂r²⟩/V = 6μ for the modulus convention; the lattice tensor μ·C_micro.
    let mu = 1.7;
    let axis = axis_from_strike_dip(270.0, 25.0);
    let s = CrossAnisotropic::from_target(130e6, 55e6, 28e6, 40e6, axis, mu).expect("target");
    let c = mean_field(&s, 6.0 * mu, DEFAULT_ORDER);
    // Q maps z onto the axis; the tensor is invariant about the axis, so any such Q works.
    let e1 = axis.cross(&Vec3::x()).normalize();
    let e2 = axis.cross(&e1);
    let q = Mat3::from_columns(&[e1, e2, axis]);
    assert!((q.determinant() - 1.0).abs() < 1e-14);
    let want = rotate4(voigt4(&transverse(130e6, 55e6, 28e6, 40e6, 32.25e6)), &q);
    let d = (c - want).abs().max() / 130e6;
    assert!(d < 1e-13, "relative difference {d:e}");
    assert!(s.kink_planes().is_empty());
}

#[test]
fn strike_and_dip_give_the_axis() {
    for strike in [0.0, 37.0, 270.0] {
        assert!((axis_from_strike_dip(strike, 0.0) - Vec3::z()).norm() < 1e-15);
    }
    assert!((axis_from_strike_dip(0.0, 90.0) - Vec3::x()).norm() < 1e-15);
    assert!((axis_from_strike_dip(90.0, 90.0) + Vec3::y()).norm() < 1e-15);
    let b = 25f64.to_radians();
    let a = axis_from_strike_dip(270.0, 25.0);
    assert!((a - Vec3::new(0.0, b.sin(), b.cos())).norm() < 1e-15);
    assert!((a.norm() - 1.0).abs() < 1e-15);
}

/// Simple cubic periodic lattice n×n×n with spacing `spacing`, every nearest-neighbour pair
/// bonded (3 bonds per sphere).
fn simple_cubic(n: usize, radius: f64, spacing: f64) -> (Packing, BondSet) {
    let idx = |a: usize, b: usize, c: usize| (a * n + b) * n + c;
    let mut positions = Vec::new();
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                positions.push(Vec3::new(a as f64, b as f64, c as f64) * spacing);
            }
        }
    }
    let cell = PeriodicCell::new(Vec3::repeat(n as f64 * spacing)).expect("cell");
    let packing = Packing::new(positions, vec![radius; n * n * n], Some(cell)).expect("packing");
    let mut bonds = BondSet::default();
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                let site = [a, b, c];
                for k in 0..3 {
                    let mut nb = site;
                    nb[k] += 1;
                    let mut image = [0i32; 3];
                    if nb[k] == n {
                        nb[k] = 0;
                        image[k] = 1;
                    }
                    let (i, j) = (idx(a, b, c), idx(nb[0], nb[1], nb[2]));
                    let mut branch = Vec3::zeros();
                    branch[k] = spacing;
                    if i < j {
                        bonds.push(i as u32, j as u32, branch, image);
                    } else {
                        bonds.push(j as u32, i as u32, -branch, image.map(|x| -x));
                    }
                }
            }
        }
    }
    (packing, bonds)
}

#[test]
fn lattice_scaling_of_touching_simple_cubic_is_pi_over_8() {
    // μ = (Zφ/8)·⟨r′⟩/R with Z = 6, φ = π/6, r′ = R: π/8 (docs/references.md).
    let r = 0.03;
    let (packing, bonds) = simple_cubic(3, r, 2.0 * r);
    assert_eq!(bonds.len(), 81);
    assert!((bonds.coordination(packing.len()) - 6.0).abs() < 1e-15);
    assert!((packing.solid_fraction() - PI / 6.0).abs() < 1e-14);
    let mu = lattice_scaling(&packing, &bonds, PI).expect("bonds");
    assert!((mu - PI / 8.0).abs() < 1e-14, "mu = {mu}");
    // π̂ enters linearly (Woo's Python default π/2).
    let half = lattice_scaling(&packing, &bonds, PI / 2.0).expect("bonds");
    assert!((half - PI / 16.0).abs() < 1e-14);
}

#[test]
fn lattice_scaling_uses_half_the_actual_centre_distance() {
    // Spacing 2.2R: r′ = 1.1R, φ = (4π/3)R³/(2.2R)³, μ = (Zφ/8)·1.1.
    let r = 0.5;
    let (packing, bonds) = simple_cubic(3, r, 2.2 * r);
    let phi = 4.0 / 3.0 * PI / 2.2f64.powi(3);
    let mu = lattice_scaling(&packing, &bonds, PI).expect("bonds");
    let want = 6.0 * phi / 8.0 * 1.1;
    assert!((mu - want).abs() < 1e-14 * want, "{mu} vs {want}");
}

#[test]
fn lattice_scaling_refuses_bad_input() {
    let (packing, bonds) = simple_cubic(3, 1.0, 2.0);
    let e = lattice_scaling(&packing, &BondSet::default(), PI).unwrap_err();
    assert!(e.to_string().contains("no bonds"), "{e}");
    assert!(lattice_scaling(&packing, &bonds, 0.0).is_err());
    assert!(lattice_scaling(&packing, &bonds, f64::NAN).is_err());
    let mut bad = BondSet::default();
    bad.push(0, 99, Vec3::x(), [0; 3]);
    let e = lattice_scaling(&packing, &bad, PI).unwrap_err();
    assert!(e.to_string().contains("99"), "{e}");
}

#[test]
fn from_target_refuses_inadmissible_targets() {
    let z = Vec3::z();
    // Not positive definite: 2·C13² > (C11 + C12)·C33.
    let e = CrossAnisotropic::from_target(130.0, 55.0, 80.0, 40.0, z, 2.0).unwrap_err();
    assert!(e.to_string().contains("positive definite"), "{e}");
    // C12 > C11: negative C66.
    let e = CrossAnisotropic::from_target(40.0, 55.0, 10.0, 50.0, z, 2.0).unwrap_err();
    assert!(e.to_string().contains("C66"), "{e}");
    // Positive definite, but E_T^b′ = −C11/2 + C33 − 6C13 + 9C12/2 = −133 < 0.
    let e = CrossAnisotropic::from_target(130.0, 55.0, 28.0, 10.0, z, 2.0).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("negative") && msg.contains("E_T^b'"), "{msg}");
    // Bad μ, non-finite values, zero axis.
    assert!(CrossAnisotropic::from_target(130.0, 55.0, 28.0, 40.0, z, 0.0).is_err());
    assert!(CrossAnisotropic::from_target(130.0, 55.0, 28.0, 40.0, z, -1.0).is_err());
    assert!(CrossAnisotropic::from_target(f64::NAN, 55.0, 28.0, 40.0, z, 2.0).is_err());
    assert!(CrossAnisotropic::from_target(130.0, 55.0, 28.0, 40.0, Vec3::zeros(), 2.0).is_err());
}

#[test]
fn magnitudes_follow_the_angle_to_the_axis() {
    let axis = axis_from_strike_dip(30.0, 60.0);
    let s = CrossAnisotropic::from_moduli([8.0, 2.0, 4.0, 1.0], axis * 3.0).expect("moduli");
    assert!((s.axis.norm() - 1.0).abs() < 1e-15);
    let along = s.magnitudes(&axis);
    assert!((along.normal - 2.0).abs() < 1e-14 && (along.shear - 1.0).abs() < 1e-14);
    let perp = axis.cross(&Vec3::z()).normalize();
    let across = s.magnitudes(&perp);
    assert!((across.normal - 8.0).abs() < 1e-14 && (across.shear - 4.0).abs() < 1e-14);
    // θ = 60°: sin² = 3/4.
    let n = (axis * 0.5 + perp * 0.75f64.sqrt()).normalize();
    let m = s.magnitudes(&n);
    assert!((m.normal - (0.75 * 8.0 + 0.25 * 2.0)).abs() < 1e-14);
    assert!((m.shear - (0.75 * 4.0 + 0.25 * 1.0)).abs() < 1e-14);
}
