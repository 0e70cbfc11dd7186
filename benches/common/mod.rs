//! The set-up the integrator benches share (`dem`, `manybody_dem`): a generated periodic
//! packing bonded at gap 0.17 R̄ with anisotropic springs, started moving under a small
//! shear of the cell, and the environment's settings (`breakage` uses the packing, the
//! settings and the CPU time).
#![allow(dead_code)]

use anisobond::bonds::{build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::dem::Simulation;
use anisobond::packing::{generate, GenerateOptions, Packing};
use anisobond::{Mat3, Vec3};

/// A setting from the environment, or the default when unset or unreadable.
pub fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The thread counts of the comma-separated list in `name`, else 1 and 2.
pub fn thread_counts(name: &str) -> Vec<usize> {
    std::env::var(name)
        .ok()
        .map(|s| s.split(',').filter_map(|t| t.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![1, 2])
}

/// A generated periodic packing of `n` spheres (seed 1).
pub fn packing(n: usize) -> Packing {
    generate(
        &GenerateOptions {
            n_particles: n,
            seed: 1,
            ..Default::default()
        },
        &|_| {},
    )
    .expect("packing")
}

/// The bonds of `p` at gap 0.17 R̄ and their springs: k_n = 10⁶(1 + n_x²) N/m (anisotropic),
/// k_s = 0.4·10⁶ N/m, k_r = 0.1·10⁶ R̄², k_tw = 0.05·10⁶ R̄² N·m/rad.
pub fn bonds_and_springs(p: &Packing) -> (BondSet, BondStiffness) {
    let b = build_bonds(p, BondingRule::Gap(0.17)).expect("bonds");
    let r = p.mean_radius();
    let nb = b.len();
    let k = BondStiffness {
        radius: vec![r; nb],
        kn: (0..nb)
            .map(|e| 1e6 * (1.0 + b.normal[e].x.powi(2)))
            .collect(),
        ks: vec![0.4e6; nb],
        kr: vec![0.1e6 * r * r; nb],
        ktw: vec![0.05e6 * r * r; nb],
    };
    (b, k)
}

/// Start `sim` moving as in an element test (it exercises the periodic terms): smooth
/// velocities of 10⁻⁴ m/s, the cell sheared at `rate` (1/s; L₀₁ = rate, L₂₂ = −2 rate), then
/// 20 warm-up steps.
pub fn start_moving(sim: &mut Simulation, rate: f64) {
    for (i, v) in sim.particles.velocity.iter_mut().enumerate() {
        *v = Vec3::new(
            (i as f64).sin(),
            (i as f64 * 1.3).cos(),
            (i as f64 * 0.7).sin(),
        ) * 1e-4;
    }
    let mut l = Mat3::zeros();
    l[(0, 1)] = rate;
    l[(2, 2)] = -2.0 * rate;
    sim.set_velocity_gradient(l).expect("periodic");
    sim.run(20, &|_| {}).expect("warm-up");
}

/// CPU time (s) consumed so far by all threads of this process (sum of the per-thread
/// `schedstat` run times; 0 where /proc is unavailable).
pub fn cpu_seconds() -> f64 {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    dir.filter_map(|e| e.ok())
        .filter_map(|e| std::fs::read_to_string(e.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-9
}
