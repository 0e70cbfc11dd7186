//! Bonding rules: brute force, lattices with known coordination, coordination targets.

use anisobond::bonds::{build_bonds, coordination_gap, COORDINATION_MAX_GAP};
use anisobond::bonds::{BondSet, BondingRule};
use anisobond::packing::{generate, GenerateOptions};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::{Error, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random non-overlapping polydisperse spheres (random sequential addition; keep the
/// solid fraction below ~0.3 or it never finishes).
fn rsa_packing(seed: u64, n: usize, side: f64, periodic: bool) -> Packing {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let cell = PeriodicCell::new(Vec3::repeat(side)).unwrap();
    let mut pos: Vec<Vec3> = Vec::new();
    let mut rad: Vec<f64> = Vec::new();
    while pos.len() < n {
        let x = Vec3::new(
            rng.gen::<f64>() * side,
            rng.gen::<f64>() * side,
            rng.gen::<f64>() * side,
        );
        let r = rng.gen_range(0.8..1.2);
        let free = pos.iter().zip(&rad).all(|(y, ry)| {
            let d = if periodic {
                cell.minimum_image(y - x).0
            } else {
                y - x
            };
            d.norm() >= r + ry
        });
        if free {
            pos.push(x);
            rad.push(r);
        }
    }
    Packing::new(pos, rad, periodic.then_some(cell)).unwrap()
}

/// All bonds by the O(N²) definition, as (i, j, image) keys.
fn brute(p: &Packing, bonded: impl Fn(f64, f64, f64) -> bool) -> Vec<(u32, u32, [i32; 3])> {
    let mut out = Vec::new();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = p.positions[j] - p.positions[i];
            let (l, image) = match &p.cell {
                Some(c) => c.minimum_image(d),
                None => (d, [0; 3]),
            };
            if bonded(p.radii[i], p.radii[j], l.norm()) {
                out.push((i as u32, j as u32, image));
            }
        }
    }
    out
}

fn keys(b: &BondSet) -> Vec<(u32, u32, [i32; 3])> {
    (0..b.len()).map(|k| (b.i[k], b.j[k], b.image[k])).collect()
}

#[test]
fn gap_and_factor_match_brute_force() {
    for periodic in [true, false] {
        let p = rsa_packing(9, 700, 24.0, periodic);
        let r_bar = p.mean_radius();
        let g = 0.3;
        let bonds = build_bonds(&p, BondingRule::Gap(g)).unwrap();
        assert_eq!(keys(&bonds), brute(&p, |a, b, d| d - (a + b) <= g * r_bar));
        assert!(!bonds.is_empty());
        let kappa = 1.15;
        let bonds = build_bonds(&p, BondingRule::Factor(kappa)).unwrap();
        assert_eq!(keys(&bonds), brute(&p, |a, b, d| d <= kappa * (a + b)));
        // Normals are unit and point from i to the image of j; lengths are centre distances.
        for k in 0..bonds.len() {
            let (i, j) = (bonds.i[k] as usize, bonds.j[k] as usize);
            let shift = p.cell.map_or(Vec3::zeros(), |c| c.shift(bonds.image[k]));
            let l = p.positions[j] + shift - p.positions[i];
            assert!((bonds.branch(k) - l).norm() < 1e-12);
            assert!((bonds.normal[k].norm() - 1.0).abs() < 1e-14);
        }
    }
}

/// Periodic lattice of touching spheres (radius 1) from a basis, n×n×n unit cells of side a.
fn lattice(basis: &[[f64; 3]], a: f64, n: usize) -> Packing {
    let mut pos = Vec::new();
    for ix in 0..n {
        for iy in 0..n {
            for iz in 0..n {
                for b in basis {
                    pos.push(Vec3::new(
                        (ix as f64 + b[0]) * a,
                        (iy as f64 + b[1]) * a,
                        (iz as f64 + b[2]) * a,
                    ));
                }
            }
        }
    }
    let cell = PeriodicCell::new(Vec3::repeat(n as f64 * a)).unwrap();
    let len = pos.len();
    Packing::new(pos, vec![1.0; len], Some(cell)).unwrap()
}

#[test]
fn simple_cubic_and_fcc_coordination() {
    // Simple cubic: nearest neighbours at 2R (6 of them), next at 2√2 R (gap 0.83 R).
    let sc = lattice(&[[0.0, 0.0, 0.0]], 2.0, 4);
    let b = build_bonds(&sc, BondingRule::Gap(0.01)).unwrap();
    assert_eq!(b.len(), 64 * 3);
    assert_eq!(b.coordination(64), 6.0);
    assert!(b.degrees(64).iter().all(|&d| d == 6));
    // FCC with touching spheres: cube side 2√2 R, 12 neighbours at 2R, next at 2√2 R.
    let fcc = lattice(
        &[
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.5],
            [0.0, 0.5, 0.5],
        ],
        2.0 * 2f64.sqrt(),
        4,
    );
    let b = build_bonds(&fcc, BondingRule::Gap(0.01)).unwrap();
    assert_eq!(b.coordination(256), 12.0);
    assert!(b.degrees(256).iter().all(|&d| d == 12));
    // Factor rule: κ = 1.01 gives the same shells.
    assert_eq!(
        build_bonds(&fcc, BondingRule::Factor(1.01)).unwrap().len(),
        b.len()
    );
    // Coordination target 12 on FCC is met exactly (ties: the whole first shell).
    let b = build_bonds(&fcc, BondingRule::Coordination(12.0)).unwrap();
    assert_eq!(b.coordination(256), 12.0);
    // A target between shells takes the closest achievable count: on simple cubic the
    // counts are Z = 0 or 6 (then 18), so Z = 4 gives the first shell.
    let b = build_bonds(&sc, BondingRule::Coordination(4.0)).unwrap();
    assert_eq!(b.coordination(64), 6.0);
}

