//! Random packing generation: determinism, solid fraction, overlaps, isotropy.

use anisobond::bonds::build_bonds;
use anisobond::bonds::BondingRule;
use anisobond::packing::pairs_within;
use anisobond::packing::Packing;
use anisobond::packing::{
    generate, generate_with_report, GenerateOptions, Polydispersity, TRUSZKOWSKA_2018_HALF_WIDTH,
};
use anisobond::Mat3;
use std::f64::consts::PI;

fn options(n: usize, phi: f64, seed: u64) -> GenerateOptions {
    GenerateOptions {
        n_particles: n,
        solid_fraction: phi,
        mean_radius: 2.5e-3,
        seed,
        ..GenerateOptions::default()
    }
}

fn bits(p: &Packing) -> (Vec<[u64; 3]>, Vec<u64>, [u64; 3]) {
    let l = p.cell.unwrap().lengths;
    (
        p.positions
            .iter()
            .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .collect(),
        p.radii.iter().map(|r| r.to_bits()).collect(),
        [l.x.to_bits(), l.y.to_bits(), l.z.to_bits()],
    )
}

/// Largest overlap R_i + R_j − |l| over all pairs, by the independent neighbour search.
fn max_overlap(p: &Packing) -> f64 {
    pairs_within(p, |_, _| 0.0, 0.0)
        .unwrap()
        .iter()
        .map(|q| -q.gap(p))
        .fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn deterministic_same_seed_and_any_thread_count() {
    let opts = options(1000, 0.6, 42);
    let run =
        |threads: usize| crate::common::on_threads(threads, || generate(&opts, &|_| {}).unwrap());
    let a = run(1);
    let b = run(2);
    let c = run(2);
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&b), bits(&c));
    let other = generate(&options(1000, 0.6, 43), &|_| {}).unwrap();
    assert_ne!(bits(&a), bits(&other));
}

#[test]
fn solid_fraction_mean_radius_and_overlap_bound() {
    for (phi, poly) in [
        (
            0.6,
            Polydispersity::Uniform {
                half_width: TRUSZKOWSKA_2018_HALF_WIDTH,
            },
        ),
        (0.55, Polydispersity::Monodisperse),
        (
            0.62,
            Polydispersity::Uniform {
                half_width: 1.0 / 6.0,
            },
        ),
    ] {
        let opts = GenerateOptions {
            polydispersity: poly,
            ..options(1000, phi, 7)
        };
        let progress = std::sync::Mutex::new(Vec::new());
        let (p, report) =
            generate_with_report(&opts, &|f| progress.lock().unwrap().push(f)).unwrap();
        assert_eq!(p.len(), 1000);
        assert!(
            (p.solid_fraction() - phi).abs() < 1e-9,
            "φ = {}",
            p.solid_fraction()
        );
        // Independently: Σ(4/3)πR³ / L³.
        let l = p.cell.unwrap().lengths;
        let vs: f64 = p.radii.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
        assert!((vs / (l.x * l.y * l.z) - phi).abs() < 1e-9);
        assert!((p.mean_radius() / 2.5e-3 - 1.0).abs() < 1e-12);
        let r_bar = p.mean_radius();
        let overlap = max_overlap(&p);
        assert!(overlap < 1e-3 * r_bar, "overlap {} R̄", overlap / r_bar);
        assert!(report.max_overlap < opts.max_overlap);
        // Radii inside the declared distribution, up to the rescaling to the sample mean
        // (relative shift ~ h/√(3N) ≈ 0.018·h; allow 8 %).
        let h = match poly {
            Polydispersity::Monodisperse => 0.0,
            Polydispersity::Uniform { half_width } => half_width,
        };
        for r in &p.radii {
            assert!((r / r_bar - 1.0).abs() <= h * 1.08 + 1e-12);
        }
        if h > 0.0 {
            // Sample variance of a uniform distribution: h²/3 (relative).
            let var: f64 = p
                .radii
                .iter()
                .map(|r| (r / r_bar - 1.0).powi(2))
                .sum::<f64>()
                / 1000.0;
            assert!((var / (h * h / 3.0) - 1.0).abs() < 0.15, "var {var}");
        }
        // Progress: starts at 0, ends at 1, never decreases.
        let pr = progress.lock().unwrap();
        assert_eq!(pr.first(), Some(&0.0));
        assert_eq!(pr.last(), Some(&1.0));
        assert!(pr.windows(2).all(|w| w[0] <= w[1]));
        // Wrapped into the cell.
        for x in &p.positions {
            for k in 0..3 {
                assert!(x[k] >= 0.0 && x[k] < l[k]);
            }
        }
    }
}

