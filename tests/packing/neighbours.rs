//! Cell-list neighbour search against an O(N²) brute force, and thread-count independence.

use anisobond::packing::{pairs_within, pairs_within_centre_distance, Pair};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random (overlapping) spheres in a box of side `side`, radii uniform in [r_lo, r_hi].
fn random_packing(seed: u64, n: usize, side: f64, r_lo: f64, r_hi: f64, periodic: bool) -> Packing {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let positions: Vec<Vec3> = (0..n)
        .map(|_| {
            Vec3::new(
                rng.gen::<f64>() * side,
                rng.gen::<f64>() * side,
                rng.gen::<f64>() * side,
            )
        })
        .collect();
    let radii: Vec<f64> = (0..n).map(|_| rng.gen_range(r_lo..=r_hi)).collect();
    let cell = periodic.then(|| PeriodicCell::new(Vec3::repeat(side)).unwrap());
    Packing::new(positions, radii, cell).unwrap()
}

/// Every pair i < j tested directly; the periodic image from the minimum-image rule.
fn brute_force(p: &Packing, max_gap_of: impl Fn(f64, f64) -> f64) -> Vec<Pair> {
    let mut out = Vec::new();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = p.positions[j] - p.positions[i];
            let (branch, image) = match &p.cell {
                Some(c) => c.minimum_image(d),
                None => (d, [0; 3]),
            };
            let (ri, rj) = (p.radii[i], p.radii[j]);
            if branch.norm() - (ri + rj) <= max_gap_of(ri, rj) {
                out.push(Pair {
                    i: i as u32,
                    j: j as u32,
                    branch,
                    image,
                });
            }
        }
    }
    out
}

#[test]
fn matches_brute_force_periodic_and_free_polydisperse() {
    for (seed, periodic) in [(1u64, true), (2, false), (3, true), (4, false)] {
        let p = random_packing(seed, 1500, 20.0, 0.3, 1.0, periodic);
        for gap in [0.0, 0.17, 0.9] {
            let found = pairs_within(&p, |_, _| gap, gap).unwrap();
            let expected = brute_force(&p, |_, _| gap);
            assert!(!expected.is_empty());
            assert_eq!(found, expected, "seed {seed} periodic {periodic} gap {gap}");
        }
        // A per-pair threshold (gap proportional to the radii sum).
        let found = pairs_within(&p, |a, b| 0.2 * (a + b), 0.4).unwrap();
        assert_eq!(found, brute_force(&p, |a, b| 0.2 * (a + b)));
    }
}

#[test]
fn periodic_pairs_across_the_boundary_have_images() {
    // Two spheres near opposite faces touch through the boundary.
    let cell = PeriodicCell::new(Vec3::new(10.0, 10.0, 10.0)).unwrap();
    let p = Packing::new(
        vec![Vec3::new(0.4, 5.0, 5.0), Vec3::new(9.7, 5.0, 5.0)],
        vec![0.5, 0.5],
        Some(cell),
    )
    .unwrap();
    let pairs = pairs_within(&p, |_, _| 0.0, 0.0).unwrap();
    assert_eq!(pairs.len(), 1);
    assert_eq!(pairs[0].image, [-1, 0, 0]);
    assert!((pairs[0].branch - Vec3::new(-0.7, 0.0, 0.0)).norm() < 1e-12);
}

#[test]
fn small_cells_fall_back_and_large_cutoffs_are_refused() {
    // 2 cells per dimension (cell only ~2.5 cutoffs wide): still equal to brute force.
    let p = random_packing(7, 60, 5.0, 0.4, 0.6, true);
    let found = pairs_within(&p, |_, _| 0.8, 0.8).unwrap();
    assert_eq!(found, brute_force(&p, |_, _| 0.8));
    // Cutoff 2·0.6 + 1.4 = 2.6 ≥ L/2 = 2.5: not unique, refused with a clear message.
    let err = pairs_within(&p, |_, _| 1.4, 1.4).unwrap_err().to_string();
    assert!(err.contains("half the periodic cell length"), "{err}");
}

#[test]
fn centre_distance_predicate_matches_brute_force() {
    let p = random_packing(11, 800, 12.0, 0.5, 1.0, true);
    let kappa = 1.3;
    let found =
        pairs_within_centre_distance(&p, kappa * 2.0, |a, b, d| d <= kappa * (a + b)).unwrap();
    let expected: Vec<Pair> = brute_force(&p, |a, b| (kappa - 1.0) * (a + b))
        .into_iter()
        .filter(|q| q.distance() <= kappa * (p.radii[q.i as usize] + p.radii[q.j as usize]))
        .collect();
    assert_eq!(found, expected);
}

#[test]
fn independent_of_thread_count() {
    let p = random_packing(5, 20_000, 40.0, 0.4, 0.8, true);
    let run = |threads: usize| {
        crate::common::on_threads(threads, || pairs_within(&p, |_, _| 0.2, 0.2).unwrap())
    };
    let one = run(1);
    let two = run(2);
    assert!(one.len() > 1000);
    assert_eq!(one.len(), two.len());
    for (a, b) in one.iter().zip(&two) {
        assert_eq!((a.i, a.j, a.image), (b.i, b.j, b.image));
        assert_eq!(a.branch.map(f64::to_bits), b.branch.map(f64::to_bits));
    }
}

#[test]
fn degenerate_inputs() {
    let empty = Packing::new(vec![], vec![], None).unwrap();
    assert!(pairs_within(&empty, |_, _| 1.0, 1.0).unwrap().is_empty());
    // All spheres on a plane (zero extent in z) in a free assembly.
    let positions: Vec<Vec3> = (0..10).map(|k| Vec3::new(k as f64, 0.0, 0.0)).collect();
    let p = Packing::new(positions, vec![0.5; 10], None).unwrap();
    let pairs = pairs_within(&p, |_, _| 1e-9, 1e-9).unwrap();
    assert_eq!(pairs.len(), 9);
    assert!(pairs_within(&p, |_, _| f64::NAN, f64::NAN).is_err());
}

/// The neighbour search's minimum image by comparisons is `minimum_image` bit for bit on
/// every difference of two positions inside the cell, halves (±L/2) and ±L included.
#[test]
fn minimum_image_near_is_minimum_image() {
    let cell = PeriodicCell::new(Vec3::new(0.7, 1.3, 0.059523)).expect("cell");
    let l = cell.lengths;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut cases: Vec<Vec3> = (0..20_000)
        .map(|_| {
            Vec3::new(
                (rng.gen::<f64>() * 2.0 - 1.0) * l.x * 1.49,
                (rng.gen::<f64>() * 2.0 - 1.0) * l.y * 1.49,
                (rng.gen::<f64>() * 2.0 - 1.0) * l.z * 1.49,
            )
        })
        .collect();
    for f in [-1.0, -0.5, 0.0, 0.5, 1.0] {
        cases.push(l * f);
        cases.push(Vec3::new(l.x * f, -l.y * f, 0.5 * l.z));
    }
    for d in cases {
        let (a, ia) = cell.minimum_image(d);
        let (b, ib) = cell.minimum_image_near(d);
        assert_eq!(ia, ib, "image of {d:?}");
        for k in 0..3 {
            assert_eq!(a[k].to_bits(), b[k].to_bits(), "component {k} of {d:?}");
        }
    }
}
