//! Particle-steps per second of the reference integrator, law (a), on a 30,000-particle
//! bonded periodic packing (gap 0.17 R̄), on 1 and 2 threads. Run:
//! `cargo bench --bench dem` (set DEM_BENCH_PARTICLES to change the size).

use anisobond::bonds::{rules::build_bonds, BondStiffness, BondingRule};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::packing::generate::{generate, GenerateOptions};
use anisobond::Vec3;
use std::time::Instant;

fn main() {
    let n: usize = std::env::var("DEM_BENCH_PARTICLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30_000);
    let t0 = Instant::now();
    let p = generate(
        &GenerateOptions {
            n_particles: n,
            seed: 1,
            ..Default::default()
        },
        &|_| {},
    )
    .expect("packing");
    let b = build_bonds(&p, BondingRule::Gap(0.17)).expect("bonds");
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
    println!(
        "setup: {} particles, {} bonds (Z = {:.2}) in {:.1} s",
        n,
        nb,
        b.coordination(n),
        t0.elapsed().as_secs_f64()
    );
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let law = build_law(LawKind::Yade, &p, &b, &k).expect("law");
            let mut sim = Simulation::new(&p, &b, law, &DemOptions { local_damping: 0.4, ..Default::default() }).expect("sim");
            for (i, v) in sim.particles.velocity.iter_mut().enumerate() {
                *v = Vec3::new((i as f64).sin(), (i as f64 * 1.3).cos(), (i as f64 * 0.7).sin()) * 1e-4;
            }
            sim.run(20, &|_| {}).expect("warm-up");
            let steps = 200;
            let t = Instant::now();
            sim.run(steps, &|_| {}).expect("run");
            let secs = t.elapsed().as_secs_f64();
            println!(
                "law (a), {threads} thread(s): {steps} steps in {secs:.3} s = {:.3e} particle-steps/s ({:.3e} bond-steps/s)",
                (n * steps) as f64 / secs,
                (nb * steps) as f64 / secs
            );
        });
    }
}
