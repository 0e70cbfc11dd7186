//! Two-particle closed forms for every law (normal, shear, bending, twisting), the energy
//! band of undamped runs and its O(dt²) scaling, bit-identical histories on 1 and 2 threads,
//! weakly bonded particles, the blow-up error, and the relaxation speed of the element tests.

use crate::common::bonded::periodic_bonded;
use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::dem::Quat;
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::dem::{path_gradient, relax_path, ElementTestOptions};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::Vec3;

fn pair(kind: LawKind, kn: f64, ks: f64, kr: f64, ktw: f64) -> (Simulation, f64) {
    // Two spheres along x with a gap (stress-free at the start).
    let (r1, r2) = (1.0e-3, 1.2e-3);
    let d = r1 + r2 + 0.2e-3;
    let p = Packing::new(
        vec![Vec3::zeros(), Vec3::new(d, 0.0, 0.0)],
        vec![r1, r2],
        None,
    )
    .unwrap();
    let mut b = BondSet::default();
    b.push(0, 1, Vec3::new(d, 0.0, 0.0), [0, 0, 0]);
    let k = BondStiffness {
        radius: vec![r1],
        kn: vec![kn],
        ks: vec![ks],
        kr: vec![kr],
        ktw: vec![ktw],
    };
    let law = build_law(kind, &p, &b, &k).unwrap();
    // Huge masses: the bond forces barely accelerate the spheres, so the prescribed
    // velocities (re-imposed every step) are the motion.
    let opts = DemOptions {
        time_step: Some(1e-9),
        mass: anisobond::dem::MassOptions {
            density: 2600.0,
            scaling: 1e12,
        },
        ..Default::default()
    };
    let sim = Simulation::new(&p, &b, law, &opts).unwrap();
    (sim, d)
}

/// Prescribe a small quasi-static relative motion of particle 1 over many tiny steps (its
/// velocity reset every step so it follows the path) and compare with the closed form.
fn drive(sim: &mut Simulation, v1: Vec3, w1: Vec3, steps: usize) {
    for _ in 0..steps {
        sim.particles.velocity[0] = Vec3::zeros();
        sim.particles.angular_velocity[0] = Vec3::zeros();
        sim.particles.velocity[1] = v1;
        sim.particles.angular_velocity[1] = w1;
        sim.step().unwrap();
    }
}

#[test]
fn two_particle_closed_forms_all_laws() {
    let (kn, ks) = (2.0e6, 0.8e6);
    let (r1, r2) = (1.0e-3, 1.2e-3);
    let (dt, steps) = (1e-9, 1000);
    let t = dt * steps as f64;
    for kind in [LawKind::Yade, LawKind::ParallelBond, LawKind::Kumar] {
        // Rotational springs the law uses (parallel bond: k̄_n I, k̄_s J with R_b = r1;
        // Kumar: k_n R*², 2 k_s R*²; YADE: as given).
        let r_star = r1 * r2 / (r1 + r2);
        let (kr, ktw) = match kind {
            LawKind::Yade | LawKind::LammpsBpm => (0.3, 0.2),
            LawKind::ParallelBond => (kn * r1 * r1 / 4.0, ks * r1 * r1 / 2.0),
            LawKind::Kumar => (kn * r_star * r_star, 2.0 * ks * r_star * r_star),
        };
        // Normal: stretch by u → force k_n u pulling i toward j (+x on particle 0).
        let (mut sim, _) = pair(kind, kn, ks, 0.3, 0.2);
        // The force of step n sees the positions after n − 1 updates; incremental quantities
        // (shear, incremental moments) have received n increments.
        let t_pos = dt * (steps - 1) as f64;
        let u = 1e-3 * t_pos; // v = 1e-3 m/s
        drive(&mut sim, Vec3::new(1e-3, 0.0, 0.0), Vec3::zeros(), steps);
        let f0 = sim.force[0];
        // Kumar's viscous normal damping adds η_n·v (Eqs. 5–6).
        let (eta_n, eta_t) = sim.law().viscosity(0);
        let fn_expected = kn * u + eta_n * 1e-3;
        assert!(
            (f0.x - fn_expected).abs() < 1e-6 * fn_expected,
            "{kind:?} normal: {} vs {}",
            f0.x,
            fn_expected
        );
        assert!(f0.y.abs() + f0.z.abs() < 1e-12 * fn_expected);
        // Shear: translate j by w along y → the normal turns; the shear force follows the
        // contact; for small w the force on i is ≈ k_s w ŷ plus the normal part.
        let (mut sim, d) = pair(kind, kn, ks, 0.3, 0.2);
        let w = 1e-3 * t;
        drive(&mut sim, Vec3::new(0.0, 1e-3, 0.0), Vec3::zeros(), steps);
        let fy = sim.force[0].y;
        let expect = ks * w + eta_t * 1e-3;
        assert!(
            (fy - expect).abs() < 2e-3 * expect,
            "{kind:?} shear: {fy} vs {expect}"
        );
        // Torque on i from the shear force at the mid-gap contact point: r_i' = r1 + gap/2.
        let arm = r1 + 0.5 * (d - r1 - r2);
        let tz = sim.torque[0].z;
        assert!(
            (tz - arm * fy).abs() < 2e-3 * (arm * fy).abs(),
            "{kind:?} shear torque {tz} vs {}",
            arm * fy
        );
        // Bending: rotate j about z by θ → moment k_r θ on i (about +z) and −k_r θ on j.
        let (mut sim, _) = pair(kind, kn, 0.0, 0.3, 0.2);
        let omega = 10.0;
        let theta = if kind == LawKind::Yade {
            omega * t_pos
        } else {
            omega * t
        };
        drive(&mut sim, Vec3::zeros(), Vec3::new(0.0, 0.0, omega), steps);
        let expect = kr * theta;
        // With k_s = 0 the torques are the moment alone (plus Kumar's twist damping = 0 here).
        assert!(
            (sim.torque[0].z - expect).abs() < 1e-6 * expect,
            "{kind:?} bending {} vs {expect}",
            sim.torque[0].z
        );
        assert!((sim.torque[1].z + expect).abs() < 1e-6 * expect);
        // Twisting: rotate j about the bond axis x by θ → moment k_tw θ (the contact point
        // does not slide, so k_s adds nothing).
        let (mut sim, _) = pair(kind, kn, ks, 0.3, 0.2);
        drive(&mut sim, Vec3::zeros(), Vec3::new(omega, 0.0, 0.0), steps);
        let expect = ktw * theta;
        assert!(
            (sim.torque[0].x - expect).abs() < 1e-6 * expect,
            "{kind:?} twist {} vs {expect}",
            sim.torque[0].x
        );
        assert!((sim.torque[1].x + expect).abs() < 1e-6 * expect);
        // The orientation integrator: a constant spin for time t turns by ω t exactly.
        let q: Quat = sim.particles.orientation[1];
        assert!((q.rotation_vector().x - omega * t).abs() < 1e-12);
    }
}

