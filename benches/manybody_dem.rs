//! Cost of the many-body term in the reference integrator (issue 33: at most 1.5× per
//! particle-step): law (a) on a bonded periodic packing (gap 0.17 R̄, rattlers excluded from
//! the term), without and with a rotated cubic term (Green–Lagrange), in the same run,
//! alternating the two several times and keeping each one's best. Run:
//! `cargo bench --bench manybody_dem` (MB_BENCH_PARTICLES, default 30,000; MB_BENCH_STEPS,
//! default 100; MB_BENCH_THREADS, comma-separated, default 1,2; MB_BENCH_REPEATS, default 5;
//! MB_BENCH_ONLY=with or without: build and run only that one, for an instruction count
//! under `valgrind --tool=callgrind --toggle-collect='*Simulation::step*'`).
//! Prints the ratio of the best times and the median (and range) of the ratios of the
//! alternating pairs, the steadier figure on a loaded machine, in wall time and in CPU time
//! (all threads of the process; a thread waiting for the CPU is not charged).

mod common;

use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::manybody::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions};
use common::env;
use std::time::Instant;

fn main() {
    let n: usize = env("MB_BENCH_PARTICLES", 30_000);
    let steps: usize = env("MB_BENCH_STEPS", 100);
    let repeats: usize = env("MB_BENCH_REPEATS", 5).max(1);
    let threads = common::thread_counts("MB_BENCH_THREADS");
    let only: String = env("MB_BENCH_ONLY", String::new());
    let p = common::packing(n);
    let (b, k) = common::bonds_and_springs(&p);
    let nb = b.len();
    let c = anisobond::homogenize::voigt_tensor(&b, &k, p.volume());
    let s = (c[(0, 0)] + c[(1, 1)] + c[(2, 2)]) / 3.0;
    let d = LocalTensor::Cubic {
        c11: 0.8 * s,
        c12: 0.5 * s,
        c44: 0.2 * s,
        rotation: anisobond::tensor::rotation_z(0.3) * anisobond::tensor::rotation_x(1.1),
    };
    let options = ManyBodyOptions {
        degenerate: DegenerateParticles::Exclude,
        ..Default::default()
    };
    let mb = ManyBody::new(&p, &b, &d, &options).expect("term");
    println!(
        "setup: {n} particles, {nb} bonds (Z = {:.2}), {} excluded from the term",
        b.coordination(n),
        mb.excluded().len()
    );
    for t in threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .expect("pool");
        pool.install(|| {
            let make = |with: bool| {
                let law = build_law(LawKind::Yade, &p, &b, &k).expect("law");
                let term = with.then(|| mb.clone());
                let opts = DemOptions {
                    local_damping: 0.4,
                    // The same time step for both (the term's Gershgorin bound is smaller).
                    time_step: Some(1e-9),
                    ..Default::default()
                };
                let mut sim = Simulation::with_manybody(&p, &b, law, term, &opts).expect("sim");
                common::start_moving(&mut sim, 1e-3);
                sim
            };
            if only == "with" || only == "without" {
                let mut sim = make(only == "with");
                let t0 = Instant::now();
                sim.run(steps, &|_| {}).expect("run");
                let per = t0.elapsed().as_secs_f64() / (n * steps) as f64;
                println!("{t} thread(s): {only} the term only: {per:.3e} s per particle-step");
                return;
            }
            let mut sims = [make(false), make(true)];
            let mut best = [f64::INFINITY; 2];
            // The ratio of each alternating pair: on a loaded machine the two best times
            // may come from quiet moments of different lengths; a pair is measured together.
            let mut paired = Vec::with_capacity(repeats);
            let mut paired_cpu = Vec::with_capacity(repeats);
            let mut best_cpu = [f64::INFINITY; 2];
            for _ in 0..repeats {
                let mut pair = [0.0; 2];
                let mut cpu = [0.0; 2];
                for (w, sim) in sims.iter_mut().enumerate() {
                    let (t0, c0) = (Instant::now(), common::cpu_seconds());
                    sim.run(steps, &|_| {}).expect("run");
                    pair[w] = t0.elapsed().as_secs_f64();
                    cpu[w] = common::cpu_seconds() - c0;
                    best[w] = best[w].min(pair[w]);
                    best_cpu[w] = best_cpu[w].min(cpu[w]);
                }
                paired.push(pair[1] / pair[0]);
                paired_cpu.push(cpu[1] / cpu[0]);
            }
            paired.sort_by(f64::total_cmp);
            paired_cpu.sort_by(f64::total_cmp);
            let per = |s: f64| s / (n * steps) as f64;
            println!(
                "{t} thread(s): without the term {:.3e} s per particle-step, with {:.3e}: ratio {:.3} \
                 (best of each); paired ratios: median {:.3}, range {:.3}–{:.3}",
                per(best[0]),
                per(best[1]),
                best[1] / best[0],
                paired[paired.len() / 2],
                paired[0],
                paired[paired.len() - 1]
            );
            println!(
                "{t} thread(s), CPU time: without {:.3e} s per particle-step, with {:.3e}: ratio \
                 {:.3} (best of each); paired ratios: median {:.3}, range {:.3}–{:.3}",
                per(best_cpu[0]),
                per(best_cpu[1]),
                best_cpu[1] / best_cpu[0],
                paired_cpu[paired_cpu.len() / 2],
                paired_cpu[0],
                paired_cpu[paired_cpu.len() - 1]
            );
        });
    }
}
