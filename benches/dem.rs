//! Particle-steps per second of the reference integrator, law (a), on a 30,000-particle
//! bonded periodic packing (gap 0.17 R̄), on 1 and 2 threads. Run:
//! `cargo bench --bench dem` (set DEM_BENCH_PARTICLES to change the size, DEM_BENCH_STEPS
//! the measured steps, DEM_BENCH_THREADS a comma-separated list of thread counts,
//! DEM_BENCH_SORT=1 to renumber the particles in Morton order first, DEM_BENCH_DAMPING the
//! Cundall damping (0.4), DEM_BENCH_RATE the shear rate of the cell in 1/s (1e-3)).
//! Besides wall time it prints the CPU time of all threads (from /proc), which is less
//! sensitive to other processes on a loaded machine.

mod common;

use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::Vec3;
use common::env;
use std::time::Instant;

fn main() {
    let n: usize = env("DEM_BENCH_PARTICLES", 30_000);
    let t0 = Instant::now();
    let p = common::packing(n);
    let p = if std::env::var("DEM_BENCH_SORT").is_ok() {
        morton_sorted(&p)
    } else {
        p
    };
    let (b, k) = common::bonds_and_springs(&p);
    let nb = b.len();
    println!(
        "setup: {} particles, {} bonds (Z = {:.2}) in {:.1} s",
        n,
        nb,
        b.coordination(n),
        t0.elapsed().as_secs_f64()
    );
    let steps: usize = env("DEM_BENCH_STEPS", 200);
    let thread_counts = common::thread_counts("DEM_BENCH_THREADS");
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
            let options = DemOptions {
                local_damping: env("DEM_BENCH_DAMPING", 0.4),
                ..Default::default()
            };
            let mut sim = Simulation::new(&p, &b, law, &options).expect("sim");
            common::start_moving(&mut sim, env("DEM_BENCH_RATE", 1e-3));
            let cpu0 = common::cpu_seconds();
            let t = Instant::now();
            sim.run(steps, &|_| {}).expect("run");
            let secs = t.elapsed().as_secs_f64();
            let cpu = common::cpu_seconds() - cpu0;
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
