//! The tangent of a pre-stressed network (src/homogenize/prestress.rs) against the closed
//! form of a preloaded FCC lattice and the stress-measure identities.

use crate::common::lattice::*;
use anisobond::homogenize::{prestressed_tensor, stress_measure_correction, Prestress};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};
use anisobond::tensor::Voigt6;

/// FCC, touching spheres of radius R (a = 2√2R, l = 2R), springs k_n, k_t, every bond
/// preloaded by N: σ⁰ = −pI with p = −8Nl/a³ = −N/(√2R²), and (hand sums over the six bond
/// directions per sphere, docs/prestress.md)
/// C11 = (k_n+k_t)/(√2R) − p/2, C12 = (k_n−k_t)/(2√2R) + 5p/4, C44 = (k_n+k_t)/(2√2R) − 3p/4.
#[test]
fn preloaded_fcc_equals_closed_form() {
    let r = 1e-3;
    let (kn, kt) = (2e6, 0.8e6);
    let (p, b) = fcc_bonded(r);
    let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
    let s2r = std::f64::consts::SQRT_2 * r;
    for n_force in [-30.0, 45.0] {
        let pre = Prestress::from_axial_forces(vec![n_force; b.len()]).unwrap();
        assert!(pre.unbalance(&p, &b) < 1e-12);
        let t = prestressed_tensor(&p, &b, &k, &pre, &RelaxedOptions::default()).unwrap();
        let pressure = -n_force / (s2r * r);
        let tol = 1e-9 * kn / r;
        for i in 0..3 {
            assert!((t.stress[(i, i)] + pressure).abs() < 1e-9 * pressure.abs());
        }
        let expect = [
            ((0, 0), (kn + kt) / s2r - pressure / 2.0),
            ((1, 1), (kn + kt) / s2r - pressure / 2.0),
            ((0, 1), (kn - kt) / (2.0 * s2r) + 1.25 * pressure),
            ((2, 1), (kn - kt) / (2.0 * s2r) + 1.25 * pressure),
            ((3, 3), (kn + kt) / (2.0 * s2r) - 0.75 * pressure),
            ((5, 5), (kn + kt) / (2.0 * s2r) - 0.75 * pressure),
            ((0, 3), 0.0),
            ((3, 4), 0.0),
        ];
        for ((a, c), v) in expect {
            assert!(
                (t.c[(a, c)] - v).abs() < tol,
                "N = {n_force}: C[{a}{c}] = {} expected {v}",
                t.c[(a, c)]
            );
        }
        // The preload is a measurable fraction of the tensor, so the test has teeth.
        assert!(pressure.abs() > 1e-2 * kn / r);
    }
}

/// The energy tangent is symmetric; the Cauchy tangent differs from it by exactly
/// −σ⁰ tr ε + sym(σ⁰ε), and the preload's effect is linear in its size and vanishes with it.
#[test]
fn prestress_of_a_disordered_network_is_consistent() {
    let (p, b) = disordered_fcc(4, 7, 0.25);
    let k = uniform_springs(b.len(), 2e6, 0.8e6, 1e-2, 1e-2);
    let opts = RelaxedOptions {
        tolerance: 1e-10,
        ..Default::default()
    };
    let strain = Voigt6::new(-1e-3, -1e-3, -1e-3, 0.0, 0.0, 0.0);
    let pre = Prestress::central_from_strain(&p, &b, &k, &strain, &opts).unwrap();
    assert!(pre.unbalance(&p, &b) < 1e-8);
    assert!(pre.axial_force.iter().any(|f| *f < 0.0));
    let free = relaxed_tensor(&p, &b, &k, &opts).unwrap().c;
    let zero = prestressed_tensor(&p, &b, &k, &pre.scaled(0.0), &opts).unwrap();
    assert!((zero.c - free).abs().max() < 1e-9 * free.abs().max());
    let one = prestressed_tensor(&p, &b, &k, &pre, &opts).unwrap();
    let two = prestressed_tensor(&p, &b, &k, &pre.scaled(2.0), &opts).unwrap();
    let asym = (one.c_energy - one.c_energy.transpose()).abs().max();
    assert!(asym < 1e-9 * free.abs().max());
    let corr = stress_measure_correction(&one.stress);
    assert!((one.c - one.c_energy - corr).abs().max() < 1e-9 * free.abs().max());
    // Linear in the preload up to the relaxation's second order: the second difference is
    // far below the first.
    let d1 = (one.c - free).abs().max();
    let d2 = (two.c - one.c * 2.0 + free).abs().max();
    assert!(d1 > 1e-4 * free.abs().max(), "preload effect {d1}");
    assert!(d2 < 0.05 * d1, "second difference {d2} vs first {d1}");
    // A compressive isotropic preload raises C12 and lowers C44 (docs/prestress.md).
    assert!(one.c[(0, 1)] > free[(0, 1)] && one.c[(3, 3)] < free[(3, 3)]);
}

