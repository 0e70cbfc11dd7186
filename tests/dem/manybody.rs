//! The many-body term in the integrator (issue 33, docs/manybody.md "Integrator"): the
//! element tests of simple-cubic and FCC lattices with the term against their closed forms
//! plus D; the undamped energy band with the term (its energy in the ledger) shrinking as
//! dt²; momentum conserved and the same bits on one and two threads; the allocation-free
//! evaluation against `ManyBody::evaluate` bit for bit; refusals (small strain, breakage,
//! another state).

use crate::common::bonded::{gap_bonded, periodic_bonded};
use crate::common::lattice::{fcc_bonded, simple_cubic_bonded, uniform_springs};
use crate::common::on_threads;
use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::dem::{
    build_law, dynamic_tensor, path_gradient, BondCriteria, BondCriterion, DemOptions,
    ElementTestOptions, LawKind, Simulation,
};
use anisobond::manybody::{
    DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions, StrainMeasure,
};
use anisobond::packing::Packing;
use anisobond::strength::criteria::{YadeAdhesion, YadeMoments};
use anisobond::tensor::{relative_difference, Stiffness6};
use anisobond::{Error, Mat3, Vec3};

/// The cubic Voigt matrix of (c11, c12, c44), written out.
fn cubic(c11: f64, c12: f64, c44: f64) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for a in 0..3 {
        for b in 0..3 {
            c[(a, b)] = if a == b { c11 } else { c12 };
        }
        c[(a + 3, a + 3)] = c44;
    }
    c
}

/// The term of `d` on `p`, `b` (Green–Lagrange unless `measure` says otherwise), degenerate
/// particles excluded.
fn term(p: &Packing, b: &BondSet, d: &LocalTensor, measure: StrainMeasure) -> ManyBody {
    ManyBody::new(
        p,
        b,
        d,
        &ManyBodyOptions {
            measure,
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        },
    )
    .unwrap()
}

/// The integrator with YADE's law on `k` and the term `mb`.
fn sim_with(
    p: &Packing,
    b: &BondSet,
    k: &BondStiffness,
    mb: Option<ManyBody>,
    opts: &DemOptions,
) -> anisobond::Result<Simulation> {
    let law = build_law(LawKind::Yade, p, b, k).unwrap();
    Simulation::with_manybody(p, b, law, mb, opts)
}

/// Simple-cubic and FCC lattices (touching spheres, k_n, k_t, no moment springs) with the
/// term: the integrator's six element tests give the lattice's closed form plus D within
/// 0.5 % (SC: C11 = k_n/2R, C12 = 0, C44 = k_t/4R; FCC: C11 = (k_n + k_t)/√2R,
/// C12 = (k_n − k_t)/2√2R, C44 = (k_n + k_t)/2√2R). D is volumetric-plus-shear on SC and
/// cubic with D12 > D44 on FCC, so both totals lie beyond the Cauchy line C12 = C44.
#[test]
fn lattice_element_tests_give_the_closed_form_plus_d() {
    let r = 1e-3;
    let (kn, kt) = (2.0e6, 0.7e6);
    let s2r = std::f64::consts::SQRT_2 * r;
    // SC: isotropic D, K = 1e9, G = 0.2e9 (C11 = K + 4G/3, C12 = K − 2G/3, C44 = G).
    let (kb, g) = (1.0e9, 0.2e9);
    // FCC: cubic D in the crystal frame (= lab).
    let (d11, d12, d44) = (1.5e9, 1.1e9, 0.3e9);
    let cases = [
        (
            "SC",
            simple_cubic_bonded(r),
            cubic(kn / (2.0 * r), 0.0, kt / (4.0 * r)),
            LocalTensor::Isotropic { bulk: kb, shear: g },
            cubic(kb + 4.0 * g / 3.0, kb - 2.0 * g / 3.0, g),
        ),
        (
            "FCC",
            fcc_bonded(r),
            cubic(
                (kn + kt) / s2r,
                (kn - kt) / (2.0 * s2r),
                (kn + kt) / (2.0 * s2r),
            ),
            LocalTensor::Cubic {
                c11: d11,
                c12: d12,
                c44: d44,
                rotation: Mat3::identity(),
            },
            cubic(d11, d12, d44),
        ),
    ];
    for (name, (p, b), c_lattice, d, d_closed) in cases {
        let k = uniform_springs(b.len(), kn, kt, 0.0, 0.0);
        let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
        assert!(mb.excluded().is_empty());
        let sim = sim_with(&p, &b, &k, Some(mb), &DemOptions::default()).unwrap();
        let plain = sim_with(&p, &b, &k, None, &DemOptions::default()).unwrap();
        // The term stiffens the assembly: the Gershgorin bound of the critical step shrinks.
        assert!(sim.stability().critical_time_step < plain.stability().critical_time_step);
        let dynamic = dynamic_tensor(&sim, &ElementTestOptions::default(), &|_| {}).unwrap();
        let expect = c_lattice + d_closed;
        let err = relative_difference(&dynamic.c, &expect);
        // Without the term the same tests give the lattice alone (the term is what moved it).
        let alone = dynamic_tensor(&plain, &ElementTestOptions::default(), &|_| {}).unwrap();
        let err_alone = relative_difference(&alone.c, &c_lattice);
        println!(
            "{name}: element tests with the term vs C_lattice + D {err:.2e}; without the term vs \
             C_lattice {err_alone:.2e}; C12 − C44 = {:.3e} Pa",
            dynamic.c[(0, 1)] - dynamic.c[(3, 3)]
        );
        assert!(err < 5e-3, "{name}: {err:.3e}");
        assert!(err_alone < 5e-3, "{name} alone: {err_alone:.3e}");
        assert!(
            dynamic.c[(0, 1)] > dynamic.c[(3, 3)],
            "{name}: beyond Cauchy"
        );
    }
}