/// Kick every particle with a random velocity and record the total energy band.
fn energy_band(dt_factor: f64, steps: usize) -> (f64, f64) {
    let (p, b, k) = periodic_bonded(300, 3);
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let mut sim = Simulation::new(&p, &b, law, &DemOptions::default()).unwrap();
    let dt = sim.time_step() * dt_factor;
    sim.set_time_step(dt).unwrap();
    for (i, v) in sim.particles.velocity.iter_mut().enumerate() {
        let s = (i as f64 * 0.7).sin();
        *v = Vec3::new(s, (i as f64 * 1.3).cos(), (i as f64 * 2.1).sin()) * 1e-3;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut e0 = 0.0;
    // Same physical time for both time steps.
    for s in 0..steps {
        sim.step().unwrap();
        let e = sim.energies().mechanical();
        if s == 0 {
            e0 = e;
        }
        lo = lo.min(e);
        hi = hi.max(e);
    }
    ((hi - lo) / e0, e0)
}

#[test]
fn undamped_energy_band_shrinks_as_dt_squared() {
    let steps = 20_000;
    let (band1, e1) = energy_band(0.5, steps);
    let (band2, e2) = energy_band(0.25, 2 * steps);
    println!(
        "energy band: dt {band1:.3e}, dt/2 {band2:.3e}, ratio {:.2}",
        band1 / band2
    );
    assert!((e1 - e2).abs() < 1e-2 * e1);
    assert!(band1 < 5e-2, "energy not conserved: band {band1:.3e}");
    let ratio = band1 / band2;
    assert!(
        ratio > 3.0 && ratio < 5.5,
        "band ratio {ratio:.2} is not ≈ 4 (O(dt²))"
    );
}

#[test]
fn one_and_two_threads_give_identical_histories() {
    let (p, b, k) = periodic_bonded(600, 5);
    let history = |threads: usize| {
        crate::common::on_threads(threads, || {
            let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
            let mut sim = Simulation::new(
                &p,
                &b,
                law,
                &DemOptions {
                    local_damping: 0.3,
                    ..Default::default()
                },
            )
            .unwrap();
            let g = path_gradient(3, 1e-4);
            sim.set_velocity_gradient(g / sim.time_step()).unwrap();
            let mut out = Vec::new();
            for s in 0..300 {
                sim.step().unwrap();
                if s == 0 {
                    sim.set_velocity_gradient(anisobond::Mat3::zeros()).unwrap();
                }
                let st = sim.stress();
                let e = sim.energies();
                out.push((
                    st.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    e.kinetic.to_bits(),
                    e.elastic.to_bits(),
                    e.local_damping.to_bits(),
                ));
            }
            (
                out,
                sim.particles
                    .position
                    .iter()
                    .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
                    .collect::<Vec<_>>(),
            )
        })
    };
    let a = history(1);
    let b2 = history(2);
    assert!(a == b2, "histories differ between 1 and 2 threads");
}

#[test]
fn weakly_bonded_particles_are_reported_and_stay_bounded() {
    // A chain: particle 0 has one bond, 1 has two, plus a free particle 3.
    let cell = PeriodicCell::new(Vec3::new(0.02, 0.02, 0.02)).unwrap();
    let p = Packing::new(
        vec![
            Vec3::new(0.002, 0.01, 0.01),
            Vec3::new(0.0041, 0.0102, 0.01),
            Vec3::new(0.0062, 0.0101, 0.0101),
            Vec3::new(0.015, 0.015, 0.015),
        ],
        vec![1e-3; 4],
        Some(cell),
    )
    .unwrap();
    let mut b = BondSet::default();
    b.push(0, 1, p.positions[1] - p.positions[0], [0, 0, 0]);
    b.push(1, 2, p.positions[2] - p.positions[1], [0, 0, 0]);
    let k = BondStiffness {
        radius: vec![1e-3; 2],
        kn: vec![1e6; 2],
        ks: vec![0.5e6; 2],
        kr: vec![0.0; 2],
        ktw: vec![0.0; 2],
    };
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let mut sim = Simulation::new(
        &p,
        &b,
        law,
        &DemOptions {
            local_damping: 0.4,
            ..Default::default()
        },
    )
    .unwrap();
    let st = sim.stability().clone();
    assert_eq!(st.one_bond_particles, vec![0, 2]);
    assert_eq!(st.two_bond_particles, vec![1]);
    assert_eq!(st.unbonded_particles, vec![3]);
    sim.particles.angular_velocity[1] = Vec3::new(100.0, 0.0, 0.0);
    sim.particles.velocity[0] = Vec3::new(0.0, 0.01, 0.0);
    let e0 = {
        sim.step().unwrap();
        sim.energies().mechanical()
    };
    sim.run(20_000, &|_| {}).unwrap();
    assert!(sim.energies().mechanical() <= e0 * (1.0 + 1e-9));
    assert!(sim
        .particles
        .position
        .iter()
        .all(|x| x.iter().all(|c| c.is_finite())));
}

#[test]
fn too_large_time_step_is_reported_with_the_step_to_use() {
    let (p, b, k) = periodic_bonded(200, 9);
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let mut sim = Simulation::new(&p, &b, law, &DemOptions::default()).unwrap();
    let crit = sim.stability().critical_time_step;
    sim.set_time_step(crit * 5.0).unwrap();
    sim.particles.velocity[0] = Vec3::new(1e-3, 0.0, 0.0);
    let err = sim.run(5000, &|_| {}).unwrap_err().to_string();
    assert!(
        err.contains("blew up") && err.contains(&format!("{:.4e}", 0.8 * crit)),
        "{err}"
    );
}

#[test]
fn element_test_relaxation_speed() {
    // YADE (strain in one step, damping 0.4): 1 % in ~20 steps, 0.1 % in ~40 per path.
    let (p, b, k) = periodic_bonded(1000, 11);
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let sim0 = Simulation::new(&p, &b, law, &DemOptions::default()).unwrap();
    let opts = ElementTestOptions {
        history_every: 1,
        tolerance: 1e-8,
        ..Default::default()
    };
    let mut worst = (0usize, 0usize);
    for path in 0..6 {
        let mut sim = sim0.clone();
        let r = relax_path(
            &mut sim,
            path,
            &path_gradient(path, 1e-5),
            &opts,
            &mut |_| {},
        )
        .unwrap();
        let fin = r.stress.norm();
        let settle = |tol: f64| {
            let last_bad = r
                .history
                .iter()
                .rposition(|h| (h.stress - r.stress).norm() > tol * fin);
            last_bad.map_or(0, |k| r.history[k].step as usize)
        };
        let (s1, s01) = (settle(1e-2), settle(1e-3));
        println!("path {path}: within 1 % after {s1} steps, within 0.1 % after {s01} steps");
        worst = (worst.0.max(s1), worst.1.max(s01));
    }
    assert!(
        worst.0 <= 60 && worst.1 <= 120,
        "relaxation too slow: {worst:?}"
    );
}