#[test]
fn coordination_target_is_hit_within_two_over_n() {
    // A dense random packing (φ = 0.6), where Z up to ~9 lies within a gap of 1.0 R̄.
    let opts = GenerateOptions {
        n_particles: 600,
        seed: 4,
        ..GenerateOptions::default()
    };
    let p = generate(&opts, &|_| {}).unwrap();
    let n = p.len();
    for z in [2.0, 4.5, 7.7] {
        let b = build_bonds(&p, BondingRule::Coordination(z)).unwrap();
        assert!(
            (b.coordination(n) - z).abs() <= 2.0 / n as f64,
            "Z {}",
            b.coordination(n)
        );
        // The gap returned rebuilds the same bonds through the gap rule.
        let g = coordination_gap(&p, z).unwrap();
        assert!(g > 0.0 && g < COORDINATION_MAX_GAP);
        let again = build_bonds(&p, BondingRule::Gap(g)).unwrap();
        assert_eq!(keys(&again), keys(&b));
    }
    // Unreachable within 1.0 R̄: refused with the Z that was reachable.
    let err = build_bonds(&p, BondingRule::Coordination(40.0)).unwrap_err();
    assert!(matches!(err, Error::Model(_)));
    assert!(err.to_string().contains("unreachable"), "{err}");
}

/// The coordination rule against a brute force over every pair: the pairs sorted by gap
/// (ties by (i, j, image)), the admissible count nearest N·Z/2 (where the gap strictly
/// increases), the cutoff midway to the next pair. Targets on both sides of the rule's
/// first search (gaps up to 0.3 R̄) must give the same pairs and the same cutoff bits.
#[test]
fn coordination_matches_brute_force_on_both_sides_of_the_first_search() {
    let opts = GenerateOptions {
        n_particles: 500,
        seed: 8,
        ..GenerateOptions::default()
    };
    let p = generate(&opts, &|_| {}).unwrap();
    let cell = p.cell.as_ref().expect("periodic");
    let (n, r_bar) = (p.len(), p.mean_radius());
    // (gap / R̄, (i, j, image)).
    type Key = (u32, u32, [i32; 3]);
    let mut all: Vec<(f64, Key)> = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let (branch, image) = cell.minimum_image(p.positions[j] - p.positions[i]);
            let gap = (branch.norm() - p.radii[i] - p.radii[j]) / r_bar;
            if gap <= COORDINATION_MAX_GAP {
                all.push((gap, (i as u32, j as u32, image)));
            }
        }
    }
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut sides = [false; 2];
    for z in [1.0, 3.0, 6.0, 7.5, 9.0, 10.5] {
        let target = z * n as f64 / 2.0;
        let mut best = (0usize, target);
        for k in 1..all.len() {
            let miss = (k as f64 - target).abs();
            if all[k - 1].0 < all[k].0 && miss < best.1 {
                best = (k, miss);
            }
        }
        let k = best.0;
        assert!(k > 0 && k < all.len(), "Z = {z} within the candidates");
        let want_gap = 0.5 * (all[k - 1].0 + all[k].0);
        sides[usize::from(want_gap > 0.3)] = true;
        let mut want: Vec<_> = all[..k].iter().map(|(_, key)| *key).collect();
        want.sort();
        let b = build_bonds(&p, BondingRule::Coordination(z)).unwrap();
        assert_eq!(keys(&b), want, "Z = {z}");
        let g = coordination_gap(&p, z).unwrap();
        assert_eq!(
            g.to_bits(),
            want_gap.to_bits(),
            "Z = {z}: cutoff {g} against {want_gap}"
        );
    }
    assert_eq!(
        sides,
        [true, true],
        "targets below and above a 0.3 R̄ cutoff"
    );
}

#[test]
fn invalid_values_and_coincident_spheres_are_refused() {
    let p = rsa_packing(1, 50, 10.0, true);
    for rule in [
        BondingRule::Gap(0.0),
        BondingRule::Gap(-0.1),
        BondingRule::Gap(f64::NAN),
        BondingRule::Factor(0.0),
        BondingRule::Factor(f64::INFINITY),
        BondingRule::Coordination(-3.0),
        BondingRule::Coordination(f64::NAN),
    ] {
        let err = build_bonds(&p, rule).unwrap_err();
        assert!(
            err.to_string().contains("must be finite and > 0"),
            "{rule:?}: {err}"
        );
    }
    let q = Packing::new(
        vec![
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(3.0, 1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
        ],
        vec![1.0; 3],
        None,
    )
    .unwrap();
    let err = build_bonds(&q, BondingRule::Gap(0.1))
        .unwrap_err()
        .to_string();
    assert!(err.contains("spheres 0 and 2 are coincident"), "{err}");
}
