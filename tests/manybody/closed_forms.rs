//! Uniform strain: the term adds exactly (Σ V_p / V)·D (stress, energy and affine tensor),
//! on a random periodic packing and on simple-cubic and FCC lattices; lattices with the term
//! against their closed-form C plus D; the tensor D of each symmetry against its own form.

use super::common::lattice::{fcc_bonded, simple_cubic_bonded, uniform_springs};
use super::common::transverse;
use super::setup::*;
use anisobond::bonds::BondSet;
use anisobond::homogenize::voigt_tensor;
use anisobond::manybody::{LocalTensor, ManyBody, StrainMeasure};
use anisobond::packing::Packing;
use anisobond::tensor::{
    from_fourth_order, isotropic_from_bulk_shear, rotate_fourth_order, rotation_z, to_fourth_order,
    Stiffness6,
};
use anisobond::{Mat3, Vec3};

/// D's of every kind with the same matrix built another way (the explicit 4th-order
/// rotation, the library's isotropic form, the test's transversely isotropic form).
fn tensors() -> Vec<(LocalTensor, Stiffness6)> {
    let mut cubic = Stiffness6::zeros();
    for a in 0..3 {
        for b in 0..3 {
            cubic[(a, b)] = if a == b { 247e9 } else { 147e9 };
        }
        cubic[(a + 3, a + 3)] = 125e9;
    }
    let r = general_rotation();
    let cubic_lab = from_fourth_order(&rotate_fourth_order(
        &to_fourth_order(&cubic),
        &r.transpose(),
    ));
    // Shale-like, axis along x: the z-axis form with indices 1 ↔ 3 (and 4 ↔ 6) swapped.
    let tz = transverse(40e9, 25e9, 12e9, 15e9, 8e9);
    let perm = [2, 1, 0, 5, 4, 3];
    let tx = Stiffness6::from_fn(|a, b| tz[(perm[a], perm[b])]);
    vec![
        (
            LocalTensor::Isotropic {
                bulk: 30e9,
                shear: 12e9,
            },
            isotropic_from_bulk_shear(30e9, 12e9),
        ),
        (
            LocalTensor::Isotropic {
                bulk: 30e9,
                shear: 0.0,
            },
            Stiffness6::from_fn(|a, b| if a < 3 && b < 3 { 30e9 } else { 0.0 }),
        ),
        (cubic_d(), cubic_lab),
        (
            LocalTensor::TransverselyIsotropic {
                c11: 40e9,
                c33: 25e9,
                c13: 12e9,
                c12: 15e9,
                c44: 8e9,
                axis: Vec3::new(-3.0, 0.0, 0.0),
            },
            tx,
        ),
    ]
}

/// The three packings: random periodic (gap-bonded, rattlers excluded), SC, FCC.
fn packings() -> Vec<(&'static str, Packing, BondSet)> {
    let (p, b) = thinned(400, 5);
    let (sc, scb) = simple_cubic_bonded(1e-3);
    let (fcc, fccb) = fcc_bonded(1e-3);
    vec![
        ("random", p, b),
        ("simple cubic", sc, scb),
        ("FCC", fcc, fccb),
    ]
}

/// Σ_included r³ / Σ r³, recomputed from the radii; and the excluded particles checked to be
/// those with fewer than three bonds or bonds in one plane.
fn expected_fraction(p: &Packing, b: &BondSet, mb: &ManyBody) -> f64 {
    let deg = b.degrees(p.len());
    for (q, &dq) in deg.iter().enumerate() {
        let mut a = Mat3::zeros();
        for e in 0..b.len() {
            if b.i[e] as usize == q || b.j[e] as usize == q {
                let l = b.branch(e);
                a += l * l.transpose();
            }
        }
        let eig = nalgebra::SymmetricEigen::new(a).eigenvalues;
        let bad = dq < 3 || eig.min() < 1e-6 * eig.max();
        assert_eq!(mb.excluded().contains(&(q as u32)), bad, "particle {q}");
    }
    let r3 = |q: usize| p.radii[q].powi(3);
    let all: f64 = (0..p.len()).map(r3).sum();
    let kept: f64 = (0..p.len())
        .filter(|q| !mb.excluded().contains(&(*q as u32)))
        .map(r3)
        .sum();
    kept / all
}

