//! The fast jammed route (pressure-controlled FIRE, Kumar 2016 Sec. 3 / O'Hern et al. 2003):
//! the jammed state is checked independently of the minimiser (contacts, virial pressure
//! and force balance recomputed from the packing), determinism on 1 and 2 threads, and an
//! ignored timing study for 3·10⁴ – 10⁵ spheres.

use anisobond::packing::pairs_within;
use anisobond::packing::Packing;
use anisobond::packing::{
    prepare, prepare_with_status, scale_to_solid_fraction, ForceBalance, PreparationRoute,
    RouteOptions, RouteReport, RouteStage, RouteStatus,
};
use anisobond::Vec3;
use std::time::Instant;

fn options(route: PreparationRoute, n: usize, seed: u64) -> RouteOptions {
    RouteOptions {
        route,
        n_particles: n,
        seed,
        ..RouteOptions::default()
    }
}

/// The state before the final affine step, rebuilt from the result by the inverse scaling.
fn jammed_state(p: &Packing, report: &RouteReport) -> Packing {
    scale_to_solid_fraction(p, report.compressed_solid_fraction).unwrap()
}

/// The jammed state recomputed from positions and radii, in R̄ units with unit contact
/// stiffness (Kumar 2016 Eq. 2).
struct Mechanics {
    /// Contacts per sphere.
    z: f64,
    /// Spheres with fewer than 4 contacts.
    rattlers: usize,
    /// Virial pressure Σ δ|l| / 3V.
    pressure: f64,
    /// Largest net force over the largest contact force (Kumar's N_max ratio).
    largest_ratio: f64,
    /// Mean net force over the mean contact force (YADE's unbalanced force).
    mean_ratio: f64,
}

fn contact_mechanics(p: &Packing) -> Mechanics {
    let r = p.mean_radius();
    let pairs = pairs_within(p, |_, _| 0.0, 0.0).unwrap();
    let mut net = vec![Vec3::zeros(); p.len()];
    let mut degree = vec![0usize; p.len()];
    let (mut virial, mut largest, mut total) = (0.0f64, 0.0f64, 0.0f64);
    for c in &pairs {
        let (i, j) = (c.i as usize, c.j as usize);
        let l = c.branch / r;
        let overlap = (p.radii[i] + p.radii[j]) / r - l.norm();
        let n = l / l.norm();
        net[i] -= n * overlap;
        net[j] += n * overlap;
        degree[i] += 1;
        degree[j] += 1;
        virial += overlap * l.norm();
        largest = largest.max(overlap);
        total += overlap;
    }
    let volume = p.volume() / r.powi(3);
    let f_max = net.iter().map(|f| f.norm()).fold(0.0, f64::max);
    let f_mean = net.iter().map(|f| f.norm()).sum::<f64>() / p.len() as f64;
    Mechanics {
        z: 2.0 * pairs.len() as f64 / p.len() as f64,
        rattlers: degree.iter().filter(|&&d| d < 4).count(),
        pressure: virial / (3.0 * volume),
        largest_ratio: f_max / largest,
        mean_ratio: f_mean / (total / pairs.len() as f64),
    }
}

