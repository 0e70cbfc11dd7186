//! Cost of the many-body term in the relaxed solve (issue 33: at most 2× the solve without
//! it; BENCHMARKS.md "Many-body term: relaxed solve"). Run with
//! `cargo bench --bench manybody` (release build; RAYON_NUM_THREADS sets the thread count;
//! ANISOBOND_BENCH_PARTICLES the size, default the demo's 30,700; ANISOBOND_BENCH_SEED the
//! packing's seed, default 2018). For instruction counts
//! (`valgrind --tool=callgrind`, repeatable on a loaded machine): ANISOBOND_BENCH_ONCE=1 runs
//! each solve once and stops, ANISOBOND_BENCH_ONLY=none|pair|term only the packing, or it and
//! one solve (the solve's count is the difference from `none`'s).
//!
//! One generated random packing (φ = 0.60, the Truszkowska standard assembly's preparation),
//! gap-bonded at 0.17 R̄, the demo's model (Truszkowska 2018 MRV, cubic Zener > 1) and an
//! isotropic term (K' = 10 GPa, G' = 3 GPa, Green–Lagrange, rattlers excluded). In the same
//! run, alternately twice each (the faster run counted, wall and CPU time): the relaxed
//! tensor of the springs alone and of the springs + term (default two-level CG, the term in
//! factored form), then the term's set-up, its stencil entries against the blocks of its
//! assembled Hessian.

use anisobond::bonds::{assign_stiffness, build_bonds, BondingRule};
use anisobond::homogenize::{
    relaxed_tensor, relaxed_tensor_with_term, BlockSparse, LeverArm, Network, RelaxedOptions,
    TwoLevel, DEFAULT_PARTICLES_PER_AGGREGATE,
};
use anisobond::manybody::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions};
use anisobond::model::Model;
use anisobond::packing::{generate, GenerateOptions};
use std::time::Instant;

/// Seconds `f` takes, and its result.
fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t = Instant::now();
    let r = f();
    (t.elapsed().as_secs_f64(), r)
}

