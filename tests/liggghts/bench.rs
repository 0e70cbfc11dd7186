//! Throughput of the LIGGGHTS driver: particle-steps per second at -np 1 and -np 2 on a
//! ~30,000-particle bonded packing. Ignored by default (minutes); run with
//! `cargo test --release --test liggghts -- --ignored --nocapture bench::`. Asserts only that both runs
//! finish and agree.

use crate::common::liggghts::*;
use anisobond::export::liggghts::{
    export_liggghts, read_stress_history, run_liggghts, DeckOptions,
};

/// Sum of "Loop time of T on P procs for S steps" lines: (seconds, steps).
fn loop_time(screen: &str) -> (f64, u64) {
    let mut t = 0.0;
    let mut s = 0;
    for l in screen.lines().filter(|l| l.starts_with("Loop time of")) {
        let w: Vec<&str> = l.split_whitespace().collect();
        t += w[3].parse::<f64>().unwrap();
        s += w[8].parse::<u64>().unwrap();
    }
    (t, s)
}

#[test]
#[ignore]
fn driver_throughput_30k() {
    let _alone = crate::common::alone();
    if let Some(r) = missing(&["liggghts", "mpicxx", "mpirun", "make"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let n: usize = std::env::var("BENCH_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(30_000);
    let t0 = std::time::Instant::now();
    let b = bonded(
        n,
        2018,
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\nmodel = \"zener-above-1\"\n\
         a_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\n[geometry]\nmoments = \"parallel-bond\"\n",
    );
    eprintln!(
        "packing + bonds: {} particles, {} bonds, {:?}",
        b.packing.len(),
        b.bonds.len(),
        t0.elapsed()
    );
    let opts = DeckOptions {
        deform_steps: 200,
        relax_steps: 200,
        output_every: 100,
        shear: false,
        ..DeckOptions::default()
    };
    let mut hist = Vec::new();
    for np in [1usize, 2] {
        let dir = fresh_dir(&format!("bench{np}"));
        export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
        let screen = run_liggghts(&driver_launch(Some(np)), &dir, "anisobond.in").unwrap();
        let (t, s) = loop_time(&screen);
        eprintln!(
            "-np {np}: {s} steps in {t:.2} s: {:.3e} particle-steps/s ({:.3} s per 1000 steps)",
            b.packing.len() as f64 * s as f64 / t,
            1000.0 * t / s as f64
        );
        hist.push(read_stress_history(&dir.join("stress_history.txt")).unwrap());
    }
    let (worst, scale) = history_difference(&hist[0].stress, &hist[1].stress);
    eprintln!("np1 vs np2: {:.3e}", worst / scale);
    assert!(worst <= 1e-9 * scale);
}
