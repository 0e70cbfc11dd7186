//! Prescribed-motion (grip) particles in the integrator and the time-integrated
//! measurement-sphere strain (Truszkowska 2018 Sec. 4.2).

use crate::common::bonded::gap_bonded;
use anisobond::bonds::{build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::dem::path_gradient;
use anisobond::dem::PrescribedMotion;
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::dem::{grip_motion, gripped_setup, GrippedOptions};
use anisobond::dem::{MeasureOptions, StrainIntegrator};
use anisobond::packing::Packing;
use anisobond::Vec3;

fn springs(nb: usize, r: f64) -> BondStiffness {
    BondStiffness {
        radius: vec![r; nb],
        kn: vec![1e6; nb],
        ks: vec![0.4e6; nb],
        kr: vec![1e6 * r * r / 4.0; nb],
        ktw: vec![0.4e6 * r * r / 2.0; nb],
    }
}

#[test]
fn held_particle_moves_at_its_velocity_whatever_the_bond_force() {
    let r = 1e-3;
    let p = Packing::new(
        vec![Vec3::zeros(), Vec3::new(2.0 * r, 0.0, 0.0)],
        vec![r, r],
        None,
    )
    .unwrap();
    let mut b = BondSet::default();
    b.push(0, 1, Vec3::new(2.0 * r, 0.0, 0.0), [0, 0, 0]);
    let law = build_law(LawKind::Yade, &p, &b, &springs(1, r)).unwrap();
    let mut sim = Simulation::new(&p, &b, law, &DemOptions::default()).unwrap();
    let v = Vec3::new(-1e-4, 2e-4, 3e-5);
    sim.set_prescribed_motion(Some(PrescribedMotion {
        particles: vec![0],
        velocity: vec![v],
    }))
    .unwrap();
    let dt = sim.time_step();
    for _ in 0..200 {
        sim.step().unwrap();
    }
    // The bond pulls on particle 0, which must not respond.
    assert!(sim.force[0].norm() > 0.0);
    let expected = v * (200.0 * dt);
    assert!((sim.particles.position[0] - expected).norm() <= 1e-12 * expected.norm());
    assert_eq!(sim.particles.velocity[0], v);
    assert_eq!(sim.particles.angular_velocity[0], Vec3::zeros());
    // The free particle follows (it has moved towards the held one's path).
    assert!((sim.particles.position[1] - Vec3::new(2.0 * r, 0.0, 0.0)).norm() > 0.0);
    // Bad input is refused.
    for bad in [
        PrescribedMotion {
            particles: vec![2],
            velocity: vec![v],
        },
        PrescribedMotion {
            particles: vec![0, 0],
            velocity: vec![v, v],
        },
        PrescribedMotion {
            particles: vec![0],
            velocity: vec![],
        },
        PrescribedMotion {
            particles: vec![1],
            velocity: vec![Vec3::new(f64::NAN, 0.0, 0.0)],
        },
    ] {
        assert!(sim.set_prescribed_motion(Some(bad)).is_err());
    }
}

#[test]
fn time_integrated_strain_rate_equals_displacement_fit() {
    let (p, b) = gap_bonded(800, 4);
    let k = springs(b.len(), p.mean_radius());
    let opts = GrippedOptions {
        measure: MeasureOptions {
            count: 20,
            radius: 3.0,
            seed: 1,
        },
        ..Default::default()
    };
    let mut s = gripped_setup(&p, &b, &k, LawKind::Yade, &opts).unwrap();
    let g = path_gradient(4, 1e-5);
    let motion = grip_motion(&s.block, &s.sim, &g, 100);
    s.sim.set_prescribed_motion(Some(motion)).unwrap();
    let mut integ = StrainIntegrator::new(&s.spheres);
    for _ in 0..150 {
        s.sim.step().unwrap();
        integ.accumulate(&s.spheres, &s.sim).unwrap();
    }
    let direct = s.spheres.displacement_gradient(&s.sim).unwrap();
    for (a, d) in integ.gradient.iter().zip(&direct) {
        let scale = d.amax();
        assert!(scale > 1e-7, "the spheres must have deformed");
        assert!((a - d).amax() < 1e-9 * scale, "{a} vs {d}");
    }
}

/// With every particle held, the energy ledger must show exactly the prescribed motion:
/// kinetic energy Σ ½m|v|² (no acceleration by the bond forces, no spin) and no Cundall
/// dissipation, although the bonds are strained and damping is on.
#[test]
fn held_particles_energy_ledger_is_that_of_the_prescribed_motion() {
    let p = crate::common::bonded::generated(200, 5);
    let p = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    let b = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
    let r = p.mean_radius();
    let law = build_law(LawKind::Yade, &p, &b, &springs(b.len(), r)).unwrap();
    let opts = DemOptions {
        local_damping: 0.4,
        ..Default::default()
    };
    let mut sim = Simulation::new(&p, &b, law, &opts).unwrap();
    // A non-affine velocity field, so that the bonds are loaded.
    let velocity: Vec<Vec3> = (0..p.len())
        .map(|k| {
            let t = k as f64;
            Vec3::new((t * 0.7).sin(), (t * 1.3).cos(), (t * 2.9).sin()) * 1e-3
        })
        .collect();
    let expected: f64 = (0..p.len())
        .map(|k| 0.5 * sim.particles.mass[k] * velocity[k].norm_squared())
        .sum();
    sim.set_prescribed_motion(Some(PrescribedMotion {
        particles: (0..p.len()).collect(),
        velocity,
    }))
    .unwrap();
    for _ in 0..100 {
        sim.step().unwrap();
    }
    let e = sim.energies();
    assert!(e.elastic > 1e-3 * expected, "bonds not loaded: {e:?}");
    assert!(
        (e.kinetic / expected - 1.0).abs() < 1e-9,
        "kinetic {:e} vs Σ½m|v|² {expected:e}",
        e.kinetic
    );
    assert!(
        e.local_damping.abs() < 1e-9 * expected,
        "damping {:e} J",
        e.local_damping
    );
}