/// Checks shared by both force-balance rules: Kumar 2016 Sec. 3's jamming point
/// (D = 0.636, Z = 6.03, < 2 % rattlers) and the reported state against the recomputed one.
fn check_jammed_state(p: &Packing, report: &RouteReport, seed: u64) -> Mechanics {
    let n = p.len();
    let phi_j = report.compressed_solid_fraction;
    assert!((phi_j - 0.636).abs() <= 0.005, "seed {seed}: φ_J = {phi_j}");
    let jammed = jammed_state(p, report);
    assert!((jammed.solid_fraction() - phi_j).abs() < 1e-12);
    let m = contact_mechanics(&jammed);
    assert!((m.z - report.compressed_coordination).abs() < 1e-9);
    assert!((m.z - 6.0).abs() <= 0.15, "seed {seed}: Z = {}", m.z);
    // Kumar: < 2 % at 5000 spheres; 2000 spheres fluctuate more (tests/packing/routes_kumar.rs: 3 %).
    assert!(
        m.rattlers < 3 * n / 100,
        "seed {seed}: {} rattlers",
        m.rattlers
    );
    assert_eq!(m.rattlers, report.rattlers);
    let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-6;
    assert!(
        close(m.pressure, report.pressure),
        "virial {:e} vs reported {:e}",
        m.pressure,
        report.pressure
    );
    assert!(
        m.pressure > 0.0 && m.pressure <= 1e-4,
        "P = {:e}",
        m.pressure
    );
    assert!(
        close(m.mean_ratio, report.mean_unbalanced),
        "{} vs {}",
        m.mean_ratio,
        report.mean_unbalanced
    );
    assert!(
        close(m.largest_ratio, report.largest_unbalanced),
        "{} vs {}",
        m.largest_ratio,
        report.largest_unbalanced
    );
    m
}

/// The default rule, YADE's unbalanced force ≤ 2·10⁻³ (mean net force over mean contact
/// force), recomputed from the packing, on a seed other than tests/packing/routes_kumar.rs's.
#[test]
fn jammed_state_is_balanced_on_average_at_low_pressure_near_kumar_jamming_point() {
    let seed = 7;
    let opts = options(PreparationRoute::Jammed, 2000, seed);
    assert_eq!(opts.jamming_balance, ForceBalance::Mean(2e-3));
    let (p, report) = prepare(&opts, &|_| {}).unwrap();
    let m = check_jammed_state(&p, &report, seed);
    assert!(
        m.mean_ratio <= 2e-3 * (1.0 + 1e-6),
        "seed {seed}: mean |F|/mean contact force = {:e}",
        m.mean_ratio
    );
}

/// Kumar's own stopping rule (Sec. 3: net forces below 10⁻³ N_max), over the whole packing.
#[test]
fn jammed_state_meets_kumar_largest_force_rule_on_request() {
    let seed = 8;
    let opts = RouteOptions {
        jamming_balance: ForceBalance::Largest(1e-3),
        ..options(PreparationRoute::Jammed, 2000, seed)
    };
    let (p, report) = prepare(&opts, &|_| {}).unwrap();
    let m = check_jammed_state(&p, &report, seed);
    assert!(
        m.largest_ratio <= 1e-3 * (1.0 + 1e-6),
        "seed {seed}: max|F|/N_max = {:e}",
        m.largest_ratio
    );
}

#[test]
fn jammed_route_is_bit_identical_on_one_and_two_threads() {
    let bits = |p: &Packing| -> Vec<u64> {
        p.positions
            .iter()
            .flat_map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .chain(p.radii.iter().map(|r| r.to_bits()))
            .chain(
                p.cell
                    .iter()
                    .flat_map(|c| c.lengths.iter().map(|l| l.to_bits())),
            )
            .collect()
    };
    // 1500 spheres: 3 chunks of the fused passes, so the threads really split the work.
    let on = |threads: usize, seed: u64| {
        crate::common::on_threads(threads, || {
            prepare(&options(PreparationRoute::Jammed, 1500, seed), &|_| {}).unwrap()
        })
    };
    let (a, ra) = on(1, 21);
    let (b, rb) = on(2, 21);
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(ra, rb);
    let (c, _) = on(2, 21);
    assert_eq!(bits(&a), bits(&c));
    let (d, _) = on(2, 22);
    assert_ne!(bits(&a), bits(&d));
}