/// A D comparable to the springs' Voigt tensor (its mean C11), rotated cubic with
/// D12 > D44.
fn comparable_d(b: &BondSet, k: &BondStiffness, p: &Packing) -> LocalTensor {
    let c = anisobond::homogenize::voigt_tensor(b, k, p.volume());
    let s = (c[(0, 0)] + c[(1, 1)] + c[(2, 2)]) / 3.0;
    LocalTensor::Cubic {
        c11: 0.8 * s,
        c12: 0.5 * s,
        c44: 0.2 * s,
        rotation: anisobond::tensor::rotation_z(0.3) * anisobond::tensor::rotation_x(1.1),
    }
}

/// Kick every particle (zero total momentum) and run undamped: the band of the
/// mechanical energy (kinetic + bonds + term) relative to its start, the largest share of
/// the term in it, and the largest |Σ m v| relative to Σ m |v|.
fn energy_band(dt_factor: f64, steps: usize) -> (f64, f64, f64) {
    let (p, b, k) = periodic_bonded(300, 3);
    let mb = term(
        &p,
        &b,
        &comparable_d(&b, &k, &p),
        StrainMeasure::GreenLagrange,
    );
    let mut sim = sim_with(&p, &b, &k, Some(mb), &DemOptions::default()).unwrap();
    let dt = sim.time_step() * dt_factor;
    sim.set_time_step(dt).unwrap();
    let n = sim.particles.len();
    let mut kick: Vec<Vec3> = (0..n)
        .map(|i| {
            let s = (i as f64 * 0.7).sin();
            Vec3::new(s, (i as f64 * 1.3).cos(), (i as f64 * 2.1).sin()) * 1e-3
        })
        .collect();
    let mass: f64 = sim.particles.mass.iter().sum();
    let mean = kick
        .iter()
        .zip(&sim.particles.mass)
        .fold(Vec3::zeros(), |a, (v, m)| a + v * *m)
        / mass;
    for v in &mut kick {
        *v -= mean;
    }
    sim.particles.velocity = kick;
    let (mut lo, mut hi, mut share, mut drift) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0);
    let mut e0 = 0.0;
    for s in 0..steps {
        sim.step().unwrap();
        let e = sim.energies();
        let m = e.mechanical();
        if s == 0 {
            e0 = m;
        }
        lo = lo.min(m);
        hi = hi.max(m);
        share = f64::max(share, e.manybody / m);
        let pp = &sim.particles;
        let (mom, scale) = pp
            .velocity
            .iter()
            .zip(&pp.mass)
            .fold((Vec3::zeros(), 0.0), |(a, s), (v, m)| {
                (a + v * *m, s + m * v.norm())
            });
        drift = f64::max(drift, mom.norm() / scale);
    }
    ((hi - lo) / e0, share, drift)
}

/// NVE with the term: the ledger (kinetic + bonds + term) closes as for springs alone (band
/// below 5 %) and the band shrinks as dt² (forces are the exact gradient of the energy the
/// ledger counts); the term holds a real share of the energy; total momentum stays zero.
#[test]
fn undamped_energy_band_with_the_term_shrinks_as_dt_squared() {
    let steps = 20_000;
    let (band1, share1, drift1) = energy_band(0.5, steps);
    let (band2, _, drift2) = energy_band(0.25, 2 * steps);
    println!(
        "with the term: energy band dt {band1:.3e}, dt/2 {band2:.3e}, ratio {:.2}; term's \
         largest share {share1:.3}; momentum drift {:.1e}",
        band1 / band2,
        drift1.max(drift2)
    );
    assert!(
        share1 > 0.05,
        "the term holds too little energy: {share1:.3}"
    );
    assert!(band1 < 5e-2, "energy not conserved: band {band1:.3e}");
    let ratio = band1 / band2;
    assert!(
        ratio > 3.0 && ratio < 5.5,
        "band ratio {ratio:.2} is not ≈ 4 (O(dt²))"
    );
    assert!(drift1.max(drift2) < 1e-10, "momentum drift {drift1:e}");
}

