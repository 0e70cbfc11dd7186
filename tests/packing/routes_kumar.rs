//! Kumar 2016's preparation routes (Sec. 3): coordination per route and interaction range
//! against Table 1, the jamming point, affine scaling, determinism.

use anisobond::bonds::build_bonds;
use anisobond::bonds::BondingRule;
use anisobond::packing::pairs_within;
use anisobond::packing::Packing;
use anisobond::packing::Polydispersity;
use anisobond::packing::{
    prepare, scale_to_solid_fraction, ForceBalance, PreparationRoute, RouteOptions, RouteReport,
};
use std::f64::consts::PI;

const ROUTES: [PreparationRoute; 3] = [
    PreparationRoute::Unjammed,
    PreparationRoute::WeaklyJammed,
    PreparationRoute::Jammed,
];

/// Kumar 2016 Table 1: Z_b at D = 0.65 for κ = 1.000, 1.025, 1.050, 1.075.
const KAPPA: [f64; 4] = [1.000, 1.025, 1.050, 1.075];
const TABLE_1: [[f64; 4]; 3] = [
    [4.52, 5.00, 5.49, 5.99],
    [5.39, 5.81, 6.23, 6.56],
    [6.56, 7.46, 8.06, 8.57],
];

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

fn solid_fraction_by_hand(p: &Packing) -> f64 {
    let l = p.cell.unwrap().lengths;
    let vs: f64 = p.radii.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
    vs / (l.x * l.y * l.z)
}

/// Table 1 within ±0.3 for every route and κ (2000 spheres instead of Kumar's 5000), plus
/// the jamming point of Sec. 3 (D = 0.636 ± 0.0004, Z = 6.03, < 2 % rattlers).
#[test]
fn table_1_coordination_per_route_and_interaction_range() {
    let mut table = Vec::new();
    for (r, route) in ROUTES.iter().enumerate() {
        let progress = std::sync::Mutex::new(Vec::new());
        let (p, report) = prepare(&options(*route, 2000, 1), &|f| {
            progress.lock().unwrap().push(f)
        })
        .unwrap();
        assert_eq!(p.len(), 2000);
        assert!((solid_fraction_by_hand(&p) - 0.65).abs() < 1e-12);
        let pr = progress.lock().unwrap();
        assert_eq!(pr.first(), Some(&0.0));
        assert_eq!(pr.last(), Some(&1.0));
        assert!(pr.windows(2).all(|w| w[0] <= w[1]));
        let zs: Vec<f64> = KAPPA.iter().map(|&k| z_at(&p, k)).collect();
        println!(
            "{}: Z at κ = {KAPPA:?}: {zs:.2?} (Kumar {:?}); φ before the affine step {:.4}, Z there {:.3}, rattlers {}",
            route.as_str(),
            TABLE_1[r],
            report.compressed_solid_fraction,
            report.compressed_coordination,
            report.rattlers
        );
        for (c, z) in zs.iter().enumerate() {
            assert!(
                (z - TABLE_1[r][c]).abs() <= 0.3,
                "{}: κ = {}: Z = {z:.3}, Kumar {}",
                route.as_str(),
                KAPPA[c],
                TABLE_1[r][c]
            );
        }
        match route {
            PreparationRoute::Unjammed => {
                assert!((report.compressed_solid_fraction - 0.3).abs() < 1e-12);
                assert_eq!(report.relaxations, 0);
            }
            PreparationRoute::WeaklyJammed => {
                assert!((report.compressed_solid_fraction - 0.5).abs() < 1e-12);
            }
            PreparationRoute::Jammed => {
                assert!(
                    (report.compressed_solid_fraction - 0.636).abs() < 0.004,
                    "φ_J = {}",
                    report.compressed_solid_fraction
                );
                assert!(
                    (report.compressed_coordination - 6.03).abs() < 0.15,
                    "Z at jamming {}",
                    report.compressed_coordination
                );
                assert!(report.rattlers < 60, "{} rattlers", report.rattlers);
                assert!(report.pressure > 0.0 && report.pressure <= 1e-4);
            }
        }
        // The affine step: s³ = φ_before / φ_after.
        assert!(
            (report.affine_scale.powi(3) * 0.65 / report.compressed_solid_fraction - 1.0).abs()
                < 1e-12
        );
        table.push(zs);
    }
    // Jamming extent orders the coordination at every κ (Kumar Sec. 3).
    for ((u, w), j) in table[0].iter().zip(&table[1]).zip(&table[2]) {
        assert!(
            u < w && w < j,
            "Z not ordered by jamming extent: {u} {w} {j}"
        );
    }
}