/// On a random packing the preload's affine terms follow the isotropic closed form of
/// docs/prestress.md, ΔC11 = −2p/5, ΔC12 = +6p/5, ΔC44 = −4p/5 (σ⁰ = −pI, bond directions
/// isotropic), to the packing's anisotropy; and the relaxed Cauchy tangent of the standard
/// assembly crosses to C12 > C44 under a compressive preload, which the stress-free network
/// never reaches (Truszkowska 2018 App. D).
#[test]
fn isotropic_preload_follows_the_closed_form_and_raises_c12_above_c44() {
    use anisobond::assembly::Assembly;
    use anisobond::model::Model;
    use anisobond::packing::{
        generate, GenerateOptions, Polydispersity, TRUSZKOWSKA_2018_HALF_WIDTH,
    };
    use anisobond::tensor::CubicProjection;
    let opts = GenerateOptions {
        n_particles: 2000,
        solid_fraction: 0.60,
        mean_radius: 1e-3,
        polydispersity: Polydispersity::Uniform {
            half_width: TRUSZKOWSKA_2018_HALF_WIDTH,
        },
        seed: 3,
        ..Default::default()
    };
    let a = Assembly::new(generate(&opts, &|_| {}).unwrap(), Model::truszkowska_mrv()).unwrap();
    let ro = RelaxedOptions::default();
    let free = relaxed_tensor(&a.packing, &a.bonds, &a.springs, &ro).unwrap();
    let c11 = CubicProjection::from_stiffness(&free.c).c11;
    let pressure = 0.08 * c11;
    let pre = Prestress::isotropic(&a.packing, &a.bonds, &a.springs, pressure, &ro).unwrap();
    let t = prestressed_tensor(&a.packing, &a.bonds, &a.springs, &pre, &ro).unwrap();
    let mean = -t.stress.trace() / 3.0;
    assert!((mean - pressure).abs() < 1e-9 * pressure);
    let affine = CubicProjection::from_stiffness(
        &(t.relaxed.c_affine + stress_measure_correction(&t.stress)),
    );
    let base = CubicProjection::from_stiffness(&free.c_affine);
    for (got, want) in [
        (affine.c11 - base.c11, -0.4 * pressure),
        (affine.c12 - base.c12, 1.2 * pressure),
        (affine.c44 - base.c44, -0.8 * pressure),
    ] {
        assert!(
            (got - want).abs() < 0.03 * pressure,
            "affine shift {got:.4e} Pa, closed form {want:.4e} Pa"
        );
    }
    let before = CubicProjection::from_stiffness(&free.c);
    let after = CubicProjection::from_stiffness(&((t.c + t.c.transpose()) * 0.5));
    assert!(before.c12 < before.c44);
    assert!(after.c12 > after.c44, "C12 {} C44 {}", after.c12, after.c44);
}

/// A compressive preload far beyond the network's stability (issue 33's refinement of the
/// relaxed CG's sign test): the relaxed tangent is refused as buckling (`Error::Degenerate`),
/// not taken for rounding. The geometric stiffness −N/l (I − nn) of a bond under a compressive
/// axial force N exceeds the transverse stiffness of its springs when N/l ≳ k_s, which an
/// isotropic pressure reaches at p of the order of the springs' C11 (N/l ≈ 0.6 k_n p/C11 for
/// isotropic bond directions): the preload is raised from half of C11 by doubling until refused.
#[test]
fn a_preload_beyond_stability_is_refused_as_buckling() {
    use anisobond::assembly::Assembly;
    use anisobond::model::Model;
    use anisobond::packing::{generate, GenerateOptions};
    use anisobond::tensor::CubicProjection;
    use anisobond::Error;
    let opts = GenerateOptions {
        n_particles: 800,
        solid_fraction: 0.60,
        mean_radius: 1e-3,
        seed: 5,
        ..Default::default()
    };
    let a = Assembly::new(generate(&opts, &|_| {}).unwrap(), Model::truszkowska_mrv()).unwrap();
    let ro = RelaxedOptions::default();
    let free = relaxed_tensor(&a.packing, &a.bonds, &a.springs, &ro).unwrap();
    let c11 = CubicProjection::from_stiffness(&free.c).c11;
    let mut refused = None;
    for factor in [0.5, 1.0, 2.0, 4.0, 8.0] {
        let pre =
            Prestress::isotropic(&a.packing, &a.bonds, &a.springs, factor * c11, &ro).unwrap();
        match prestressed_tensor(&a.packing, &a.bonds, &a.springs, &pre, &ro) {
            Ok(_) => continue,
            Err(e) => {
                refused = Some((factor, e));
                break;
            }
        }
    }
    match refused {
        Some((_, Error::Degenerate(m))) => assert!(m.contains("buckles"), "{m}"),
        other => panic!("expected buckling under a preload up to 8 C11, got {other:?}"),
    }
}