#[test]
fn bond_normals_are_isotropic() {
    // Fabric tensor ⟨n⊗n⟩ of a random packing: I/3 up to sampling noise (~1/√N_b).
    let p = generate(&options(4000, 0.6, 3), &|_| {}).unwrap();
    let bonds = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
    assert!(bonds.len() > 10_000);
    let mut fabric = Mat3::zeros();
    for n in &bonds.normal {
        fabric += n * n.transpose();
    }
    fabric /= bonds.len() as f64;
    let dev = fabric - Mat3::identity() / 3.0;
    let worst = dev.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    // Within 3 % of 1/3 (sampling noise ≈ 0.002 for ~15,000 bonds).
    assert!(worst < 0.01, "fabric {fabric}");
    assert!((fabric.trace() - 1.0).abs() < 1e-12);
}

#[test]
fn bad_options_are_refused() {
    let bad = [
        GenerateOptions {
            n_particles: 1,
            ..options(10, 0.6, 1)
        },
        GenerateOptions {
            solid_fraction: 0.7,
            ..options(100, 0.6, 1)
        },
        GenerateOptions {
            solid_fraction: f64::NAN,
            ..options(100, 0.6, 1)
        },
        GenerateOptions {
            mean_radius: -1.0,
            ..options(100, 0.6, 1)
        },
        GenerateOptions {
            polydispersity: Polydispersity::Uniform { half_width: 1.0 },
            ..options(100, 0.6, 1)
        },
        // Too few spheres for a unique minimum image.
        options(8, 0.6, 1),
    ];
    for o in bad {
        assert!(generate(&o, &|_| {}).is_err(), "{o:?}");
    }
}

/// Timing and coordination numbers (run with `--release -- --ignored --nocapture`).
#[test]
#[ignore]
fn timing_and_coordination() {
    let _alone = crate::common::alone();
    for phi in [0.62, 0.63] {
        let t = std::time::Instant::now();
        let (p, rep) = generate_with_report(&options(10_000, phi, 1), &|_| {}).unwrap();
        let z = build_bonds(&p, BondingRule::Gap(0.17))
            .unwrap()
            .coordination(p.len());
        println!(
            "φ = {phi}, N = 10000: {:.2} s, {} iterations, Z(0.17) = {z:.3}",
            t.elapsed().as_secs_f64(),
            rep.iterations
        );
    }
    for n in [1_000usize, 10_000, 30_000] {
        let t = std::time::Instant::now();
        let (p, rep) = generate_with_report(&options(n, 0.6, 1), &|_| {}).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let z = |g: f64| {
            build_bonds(&p, BondingRule::Gap(g))
                .unwrap()
                .coordination(n)
        };
        println!(
            "N = {n}: {dt:.2} s, {} iterations, {} rebuilds, max overlap {:.2e} R̄, \
             Z(gap 0) = {:.3}, Z(1e-3) = {:.3}, Z(0.01) = {:.3}, Z(0.17) = {:.3}, threads {}",
            rep.iterations,
            rep.neighbour_rebuilds,
            rep.max_overlap,
            z(1e-12),
            z(1e-3),
            z(0.01),
            z(0.17),
            rayon::current_num_threads()
        );
    }
}