/// The status stream of a jammed preparation (what `anisobond pack` shows on its bar) agrees
/// with the result: stages run gas → compression → jamming stages in order → done, fractions
/// and iteration counts never decrease, the last report of the last jamming stage is the
/// converged state of the final report (residual ≤ 1, its pressure, its solid fraction, all
/// FIRE iterations), and listening changes no bit of the packing.
#[test]
fn status_reports_follow_the_jammed_preparation() {
    let opts = options(PreparationRoute::Jammed, 800, 4);
    let seen = std::sync::Mutex::new(Vec::<RouteStatus>::new());
    let (p, report) =
        prepare_with_status(&opts, &|s: &RouteStatus| seen.lock().unwrap().push(*s)).unwrap();
    let seen = seen.into_inner().unwrap();
    let rank = |s: &RouteStage| match *s {
        RouteStage::Gas => (0, 0),
        RouteStage::Compression { .. } => (1, 0),
        RouteStage::Jamming { stage, .. } => (2, stage),
        RouteStage::Done => (3, 0),
    };
    assert_eq!(seen.first().unwrap().stage, RouteStage::Gas);
    assert_eq!(seen.first().unwrap().fraction, 0.0);
    for w in seen.windows(2) {
        assert!(w[0].fraction <= w[1].fraction, "{:?} then {:?}", w[0], w[1]);
        assert!(
            w[0].iterations <= w[1].iterations,
            "{:?} then {:?}",
            w[0],
            w[1]
        );
        assert!(
            rank(&w[0].stage) <= rank(&w[1].stage),
            "{:?} then {:?}",
            w[0],
            w[1]
        );
    }
    let last = seen.last().unwrap();
    assert_eq!(last.stage, RouteStage::Done);
    assert_eq!(last.fraction, 1.0);
    assert_eq!(last.iterations, report.iterations);
    assert!((last.solid_fraction - p.solid_fraction()).abs() < 1e-12);
    let jamming: Vec<&RouteStatus> = seen
        .iter()
        .filter(|s| matches!(s.stage, RouteStage::Jamming { .. }))
        .collect();
    let end = jamming.last().unwrap();
    match end.stage {
        RouteStage::Jamming {
            stage,
            stages,
            target_pressure,
            pressure,
            residual,
        } => {
            assert_eq!(stage, stages);
            assert!(stages >= 2, "{stages} stages");
            assert!(residual <= 1.0, "residual {residual}");
            assert_eq!(pressure, report.pressure);
            assert_eq!(target_pressure, 0.5 * opts.jamming_pressure);
            assert!((pressure / target_pressure - 1.0).abs() <= 0.5);
        }
        _ => unreachable!(),
    }
    assert_eq!(end.solid_fraction, report.compressed_solid_fraction);
    assert_eq!(end.iterations, report.iterations);
    assert!(seen
        .iter()
        .any(|s| matches!(s.stage, RouteStage::Compression { target_solid_fraction } if target_solid_fraction == 0.55)));
    // The plain call gives the same packing, bit for bit.
    let (q, report_q) = prepare(&opts, &|_| {}).unwrap();
    assert_eq!(p.positions, q.positions);
    assert_eq!(report, report_q);
}

/// Timing study: `cargo test --release --test packing -- --ignored --nocapture routes_jam_fast::`.
#[test]
#[ignore]
fn timing_of_the_routes_for_large_packings() {
    let _alone = crate::common::alone();
    let sizes: Vec<usize> = std::env::var("JAM_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![2000, 10_000, 30_000]);
    for n in sizes {
        for route in [
            PreparationRoute::Unjammed,
            PreparationRoute::WeaklyJammed,
            PreparationRoute::Jammed,
        ] {
            let t = Instant::now();
            let (_, r) = prepare(&options(route, n, 1), &|_| {}).unwrap();
            println!(
                "N {n:>6} {:>13}: {:6.1} s, {:>7} iterations, {} minimisations, φ {:.4}, Z {:.3}, \
                 rattlers {}, P {:.1e}",
                route.as_str(),
                t.elapsed().as_secs_f64(),
                r.iterations,
                r.relaxations,
                r.compressed_solid_fraction,
                r.compressed_coordination,
                r.rattlers,
                r.pressure
            );
        }
    }
}
