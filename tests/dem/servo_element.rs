//! Stress-controlled (servo) element tests of Šmilauer in the integrator against
//! the exact relaxed tensor of the same bonded packing (`relaxed_tensor`, LeverArm::MidGap =
//! YADE's contact point): the uniaxial tests under zero lateral stress must give
//! E_i = 1/S_ii and ν_ij = −S_ij·E_i of the relaxed S = C⁻¹, the shears C_44…, and the
//! stiffness built from them the same as built from the relaxed tensor.

use crate::common::bonded::{relaxed_exact, yade_sim};
use anisobond::bonds::lattice_scaling;
use anisobond::bonds::{assign_stiffness, build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::dem::{
    expected_test_constants, stiffness_from_tests, stress_controlled_tensor,
    transversely_isotropic, StressTestOptions,
};
use anisobond::dem::{servo_until_converged, ComponentControl, ServoOptions, StressServo};
use anisobond::packing::Packing;
use anisobond::packing::{generate, GenerateOptions, Polydispersity};
use anisobond::schemes::CrossAnisotropic;
use anisobond::schemes::Isotropic;
use anisobond::schemes::{Convention, Geometry, StiffnessScheme};
use anisobond::tensor::{relative_difference, Stiffness6};
use anisobond::Vec3;

fn packing(n: usize, solid_fraction: f64, radius: f64, seed: u64) -> Packing {
    generate(
        &GenerateOptions {
            n_particles: n,
            solid_fraction,
            mean_radius: radius,
            polydispersity: Polydispersity::Monodisperse,
            seed,
            ..Default::default()
        },
        &|_| {},
    )
    .unwrap()
}

/// 400 spheres (solid fraction 0.6, R̄ = 1 mm, seed 11) bonded within a gap of 0.3 R̄ by
/// isotropic springs k_n = 1e6, k_s = 0.4e6 N/m, and their exact relaxed tensor.
fn isotropic_block() -> (Packing, BondSet, BondStiffness, Stiffness6) {
    let p = packing(400, 0.6, 1e-3, 11);
    let b = build_bonds(&p, BondingRule::Gap(0.3)).unwrap();
    let geometry = Geometry {
        convention: Convention::Spring,
        ..Default::default()
    };
    let k = assign_stiffness(&p, &b, &Isotropic::new(1e6, 0.4e6).unwrap(), &geometry).unwrap();
    let c = relaxed_exact(&p, &b, &k).c;
    (p, b, k, c)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// (a) Isotropic springs on a few hundred spheres: E, ν and G of the servo tests against
/// the relaxed tensor's, lateral stresses below t_r·axial.
#[test]
fn uniaxial_servo_tests_match_the_relaxed_tensor_isotropic() {
    let (p, b, k, c) = isotropic_block();
    let (young, poisson, shear) = expected_test_constants(&c).unwrap();
    let s = yade_sim(&p, &b, &k, None);
    let t_r = 1e-4;
    let opts = StressTestOptions {
        servo: ServoOptions {
            stress_tolerance: t_r,
            ..Default::default()
        },
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let r = stress_controlled_tensor(&s, &opts, &|_| {}).unwrap();
    let steps: Vec<usize> = r
        .uniaxial
        .iter()
        .map(|u| u.outcome.steps)
        .chain(r.shear.iter().map(|g| g.outcome.steps))
        .collect();
    println!(
        "{} spheres, {} bonds: steps {steps:?}, {:.1} s",
        p.len(),
        b.len(),
        t0.elapsed().as_secs_f64()
    );
    for u in &r.uniaxial {
        let a = u.axis;
        println!(
            "axis {a}: E {:.6e} vs relaxed {:.6e}; ν {:?} vs {:?}; lateral/axial {:.2e}",
            u.young,
            young[a],
            u.poisson,
            [poisson[(a, 0)], poisson[(a, 1)], poisson[(a, 2)]],
            u.outcome.relative_stress_error
        );
        assert!(rel(u.young, young[a]) < 1e-3, "E_{a}");
        for j in 0..3 {
            if j != a {
                assert!(
                    rel(u.poisson[j], poisson[(a, j)]) < 1e-3,
                    "ν_{a}{j}: {} vs {}",
                    u.poisson[j],
                    poisson[(a, j)]
                );
            }
        }
        // Every non-axial stress component below t_r·|σ_axial|, the axial strain exact.
        let axial = u.outcome.stress[a].abs();
        for q in 0..6 {
            if q != a {
                assert!(u.outcome.stress[q].abs() <= t_r * axial, "σ_{q}");
            }
        }
        assert!(rel(u.outcome.strain[a], opts.strain) < 1e-8);
    }
    for g in &r.shear {
        let q = g.component;
        println!(
            "G_{q}: {:.6e} vs relaxed C_{q}{q} {:.6e}",
            g.modulus,
            shear[q - 3]
        );
        assert!(rel(g.modulus, shear[q - 3]) < 1e-3, "G {q}");
    }
    // The relaxation matters on this packing (else the test could not tell).
    let affine = StressServo::new(
        &s,
        [ComponentControl::Strain(0.0); 6],
        &ServoOptions::default(),
    )
    .unwrap()
    .stiffness()
    .to_owned();
    assert!(relative_difference(&affine, &c) > 0.05);
}

/// (b) Šmilauer's cross-anisotropic scheme (target 130, 55, 28, 40 MPa about z) on a small
/// I_R = 1.8 packing: the servo converges and the recovered stiffness equals the one built
/// the same way from the relaxed tensor.
#[test]
fn cross_anisotropic_servo_tests_match_the_relaxed_tensor() {
    let p = packing(300, 0.5, 0.03, 5);
    let b = build_bonds(&p, BondingRule::Factor(1.8)).unwrap();
    let geometry = Geometry {
        convention: Convention::Modulus,
        ..Default::default()
    };
    let mu = lattice_scaling(&p, &b, geometry.pi_hat).unwrap();
    let scheme = CrossAnisotropic::from_target(130e6, 55e6, 28e6, 40e6, Vec3::z(), mu).unwrap();
    let k = assign_stiffness(&p, &b, &scheme as &dyn StiffnessScheme, &geometry).unwrap();
    let c = relaxed_exact(&p, &b, &k).c;
    let (young, poisson, shear) = expected_test_constants(&c).unwrap();
    let (c_orth_expected, ti_expected, _) = stiffness_from_tests(young, &poisson, shear).unwrap();
    let s = yade_sim(&p, &b, &k, None);
    let t0 = std::time::Instant::now();
    let opts = StressTestOptions {
        servo: ServoOptions {
            stress_tolerance: 1e-4,
            ..Default::default()
        },
        ..Default::default()
    };
    let r = stress_controlled_tensor(&s, &opts, &|_| {}).unwrap();
    let d_orth = relative_difference(&r.c_orthotropic, &c_orth_expected);
    let d_ti = relative_difference(&r.c_cross_anisotropic, &transversely_isotropic(ti_expected));
    println!(
        "{} spheres, Z = {:.1}, μ = {mu:.3}: orthotropic C vs relaxed-derived {d_orth:.2e}, \
         TI {d_ti:.2e}, orthotropic C vs relaxed C itself {:.2e}; TI (C11,C12,C13,C33,C44) \
         {:?} MPa; {:.1} s",
        p.len(),
        b.coordination(p.len()),
        relative_difference(&r.c_orthotropic, &c),
        r.cross_anisotropic.map(|x| x / 1e6),
        t0.elapsed().as_secs_f64()
    );
    for u in &r.uniaxial {
        assert!(u.outcome.relative_stress_error <= 1e-4);
    }
    assert!(d_orth < 1e-3, "orthotropic {d_orth:.3e}");
    assert!(d_ti < 1e-3, "transversely isotropic {d_ti:.3e}");
    // z is the soft axis of this target: E_z well below E_x.
    assert!(r.uniaxial[2].young < 0.6 * r.uniaxial[0].young);
}

/// Closed form: the six tests on an exact transversely isotropic tensor return it, through
/// both the orthotropic and the cross-anisotropic inversion.
#[test]
fn engineering_constants_of_an_exact_transversely_isotropic_tensor_invert_back() {
    let t = [130e6, 40e6, 28e6, 55e6, 32.2e6];
    let c = transversely_isotropic(t);
    let (young, poisson, shear) = expected_test_constants(&c).unwrap();
    // ν_xz/E_x = ν_zx/E_z (symmetric compliance).
    assert!(rel(poisson[(0, 2)] / young[0], poisson[(2, 0)] / young[2]) < 1e-12);
    let (orth, ti, mismatch) = stiffness_from_tests(young, &poisson, shear).unwrap();
    assert!(mismatch < 1e-12);
    assert!(relative_difference(&orth, &c) < 1e-12);
    for (a, b) in ti.iter().zip(t) {
        assert!(rel(*a, b) < 1e-12, "{a} vs {b}");
    }
    // Negative modulus is refused.
    assert!(stiffness_from_tests([-1.0, 1.0, 1.0], &poisson, shear).is_err());
}

/// (c) Bit-identical servo runs on 1 and 2 threads (more than one particle chunk).
#[test]
fn servo_is_bit_identical_on_one_and_two_threads() {
    let p = packing(1500, 0.6, 1e-3, 3);
    let b = build_bonds(&p, BondingRule::Gap(0.2)).unwrap();
    let geometry = Geometry {
        convention: Convention::Spring,
        ..Default::default()
    };
    let k = assign_stiffness(&p, &b, &Isotropic::new(1e6, 0.4e6).unwrap(), &geometry).unwrap();
    let run = |threads: usize| {
        crate::common::on_threads(threads, || {
            let mut s = yade_sim(&p, &b, &k, None);
            s.set_local_damping(0.4).unwrap();
            let mut controls = [ComponentControl::Stress(0.0); 6];
            controls[2] = ComponentControl::Strain(-1e-5);
            let servo = StressServo::new(&s, controls, &ServoOptions::default()).unwrap();
            // A step limit too short for convergence is an error naming the residuals.
            let short = ServoOptions {
                max_steps: 50,
                ..Default::default()
            };
            let err =
                servo_until_converged(&mut s.clone(), &servo, &short, &mut |_| {}).unwrap_err();
            assert!(
                err.to_string().contains("did not converge in 50 steps"),
                "{err}"
            );
            let out = servo_until_converged(&mut s, &servo, &ServoOptions::default(), &mut |_| {})
                .unwrap();
            (out, s.particles.position.clone())
        })
    };
    let one = run(1);
    let two = run(2);
    println!("1500 spheres: converged in {} steps", one.0.steps);
    assert_eq!(one.0, two.0);
    assert_eq!(one.1, two.1);
}

/// Every component stress-controlled toward a general target stress: the final strain is
/// S·σ* with the relaxed compliance S = C⁻¹ (a closed form of the relaxed tensor).
#[test]
fn full_stress_control_reaches_the_compliance_strain() {
    let (p, b, k, c) = isotropic_block();
    let target = anisobond::tensor::Voigt6::new(-1000.0, -2000.0, -500.0, 300.0, -200.0, 100.0);
    let want = c.try_inverse().unwrap() * target;
    for gain in [0.5, 1.0, 0.2] {
        let mut s = yade_sim(&p, &b, &k, None);
        s.set_local_damping(0.4).unwrap();
        let controls = std::array::from_fn(|q| ComponentControl::Stress(target[q]));
        let opts = ServoOptions {
            gain,
            stress_tolerance: 1e-5,
            ..Default::default()
        };
        let servo = StressServo::new(&s, controls, &opts).unwrap();
        let out = servo_until_converged(&mut s, &servo, &opts, &mut |_| {}).unwrap();
        let err = (out.strain - want).norm() / want.norm();
        println!(
            "full stress control, gain {gain}: {} steps, strain error {err:.2e} vs S·σ*, \
             stress error {:.2e}",
            out.steps, out.relative_stress_error
        );
        assert!(out.relative_stress_error <= 1e-5);
        assert!(err < 1e-3, "strain {:?} vs {:?}", out.strain, want);
    }
}

/// Bad input gives clear errors, not panics.
#[test]
fn servo_refuses_bad_input() {
    let p = packing(200, 0.6, 1e-3, 2);
    let b = build_bonds(&p, BondingRule::Gap(0.3)).unwrap();
    let geometry = Geometry {
        convention: Convention::Spring,
        ..Default::default()
    };
    let k = assign_stiffness(&p, &b, &Isotropic::new(1e6, 0.4e6).unwrap(), &geometry).unwrap();
    let mut s = yade_sim(&p, &b, &k, None);
    let free = [ComponentControl::Stress(0.0); 6];
    for gain in [0.0, 1.5, f64::NAN] {
        let o = ServoOptions {
            gain,
            ..Default::default()
        };
        assert!(StressServo::new(&s, free, &o).is_err());
    }
    let mut nan = free;
    nan[1] = ComponentControl::Strain(f64::NAN);
    assert!(StressServo::new(&s, nan, &ServoOptions::default()).is_err());
    let mut rate = free;
    rate[0] = ComponentControl::StrainRate(1.0);
    let servo = StressServo::new(&s, rate, &ServoOptions::default()).unwrap();
    let e = servo_until_converged(&mut s, &servo, &ServoOptions::default(), &mut |_| {});
    assert!(e.unwrap_err().to_string().contains("strain rate"));
    // Zero springs: no resistance to the controlled strains.
    let zero = BondStiffness {
        kn: vec![0.0; b.len()],
        ks: vec![0.0; b.len()],
        ..k.clone()
    };
    let soft = Simulation::new(
        &p,
        &b,
        build_law(LawKind::Yade, &p, &b, &zero).unwrap(),
        &DemOptions {
            time_step: Some(1e-6),
            ..Default::default()
        },
    )
    .unwrap();
    let e = StressServo::new(&soft, free, &ServoOptions::default()).unwrap_err();
    assert!(e.to_string().contains("singular"), "{e}");
    // A free (non-periodic) assembly has no cell to control.
    let mut fp = p.clone();
    fp.cell = None;
    let fb = build_bonds(&fp, BondingRule::Gap(0.3)).unwrap();
    let fk = assign_stiffness(&fp, &fb, &Isotropic::new(1e6, 0.4e6).unwrap(), &geometry).unwrap();
    let fsim = yade_sim(&fp, &fb, &fk, None);
    assert!(StressServo::new(&fsim, free, &ServoOptions::default()).is_err());
    assert!(stress_controlled_tensor(&fsim, &StressTestOptions::default(), &|_| {}).is_err());
    let bad = StressTestOptions {
        strain: 0.0,
        ..Default::default()
    };
    assert!(stress_controlled_tensor(&s, &bad, &|_| {}).is_err());
}