/// CPU seconds of this process so far, all threads (user + system; /proc/self/stat fields 14
/// and 15 in Linux's USER_HZ = 100 ticks), or NaN where unreadable: on a loaded machine the
/// wall time depends on the other processes, the CPU time much less.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    let Some(rest) = stat.rsplit_once(')').map(|x| x.1) else {
        return f64::NAN;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok());
    match (tick(11), tick(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// Wall and CPU seconds `f` takes, and its result.
fn timed_cpu<T>(f: impl FnOnce() -> T) -> (f64, f64, T) {
    let c = cpu_seconds();
    let (t, r) = timed(f);
    (t, cpu_seconds() - c, r)
}

fn main() {
    let n: usize = std::env::var("ANISOBOND_BENCH_PARTICLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30_700);
    let threads = rayon::current_num_threads();
    // ANISOBOND_BENCH_SEED: another packing (seed 1 is the CLI's `pack --preset
    // truszkowska-standard`, with nearly degenerate particles, docs/manybody.md).
    let seed = std::env::var("ANISOBOND_BENCH_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(GenerateOptions::default().seed);
    let p = generate(
        &GenerateOptions {
            n_particles: n,
            seed,
            ..Default::default()
        },
        &|_| {},
    )
    .expect("packing");
    let bonds = build_bonds(&p, BondingRule::Gap(0.17)).expect("bonding");
    let model = Model::truszkowska_mrv();
    let scheme = model.build_scheme(None).expect("scheme");
    let k = assign_stiffness(&p, &bonds, scheme.as_ref(), &model.geometry).expect("springs");
    println!(
        "packing: {} particles, {} bonds (Z = {:.3}), {threads} threads",
        p.len(),
        bonds.len(),
        bonds.coordination(p.len())
    );
    let tensor = LocalTensor::Isotropic {
        bulk: 10e9,
        shear: 3e9,
    };
    let options = ManyBodyOptions {
        degenerate: DegenerateParticles::Exclude,
        ..Default::default()
    };
    let opts = RelaxedOptions::default();
    let once = std::env::var("ANISOBOND_BENCH_ONCE").is_ok();
    let (mut t_pair, mut t_term) = (f64::INFINITY, f64::INFINITY);
    let (mut c_pair, mut c_term) = (f64::INFINITY, f64::INFINITY);
    let (mut pair, mut with) = (None, None);
    for _ in 0..if once { 1 } else { 2 } {
        let only = std::env::var("ANISOBOND_BENCH_ONLY").unwrap_or_default();
        if only == "none" {
            return;
        }
        if only != "term" {
            let (t, c, r) = timed_cpu(|| relaxed_tensor(&p, &bonds, &k, &opts).expect("relaxed"));
            if only == "pair" {
                println!("pair: {} iterations", r.iterations);
                return;
            }
            (t_pair, c_pair) = (t_pair.min(t), c_pair.min(c));
            pair = Some(r);
        }
        // The term's set-up is part of its cost.
        let (t, c, r) = timed_cpu(|| {
            let mb = ManyBody::new(&p, &bonds, &tensor, &options).expect("term");
            let r = relaxed_tensor_with_term(&p, &bonds, &k, Some(&mb), &opts).expect("relaxed");
            (mb.volume_fraction(), r)
        });
        if only == "term" {
            println!("term: {} iterations", r.1.iterations);
            return;
        }
        (t_term, c_term) = (t_term.min(t), c_term.min(c));
        with = Some(r);
    }
    let (pair, (fraction, with)) = (pair.unwrap(), with.unwrap());
    println!(
        "relaxed, springs: {t_pair:.3} s, {} iterations, residual {:.1e}, {} active particles, C11 {:.4e} Pa, CPU {c_pair:.2} s",
        pair.iterations, pair.relative_residual, pair.active_particles, pair.c[(0, 0)]
    );
    println!(
        "relaxed, springs + term: {t_term:.3} s, {} iterations, residual {:.1e}, {} active particles, C11 {:.4e} Pa, volume fraction {fraction:.4}, CPU {c_term:.2} s",
        with.iterations, with.relative_residual, with.active_particles, with.c[(0, 0)]
    );
    println!(
        "ratio: {:.2}x (CPU time {:.2}x)",
        t_term / t_pair,
        c_term / c_pair
    );
    if once {
        return;
    }
    // Where the term's time goes: the relaxed CG applies it in factored form (one gather and
    // one scatter per stencil entry); the assembled Hessian serves the Cholesky solver only.
    let (t_new, mb) = timed(|| ManyBody::new(&p, &bonds, &tensor, &options).expect("term"));
    let entries: usize = (0..mb.len()).map(|q| mb.stencil(q).0.len()).sum();
    let l = mb.reference_branches();
    let (t_hess, kt) = timed(|| mb.hessian(l).expect("hessian"));
    let net = Network::build(&p, &bonds, &k, LeverArm::MidGap, true, None).expect("network");
    let ks = BlockSparse::assemble(&net);
    println!(
        "term parts: set-up {t_new:.3} s; factored form in the CG, {:.1} stencil entries per particle; assembled Hessian (Cholesky solver only) {t_hess:.3} s",
        entries as f64 / mb.len() as f64
    );
    let cell = p.cell.expect("periodic");
    let (t_tl_pair, _) = timed(|| {
        TwoLevel::new(
            &ks,
            &p.positions,
            cell.lengths,
            true,
            DEFAULT_PARTICLES_PER_AGGREGATE,
        )
    });
    println!("set-up: two-level coarse space of the springs' K {t_tl_pair:.3} s");
    println!(
        "K blocks: springs {}, term assembled {}, per particle {:.1} vs {:.1} (second neighbours)",
        ks.blocks(),
        kt.blocks(),
        ks.blocks() as f64 / ks.rows() as f64,
        kt.blocks() as f64 / kt.rows() as f64
    );
}