#[test]
fn uniform_small_strain_adds_d_exactly() {
    for (name, p, b) in packings() {
        for (d, d_ref) in tensors() {
            let mb = term(&p, &b, &d, StrainMeasure::Small);
            let frac = expected_fraction(&p, &b, &mb);
            if name != "random" {
                assert_eq!(frac, 1.0);
            } else {
                assert!(frac > 0.8 && frac < 1.0, "{frac}");
            }
            // 1 %: the strain is fitted from branch vectors known to ε_mach·|L|, so its relative
            // precision is ~1e-16/|ε| (1e-13 at 0.1 %); the measure is linear at any size.
            let eps = general_strain(1e-2);
            let h = Mat3::identity() + eps;
            let (_, l) = perturbed(&mb, &p, &h, 0.0, 0);
            let ev = mb.evaluate(&l).unwrap();
            let e6 = voigt_of(&eps);
            let sigma = tensor_of(&(d_ref * e6)) * frac;
            let err = (ev.stress - sigma).abs().max() / sigma.abs().max();
            let volume = p.volume();
            let energy = 0.5 * e6.dot(&(d_ref * e6)) * frac * volume;
            let err_u = (ev.energy - energy).abs() / energy;
            println!("{name}: stress {err:.1e}, energy {err_u:.1e}");
            assert!(err < 1e-12, "{name} {d:?}: stress {err:e}");
            assert!(err_u < 1e-12, "{name} {d:?}: energy {err_u:e}");
            // Forces sum to zero (each stencil's coefficients do); on a centro-symmetric
            // lattice every particle's force is zero, on a disordered packing the term loads
            // the fluctuation as the bonds do (the relaxed tensor lies below the affine one).
            let fscale = sigma.abs().max() * p.mean_radius().powi(2);
            let net = ev.forces.iter().fold(Vec3::zeros(), |a, f| a + f);
            assert!(net.norm() < 1e-10 * fscale, "{name}: net force {net:?}");
            let fmax = ev.forces.iter().fold(0.0_f64, |m, f| m.max(f.norm()));
            if name == "random" {
                assert!(fmax > 1e-3 * fscale, "{name}: {fmax:e}");
            } else {
                assert!(
                    fmax < 1e-10 * fscale,
                    "{name}: force {fmax:e} vs {fscale:e}"
                );
            }
        }
    }
}

#[test]
fn uniform_finite_strain_green_lagrange_is_exact() {
    for (name, p, b) in packings() {
        let (d, d_ref) = tensors().swap_remove(2);
        let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
        let frac = expected_fraction(&p, &b, &mb);
        // A finite, non-symmetric gradient: 5 % strain with a rotation.
        let f = rotation_z(0.4) * (Mat3::identity() + general_strain(0.05));
        let (_, l) = perturbed(&mb, &p, &f, 0.0, 0);
        let ev = mb.evaluate(&l).unwrap();
        let e = (f.transpose() * f - Mat3::identity()) * 0.5;
        let e6 = voigt_of(&e);
        let s = tensor_of(&(d_ref * e6));
        let nominal = f * s * frac;
        let err = (ev.stress - nominal).abs().max() / nominal.abs().max();
        let energy = 0.5 * e6.dot(&(d_ref * e6)) * frac * p.volume();
        let err_u = (ev.energy - energy).abs() / energy;
        println!("{name}: Green–Lagrange stress {err:.1e}, energy {err_u:.1e}");
        assert!(err < 1e-12, "{name}: stress {err:e}");
        assert!(err_u < 1e-12, "{name}: energy {err_u:e}");
    }
}

/// The affine tensor summed from the Hessian's bond blocks equals (Σ V_p/V)·D at the
/// reference state, and for the small strain at any state.
#[test]
fn affine_tensor_is_the_closed_form() {
    for (name, p, b) in packings() {
        for (d, d_ref) in tensors() {
            for measure in [StrainMeasure::Small, StrainMeasure::GreenLagrange] {
                let mb = term(&p, &b, &d, measure);
                let frac = expected_fraction(&p, &b, &mb);
                let c = mb.affine_tensor(mb.reference_branches()).unwrap();
                let expect = d_ref * frac;
                let err = max_abs6(&(c - expect)) / max_abs6(&expect);
                assert!(err < 1e-12, "{name} {measure:?}: {err:e}");
                let err_cf = max_abs6(&(mb.closed_form_tensor() - expect)) / max_abs6(&expect);
                assert!(err_cf < 1e-12, "{name}: closed form {err_cf:e}");
                if measure == StrainMeasure::Small {
                    let (_, l) = perturbed(
                        &mb,
                        &p,
                        &(Mat3::identity() + general_strain(0.02)),
                        0.05 * p.mean_radius(),
                        3,
                    );
                    let c = mb.affine_tensor(&l).unwrap();
                    let err = max_abs6(&(c - expect)) / max_abs6(&expect);
                    assert!(err < 1e-12, "{name}: small strain, perturbed {err:e}");
                }
            }
        }
    }
}