#[test]
fn gas_is_overlap_free_and_deterministic_on_any_thread_count() {
    // Unjammed at the gas fraction itself: the random sequential addition, untouched.
    let o = RouteOptions {
        solid_fraction: 0.3,
        ..options(PreparationRoute::Unjammed, 3000, 5)
    };
    let (gas, _) = prepare(&o, &|_| {}).unwrap();
    let touching = pairs_within(&gas, |_, _| 0.0, 0.0).unwrap();
    assert!(touching.is_empty(), "{} overlapping pairs", touching.len());

    let bits = |p: &Packing| -> Vec<u64> {
        p.positions
            .iter()
            .flat_map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .chain(p.radii.iter().map(|r| r.to_bits()))
            .collect()
    };
    let on = |threads: usize| {
        crate::common::on_threads(threads, || run(PreparationRoute::Jammed, 500, 11).0)
    };
    let a = on(1);
    let b = on(2);
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&run(PreparationRoute::Jammed, 500, 12).0));
}

#[test]
fn affine_scaling_keeps_fractional_positions_and_radii() {
    let (p, _) = run(PreparationRoute::WeaklyJammed, 400, 3);
    let q = scale_to_solid_fraction(&p, 0.7).unwrap();
    assert!((solid_fraction_by_hand(&q) - 0.7).abs() < 1e-12);
    assert_eq!(p.radii, q.radii);
    let (lp, lq) = (p.cell.unwrap().lengths, q.cell.unwrap().lengths);
    for (a, b) in p.positions.iter().zip(&q.positions) {
        for k in 0..3 {
            assert!((a[k] / lp[k] - b[k] / lq[k]).abs() < 1e-12);
        }
    }
    let free = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    assert!(scale_to_solid_fraction(&free, 0.6).is_err());
    assert!(scale_to_solid_fraction(&p, 0.0).is_err());
    assert!(scale_to_solid_fraction(&p, f64::NAN).is_err());
}

#[test]
fn bad_options_are_refused() {
    let base = options(PreparationRoute::WeaklyJammed, 500, 1);
    let bad = [
        RouteOptions {
            n_particles: 1,
            ..base.clone()
        },
        RouteOptions {
            n_particles: 10,
            ..base.clone()
        },
        RouteOptions {
            solid_fraction: -0.1,
            ..base.clone()
        },
        RouteOptions {
            gas_solid_fraction: 0.4,
            ..base.clone()
        },
        RouteOptions {
            weak_jamming_solid_fraction: 0.2,
            ..base.clone()
        },
        RouteOptions {
            compression_step: 0.0,
            ..base.clone()
        },
        RouteOptions {
            jamming_pressure: f64::INFINITY,
            ..base.clone()
        },
        RouteOptions {
            jamming_balance: ForceBalance::Mean(0.0),
            ..base.clone()
        },
        RouteOptions {
            jamming_balance: ForceBalance::Largest(f64::NAN),
            ..base.clone()
        },
        RouteOptions {
            polydispersity: Polydispersity::Uniform { half_width: 1.5 },
            ..base.clone()
        },
        RouteOptions {
            mean_radius: 0.0,
            ..base
        },
    ];
    for o in bad {
        assert!(prepare(&o, &|_| {}).is_err(), "{o:?}");
    }
}
