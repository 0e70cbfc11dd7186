//! Throughput of the core pipeline (BENCHMARKS.md): neighbour search + bonding and the bond
//! table of ~1e6 particles / bonds. Run with `cargo bench --bench core` (release build;
//! RAYON_NUM_THREADS sets the thread count). Sizes via ANISOBOND_BENCH_PARTICLES.
//! ANISOBOND_BENCH_RELAXED=cg,cg-jacobi,cholesky adds the relaxed tensor's solvers on a
//! packing of ANISOBOND_BENCH_RELAXED_PARTICLES (default 30,000) particles.
//!
//! The packing is a jittered FCC lattice at solid fraction 0.60 with radii R̄ ± R̄/6, so
//! the bonding workload (≈ 7–8 bonds per particle at gap 0.17 R̄) is that of a dense
//! random packing without spending minutes generating one.

use anisobond::bonds::{
    assign_stiffness, build_bonds, write_bond_table, write_bond_table_to, BondingRule,
};
use anisobond::homogenize::{
    relaxed_tensor, CgPreconditioner, RelaxedOptions, RelaxedSolver,
    DEFAULT_PARTICLES_PER_AGGREGATE,
};
use anisobond::model::Model;
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::Vec3;
use rand::{Rng, SeedableRng};
use std::time::Instant;

fn jittered_fcc(n_target: usize, seed: u64) -> Packing {
    let cells = ((n_target as f64 / 4.0).cbrt().round() as usize).max(2);
    let r_mean = 1e-3;
    // FCC touching: a = 2√2 R gives φ = 0.7405; scale the lattice to φ = 0.60.
    let a = 2.0 * std::f64::consts::SQRT_2 * r_mean * (0.7405 / 0.60_f64).cbrt();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let basis = [
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, 0.0, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let mut pos = Vec::new();
    let mut rad = Vec::new();
    for i in 0..cells {
        for j in 0..cells {
            for k in 0..cells {
                for b in basis {
                    let jitter = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 0.05 * a;
                    pos.push(
                        Vec3::new(
                            (i as f64 + b[0]) * a,
                            (j as f64 + b[1]) * a,
                            (k as f64 + b[2]) * a,
                        ) + jitter,
                    );
                    rad.push(r_mean * (1.0 + (rng.gen::<f64>() - 0.5) / 3.0));
                }
            }
        }
    }
    let l = cells as f64 * a;
    Packing::new(pos, rad, Some(PeriodicCell::new(Vec3::repeat(l)).unwrap())).unwrap()
}

fn main() {
    let n: usize = std::env::var("ANISOBOND_BENCH_PARTICLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let threads = rayon::current_num_threads();
    let p = jittered_fcc(n, 1);
    println!(
        "packing: {} particles (jittered FCC, φ = {:.3}), {threads} threads",
        p.len(),
        p.solid_fraction()
    );

    let t = Instant::now();
    let bonds = build_bonds(&p, BondingRule::Gap(0.17)).expect("bonding");
    let t_bond = t.elapsed().as_secs_f64();
    println!(
        "neighbour search + bonding: {:.3} s ({} bonds, Z = {:.2})",
        t_bond,
        bonds.len(),
        bonds.coordination(p.len())
    );

    let model = Model::truszkowska_mrv();
    let scheme = model.build_scheme(None).expect("scheme");
    let t = Instant::now();
    let k = assign_stiffness(&p, &bonds, scheme.as_ref(), &model.geometry).expect("stiffness");
    let t_assign = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut buf = Vec::with_capacity(bonds.len() * 170);
    write_bond_table_to(&mut buf, &bonds, &k).expect("format");
    let t_format = t.elapsed().as_secs_f64();
    println!(
        "  formatting the CSV in memory: {t_format:.3} s ({:.1} MB)",
        buf.len() as f64 / 1e6
    );
    drop(buf);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("bonds.csv");
    let t = Instant::now();
    write_bond_table(&path, &bonds, &k).expect("write");
    let t_write = t.elapsed().as_secs_f64();
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    println!(
        "bond table of {} bonds: stiffness {:.3} s + CSV write {:.3} s = {:.3} s ({:.1} MB)",
        bonds.len(),
        t_assign,
        t_write,
        t_assign + t_write,
        size as f64 / 1e6
    );
    drop(k);
    drop(bonds);
    drop(p);
    if let Ok(list) = std::env::var("ANISOBOND_BENCH_RELAXED") {
        relaxed_bench(&list, &model);
    }
}

/// Relaxed tensor by each named solver: wall time, iterations, and agreement with the first.
fn relaxed_bench(list: &str, model: &Model) {
    let n: usize = std::env::var("ANISOBOND_BENCH_RELAXED_PARTICLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30_000);
    let p = jittered_fcc(n, 2);
    // At gap 0.17 R̄ this dilated lattice (Z ≈ 6.4) has mechanisms; 0.5 R̄ makes it rigid.
    let bonds = build_bonds(&p, BondingRule::Gap(0.5)).expect("bonding");
    let scheme = model.build_scheme(None).expect("scheme");
    let k = assign_stiffness(&p, &bonds, scheme.as_ref(), &model.geometry).expect("stiffness");
    let mut first: Option<anisobond::tensor::Stiffness6> = None;
    for name in list.split(',') {
        let solver = match name.trim() {
            "cg" => RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::TwoLevel {
                    particles_per_aggregate: DEFAULT_PARTICLES_PER_AGGREGATE,
                },
            },
            "cg-jacobi" => RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::BlockJacobi,
            },
            "cholesky" => RelaxedSolver::Cholesky,
            other => {
                println!("relaxed: unknown solver {other:?} (cg, cg-jacobi, cholesky)");
                continue;
            }
        };
        let opts = RelaxedOptions {
            solver,
            ..Default::default()
        };
        let t = Instant::now();
        match relaxed_tensor(&p, &bonds, &k, &opts) {
            Ok(r) => {
                let secs = t.elapsed().as_secs_f64();
                let diff = first.map(|c| (c - r.c).amax() / c.amax()).unwrap_or(0.0);
                first.get_or_insert(r.c);
                println!(
                    "relaxed {name}: {} particles, {} bonds: {secs:.3} s, {} iterations, residual {:.1e}, tensor vs first solver {diff:.1e}",
                    r.active_particles, r.active_bonds, r.iterations, r.relative_residual
                );
            }
            Err(e) => println!("relaxed {name}: {e}"),
        }
    }
}
