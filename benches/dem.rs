//! Particle-steps per second of the reference integrator, law (a), on a 30,000-particle
//! bonded periodic packing (gap 0.17 R̄), on 1 and 2 threads. Run:
//! `cargo bench --bench dem` (set DEM_BENCH_PARTICLES to change the size, DEM_BENCH_STEPS
//! the measured steps, DEM_BENCH_THREADS a comma-separated list of thread counts,
//! DEM_BENCH_SORT=1 to renumber the particles in Morton order first, DEM_BENCH_DAMPING the
//! Cundall damping (0.4), DEM_BENCH_RATE the shear rate of the cell in 1/s (1e-3)).
//! Besides wall time it prints the CPU time of all threads (from /proc), which is less
//! sensitive to other processes on a loaded machine.

use anisobond::bonds::{build_bonds, BondStiffness, BondingRule};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::packing::{generate, GenerateOptions};
use anisobond::{Mat3, Vec3};
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
    let p = if std::env::var("DEM_BENCH_SORT").is_ok() {
        morton_sorted(&p)
    } else {
        p
    };
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
    let steps: usize = std::env::var("DEM_BENCH_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let thread_counts: Vec<usize> = std::env::var("DEM_BENCH_THREADS")
        .ok()
        .map(|s| s.split(',').filter_map(|t| t.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![1, 2]);
    let kind = match std::env::var("DEM_BENCH_LAW").as_deref() {
        Ok("parallel-bond") => LawKind::ParallelBond,
        Ok("kumar") => LawKind::Kumar,
        _ => LawKind::Yade,
    };
    for threads in thread_counts {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let law = build_law(kind, &p, &b, &k).expect("law");
            let mut sim = Simulation::new(&p, &b, law, &DemOptions { local_damping: env_f64("DEM_BENCH_DAMPING", 0.4), ..Default::default() }).expect("sim");
            for (i, v) in sim.particles.velocity.iter_mut().enumerate() {
                *v = Vec3::new((i as f64).sin(), (i as f64 * 1.3).cos(), (i as f64 * 0.7).sin()) * 1e-4;
            }
            // A small shear rate, as in an element test (exercises the periodic terms).
            let mut l = Mat3::zeros();
            let rate = env_f64("DEM_BENCH_RATE", 1e-3);
            l[(0, 1)] = rate;
            l[(2, 2)] = -2.0 * rate;
            sim.set_velocity_gradient(l).expect("periodic");
            sim.run(20, &|_| {}).expect("warm-up");
            let cpu0 = cpu_seconds();
            let t = Instant::now();
            sim.run(steps, &|_| {}).expect("run");
            let secs = t.elapsed().as_secs_f64();
            let cpu = cpu_seconds() - cpu0;
            println!(
                "law {kind:?}, {threads} thread(s): {steps} steps in {secs:.3} s = {:.3e} particle-steps/s ({:.3e} bond-steps/s); CPU {cpu:.3} s = {:.3e} particle-steps per CPU-s",
                (n * steps) as f64 / secs,
                (nb * steps) as f64 / secs,
                (n * steps) as f64 / cpu
            );
            if std::env::var("DEM_BENCH_HASH").is_ok() {
                println!("state hash {:016x}", state_hash(&sim));
            }
        });
    }
}

/// CPU time (s) consumed so far by all threads of this process (sum of the per-thread
/// `schedstat` run times; 0 where /proc is unavailable).
fn cpu_seconds() -> f64 {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    dir.filter_map(|e| e.ok())
        .filter_map(|e| std::fs::read_to_string(e.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-9
}

/// FNV-1a hash of the particle state and resultants (−0 folded onto +0), to check that an
/// optimisation leaves the trajectory bit for bit unchanged.
fn state_hash(sim: &Simulation) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: f64| {
        for byte in (x + 0.0).to_bits().to_le_bytes() {
            h ^= byte as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    let p = &sim.particles;
    for k in 0..p.len() {
        for v in [
            p.position[k],
            p.velocity[k],
            p.angular_velocity[k],
            sim.force[k],
            sim.torque[k],
        ] {
            v.iter().for_each(|&x| eat(x));
        }
        let q = p.orientation[k];
        eat(q.w);
        q.v.iter().for_each(|&x| eat(x));
    }
    sim.stress().iter().for_each(|&x| eat(x));
    h
}

/// Experiment: particles in Morton (Z-curve) order of their 2R̄ cells.
fn morton_sorted(p: &anisobond::packing::Packing) -> anisobond::packing::Packing {
    let (lo, _) = p.bounding_box();
    let h = 2.0 * p.mean_radius();
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    let key = |v: &Vec3| {
        let c = (v - lo) / h;
        spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2
    };
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by_key(|&k| (key(&p.positions[k]), k));
    anisobond::packing::Packing::new(
        order.iter().map(|&k| p.positions[k]).collect(),
        order.iter().map(|&k| p.radii[k]).collect(),
        p.cell,
    )
    .expect("sorted")
}

/// A number from the environment, or the default.
fn env_f64(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}
