//! Law (a)'s AVX2 lanes against its scalar kernel: the same trajectory bit for bit, with
//! spins both inside the small-angle series' range and far outside it (libm fallback per
//! lane), on a periodic packing under a shear rate. The scalar kernels are chosen by the
//! run's own option (`DemOptions::simd = false`).

use crate::common::bonded::periodic_bonded;
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::{Mat3, Vec3};

fn run(scalar: bool, spin: f64) -> Vec<u64> {
    let (p, b, k) = periodic_bonded(400, 11);
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let mut sim = Simulation::new(
        &p,
        &b,
        law,
        &DemOptions {
            local_damping: 0.2,
            check_interval: 0,
            simd: !scalar,
            ..Default::default()
        },
    )
    .unwrap();
    let dt = sim.time_step();
    for (i, w) in sim.particles.angular_velocity.iter_mut().enumerate() {
        // Every fifth particle turns fast enough (up to `spin` rad per step) to leave the
        // series' range after a few steps; the rest turn slowly.
        let scale = if i % 5 == 0 { spin } else { 1e-4 };
        *w = Vec3::new(
            (i as f64).sin(),
            (1.7 * i as f64).cos(),
            (0.3 * i as f64).sin(),
        ) * (scale / dt);
    }
    let mut l = Mat3::zeros();
    l[(0, 1)] = 1e-3 / (1000.0 * dt);
    sim.set_velocity_gradient(l).unwrap();
    sim.run(60, &|_| {}).unwrap();
    let mut bits = Vec::new();
    for k in 0..sim.particles.len() {
        for v in [
            sim.particles.position[k],
            sim.particles.angular_velocity[k],
            sim.force[k],
            sim.torque[k],
        ] {
            bits.extend(v.iter().map(|x| (x + 0.0).to_bits()));
        }
    }
    bits.extend(sim.stress().iter().map(|x| (x + 0.0).to_bits()));
    let e = sim.energies();
    bits.extend([e.kinetic, e.elastic, e.local_damping].map(|x| (x + 0.0).to_bits()));
    bits
}

#[test]
fn lanes_and_scalar_kernel_give_the_same_bits() {
    for spin in [1e-4, 0.05] {
        let lanes = run(false, spin);
        let scalar = run(true, spin);
        let differing = lanes.iter().zip(&scalar).filter(|(a, b)| a != b).count();
        assert_eq!(
            differing,
            0,
            "spin {spin} rad/step: {differing} of {} values differ",
            lanes.len()
        );
    }
}