/// A damped sheared history with the term: stress, energies (the term's included) and
/// positions have the same bits on one and two threads.
#[test]
fn one_and_two_threads_give_identical_histories_with_the_term() {
    let (p, b, k) = periodic_bonded(600, 5);
    let d = comparable_d(&b, &k, &p);
    let history = |threads: usize| {
        on_threads(threads, || {
            let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
            let opts = DemOptions {
                local_damping: 0.3,
                ..Default::default()
            };
            let mut sim = sim_with(&p, &b, &k, Some(mb), &opts).unwrap();
            let g = path_gradient(3, 1e-4);
            sim.set_velocity_gradient(g / sim.time_step()).unwrap();
            let mut out = Vec::new();
            for s in 0..300 {
                sim.step().unwrap();
                if s == 0 {
                    sim.set_velocity_gradient(Mat3::zeros()).unwrap();
                }
                let e = sim.energies();
                let mut row: Vec<u64> = sim.stress().iter().map(|x| x.to_bits()).collect();
                row.extend([e.kinetic, e.elastic, e.manybody, e.local_damping].map(f64::to_bits));
                out.push(row);
            }
            let x: Vec<[u64; 3]> = sim
                .particles
                .position
                .iter()
                .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
                .collect();
            (out, x, sim.energies().manybody)
        })
    };
    let one = history(1);
    let two = history(2);
    assert!(one.2 > 0.0, "the term stored no energy");
    assert!(one == two, "histories differ between 1 and 2 threads");
}

/// The allocation-free evaluation the integrator calls gives `evaluate`'s energy, forces and
/// nominal stress bit for bit, on one and two threads, at a strained, perturbed state.
#[test]
fn evaluate_into_has_the_bits_of_evaluate() {
    let (p, b, k) = periodic_bonded(400, 11);
    let mb = term(
        &p,
        &b,
        &comparable_d(&b, &k, &p),
        StrainMeasure::GreenLagrange,
    );
    let h = Mat3::identity() + Mat3::new(1.0, 0.3, -0.2, 0.3, -0.5, 0.1, -0.2, 0.1, 0.7) * 0.01;
    let x: Vec<Vec3> = p
        .positions
        .iter()
        .enumerate()
        .map(|(i, x)| h * x + Vec3::new((i as f64).sin(), (1.7 * i as f64).cos(), 0.3) * 1e-6)
        .collect();
    let branch = mb.branch_vectors(&x, &h).unwrap();
    let reference = mb.evaluate(&branch).unwrap();
    for threads in [1, 2] {
        let (energy, forces, stress) = on_threads(threads, || {
            let mut ws = mb.workspace();
            mb.evaluate_into(|b| branch[b], &mut ws);
            let mut s = Mat3::zeros();
            for (bb, lb) in mb.reference_branches().iter().enumerate() {
                s += mb.bond_gradient(bb, &ws) * lb.transpose();
            }
            // The integrator's entry (no force pass) leaves the same energy and g_b.
            let mut lean = mb.workspace();
            mb.gradients_into(|b| branch[b], &mut lean);
            assert_eq!(lean.energy().to_bits(), ws.energy().to_bits());
            assert!(
                lean.gradient == ws.gradient,
                "{threads} threads: g_b differ"
            );
            (ws.energy(), ws.force.clone(), s / p.volume())
        });
        assert_eq!(energy.to_bits(), reference.energy.to_bits());
        assert!(
            forces == reference.forces,
            "{threads} threads: forces differ"
        );
        assert!(
            stress == reference.stress,
            "{threads} threads: stress differs"
        );
    }
    assert!(reference.energy > 0.0);
}

/// Refused with [`Error::Invalid`]: the small-strain measure (not rotation invariant),
/// breakage together with the term, a term built on another state.
#[test]
fn refusals() {
    let (p, b, k) = periodic_bonded(200, 2);
    let d = comparable_d(&b, &k, &p);
    let small = term(&p, &b, &d, StrainMeasure::Small);
    match sim_with(&p, &b, &k, Some(small), &DemOptions::default()) {
        Err(Error::Invalid(m)) => assert!(m.contains("rotation invariant"), "{m}"),
        other => panic!("small strain accepted: {:?}", other.err()),
    }
    let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
    let mut sim = sim_with(&p, &b, &k, Some(mb), &DemOptions::default()).unwrap();
    let at_once = BondCriterion::Yade(YadeAdhesion {
        normal: 1.0,
        shear: 1.0,
        tan_friction: 0.0,
        cohesion_disables_friction: false,
        moments: YadeMoments::Elastic,
    });
    let criteria = BondCriteria::from_criteria(LawKind::Yade, vec![at_once; b.len()]);
    match sim.set_breakage(Some(criteria)) {
        Err(Error::Invalid(m)) => assert!(m.contains("many-body"), "{m}"),
        other => panic!("breakage with the term accepted: {other:?}"),
    }
    // A term whose reference branch vectors are 1 % longer than the packing's.
    let mut stretched_bonds = b.clone();
    for l in &mut stretched_bonds.length {
        *l *= 1.01;
    }
    let other = term(&p, &stretched_bonds, &d, StrainMeasure::GreenLagrange);
    match sim_with(&p, &b, &k, Some(other), &DemOptions::default()) {
        Err(Error::Invalid(m)) => assert!(m.contains("reference"), "{m}"),
        other => panic!("a term of another state accepted: {:?}", other.err()),
    }
}

