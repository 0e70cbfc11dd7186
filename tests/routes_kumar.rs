//! Kumar 2016's preparation routes (Sec. 3): coordination per route and interaction range
//! against Table 1, the jamming point, affine scaling, determinism.

use anisobond::bonds::rules::build_bonds;
use anisobond::bonds::BondingRule;
use anisobond::packing::routes::{
    prepare, scale_to_solid_fraction, PreparationRoute, RouteOptions, RouteReport,
};
use anisobond::packing::Packing;

fn options(route: PreparationRoute, n: usize, seed: u64) -> RouteOptions {
    RouteOptions {
        route,
        n_particles: n,
        seed,
        ..RouteOptions::default()
    }
}

fn run(route: PreparationRoute, n: usize, seed: u64) -> (Packing, RouteReport) {
    prepare(&options(route, n, seed), &|_| {}).unwrap()
}

fn z_at(p: &Packing, kappa: f64) -> f64 {
    build_bonds(p, BondingRule::Factor(kappa))
        .unwrap()
        .coordination(p.len())
}

/// Exploration: print Z per route and κ (run with `--release -- --ignored --nocapture`).
#[test]
#[ignore]
fn print_table_1() {
    let n: usize = std::env::var("ROUTES_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000);
    for route in [
        PreparationRoute::Unjammed,
        PreparationRoute::WeaklyJammed,
        PreparationRoute::Jammed,
    ] {
        let t = std::time::Instant::now();
        let (p, r) = run(route, n, 1);
        let zs: Vec<String> = [1.0, 1.025, 1.05, 1.075]
            .iter()
            .map(|&k| format!("{:.3}", z_at(&p, k)))
            .collect();
        println!(
            "{:>14} N={n}: Z(κ=1,1.025,1.05,1.075) = {}; φ before affine {:.4}, Z there {:.3}, \
             rattlers {}, P {:.2e}, {} relaxations, {} iterations, {:.2} s",
            route.as_str(),
            zs.join(" "),
            r.compressed_solid_fraction,
            r.compressed_coordination,
            r.rattlers,
            r.pressure,
            r.relaxations,
            r.iterations,
            t.elapsed().as_secs_f64()
        );
    }
}