/// Simple-cubic and FCC lattices: the Voigt sum of their springs plus the term's affine
/// tensor equals the lattice closed form plus D (SC: C11 = k_n/2R, C12 = 0, C44 = k_t/4R;
/// FCC: C11 = (k_n + k_t)/√2R, C12 = (k_n − k_t)/2√2R, C44 = (k_n + k_t)/2√2R), C12 ≠ C44
/// beyond the Cauchy line included.
#[test]
fn lattices_with_the_term_match_their_closed_forms() {
    let r = 1e-3;
    let (kn, kt) = (2.0e6, 0.7e6);
    let s2r = std::f64::consts::SQRT_2 * r;
    let closed = |c11: f64, c12: f64, c44: f64| {
        let mut c = Stiffness6::zeros();
        for a in 0..3 {
            for b in 0..3 {
                c[(a, b)] = if a == b { c11 } else { c12 };
            }
            c[(a + 3, a + 3)] = c44;
        }
        c
    };
    let cases = [
        (
            simple_cubic_bonded(r),
            closed(kn / (2.0 * r), 0.0, kt / (4.0 * r)),
        ),
        (
            fcc_bonded(r),
            closed(
                (kn + kt) / s2r,
                (kn - kt) / (2.0 * s2r),
                (kn + kt) / (2.0 * s2r),
            ),
        ),
    ];
    for ((p, b), c_lattice) in cases {
        for (d, d_ref) in tensors() {
            let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
            assert!(mb.excluded().is_empty());
            let pair = voigt_tensor(&b, &uniform_springs(b.len(), kn, kt, 0.0, 0.0), p.volume());
            let total = pair + mb.affine_tensor(mb.reference_branches()).unwrap();
            let expect = c_lattice + d_ref;
            let err = max_abs6(&(total - expect)) / max_abs6(&expect);
            assert!(err < 1e-12, "{err:e}");
        }
        // A purely volumetric D moves C11 and C12 by K and leaves C44: C12 − C44 = K + the
        // pairwise C12 − C44, past the Cauchy line for K large enough.
        let k_add = 2.0 * kn / r;
        let mb = term(
            &p,
            &b,
            &LocalTensor::Isotropic {
                bulk: k_add,
                shear: 0.0,
            },
            StrainMeasure::Small,
        );
        let total = voigt_tensor(&b, &uniform_springs(b.len(), kn, kt, 0.0, 0.0), p.volume())
            + mb.affine_tensor(mb.reference_branches()).unwrap();
        let shift = (total[(0, 1)] - total[(3, 3)]) - (c_lattice[(0, 1)] - c_lattice[(3, 3)]);
        assert!((shift - k_add).abs() < 1e-12 * k_add);
        assert!(total[(0, 1)] > total[(3, 3)]);
    }
}

/// The cubic D rotated by 45° about z against the textbook rotated constants:
/// C11' = (C11 + C12)/2 + C44, C12' = (C11 + C12)/2 − C44, C66' = (C11 − C12)/2.
#[test]
fn cubic_tensor_rotated_about_z_matches_its_closed_form() {
    let d = LocalTensor::Cubic {
        c11: 247e9,
        c12: 147e9,
        c44: 125e9,
        rotation: rotation_z(std::f64::consts::FRAC_PI_4),
    }
    .voigt()
    .unwrap();
    let tol = 1e-3; // Pa on 3e11: 3e-15 relative
    assert!((d[(0, 0)] - (197e9 + 125e9)).abs() < tol);
    assert!((d[(0, 1)] - (197e9 - 125e9)).abs() < tol);
    assert!((d[(5, 5)] - 50e9).abs() < tol);
    assert!((d[(2, 2)] - 247e9).abs() < tol);
    assert!((d[(3, 3)] - 125e9).abs() < tol);
    assert!(d[(0, 5)].abs() < tol);
}