/// A model file's `[manybody]` reaches the integrator: `Assembly::simulation` (what `run`
/// and `stress-test` use) carries the term with the table's D (written out here), and its
/// first strained step stores energy in it; the small-strain measure is refused there; the
/// gripped tests on a free block refuse the table ([`Error::Model`]) instead of leaving it out.
#[test]
fn model_files_bring_the_term_to_the_integrator() {
    use anisobond::assembly::Assembly;
    use anisobond::model::Model;
    let packing = crate::common::bonded::generated(300, 4);
    let with = |extra: &str| {
        let text = format!(
            "{}[manybody]\nkind = \"isotropic\"\nbulk = 2e12\nshear = 0.5e12\n{extra}",
            crate::common::CUBIC_MODEL
        );
        let model = Model::from_toml_str(&text, "m.toml").unwrap();
        Assembly::new(packing.clone(), model).unwrap()
    };
    let asm = with("");
    let mut sim = asm
        .simulation(LawKind::Yade, &DemOptions::default())
        .unwrap();
    let (kb, g) = (2e12, 0.5e12);
    let expect = cubic(kb + 4.0 * g / 3.0, kb - 2.0 * g / 3.0, g);
    let got = *sim.manybody().expect("the term").tensor().unwrap();
    assert!((got - expect).amax() <= 1e-9 * expect.amax());
    sim.set_velocity_gradient(path_gradient(0, 1e-5) / sim.time_step())
        .unwrap();
    for _ in 0..3 {
        sim.step().unwrap();
    }
    assert!(sim.energies().manybody > 0.0);
    match with("measure = \"small\"\n").simulation(LawKind::Yade, &DemOptions::default()) {
        Err(Error::Invalid(m)) => assert!(m.contains("rotation invariant"), "{m}"),
        other => panic!("small strain accepted: {:?}", other.err()),
    }
    let grips = asm.gripped_tests(LawKind::Yade, &Default::default(), &|_| {});
    match grips {
        Err(Error::Model(m)) => assert!(m.contains("[manybody]"), "{m}"),
        other => panic!("gripped tests ran without the term: {:?}", other.err()),
    }
}

/// A disordered periodic packing (800 spheres, gap-bonded, direction-dependent springs with
/// moments) with a rotated cubic term: the integrator's element tests give the exact relaxed
/// tensor with the term (`relaxed_tensor_with_term`, tolerance 1e-10) within 0.5 %, while
/// the affine (Voigt-level) tensor differs from it by more.
#[test]
fn disordered_element_tests_give_the_relaxed_tensor_with_the_term() {
    use anisobond::homogenize::{relaxed_tensor_with_term, RelaxedOptions};
    let (p, b) = gap_bonded(800, 7);
    let k = crate::common::bonded::directional_springs(&p, &b, true);
    let mb = term(
        &p,
        &b,
        &comparable_d(&b, &k, &p),
        StrainMeasure::GreenLagrange,
    );
    let relaxed = relaxed_tensor_with_term(
        &p,
        &b,
        &k,
        Some(&mb),
        &RelaxedOptions {
            tolerance: 1e-10,
            ..Default::default()
        },
    )
    .unwrap();
    let sim = sim_with(&p, &b, &k, Some(mb), &DemOptions::default()).unwrap();
    let opts = ElementTestOptions {
        tolerance: 1e-6,
        ..Default::default()
    };
    let dynamic = dynamic_tensor(&sim, &opts, &|_| {}).unwrap();
    let d = relative_difference(&dynamic.c, &relaxed.c);
    let da = relative_difference(&relaxed.c_affine, &relaxed.c);
    println!("disordered with the term: dynamic vs relaxed {d:.2e} (affine vs relaxed {da:.2e})");
    assert!(
        da > 0.02,
        "the test needs a packing whose relaxation matters"
    );
    assert!(d < 5e-3, "dynamic tensor differs from relaxed by {d:.3e}");
}
