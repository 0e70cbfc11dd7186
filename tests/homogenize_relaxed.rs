//! The relaxed (static equilibrium) tensor: closed forms on lattices, the bounds and
//! orderings of docs/references.md "Relaxed (static) stiffness: properties to test", and Kruyt's
//! LAF estimates between them.

use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::homogenize::laf::laf_tensor;
use anisobond::homogenize::network::LeverArm;
use anisobond::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use anisobond::homogenize::voigt::voigt_tensor;
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::tensor::Stiffness6;
use anisobond::Vec3;
use rand::{Rng, SeedableRng};

/// All pairs with surface gap ≤ `gap`, by brute force over the minimum image.
fn brute_bonds(p: &Packing, gap: f64) -> BondSet {
    let cell = p.cell.unwrap();
    let mut b = BondSet::default();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let (l, img) = cell.minimum_image(p.positions[j] - p.positions[i]);
            if l.norm() - p.radii[i] - p.radii[j] <= gap {
                b.push(i as u32, j as u32, l, img);
            }
        }
    }
    b
}

fn uniform_springs(n: usize, kn: f64, ks: f64, kr: f64, ktw: f64) -> BondStiffness {
    BondStiffness {
        radius: vec![1.0; n],
        kn: vec![kn; n],
        ks: vec![ks; n],
        kr: vec![kr; n],
        ktw: vec![ktw; n],
    }
}

fn lattice(basis: &[[f64; 3]], cells: usize, a: f64, r: f64, jitter: f64, seed: u64) -> Packing {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut pos = Vec::new();
    let mut rad = Vec::new();
    for i in 0..cells {
        for j in 0..cells {
            for k in 0..cells {
                for b in basis {
                    let d = Vec3::new(
                        rng.gen::<f64>() - 0.5,
                        rng.gen::<f64>() - 0.5,
                        rng.gen::<f64>() - 0.5,
                    );
                    pos.push(
                        Vec3::new(i as f64 + b[0], j as f64 + b[1], k as f64 + b[2]) * a
                            + d * jitter * a,
                    );
                    rad.push(r);
                }
            }
        }
    }
    let l = cells as f64 * a;
    Packing::new(pos, rad, Some(PeriodicCell::new(Vec3::repeat(l)).unwrap())).unwrap()
}

const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];

fn max_abs(c: &Stiffness6) -> f64 {
    c.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

fn min_eigenvalue(c: &Stiffness6) -> f64 {
    let s = (c + c.transpose()) * 0.5;
    nalgebra::SymmetricEigen::new(s).eigenvalues.min()
}

#[test]
fn simple_cubic_and_fcc_relaxed_equal_closed_forms() {
    let r = 1e-3;
    let (kn, kt) = (2e6, 0.8e6);
    // Simple cubic, bond length 2R: C11 = kn/(2R), C12 = 0, C44 = kt/(4R).
    let p = lattice(&[[0.0; 3]], 4, 2.0 * r, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    assert_eq!(b.len(), 3 * 64);
    let res = relaxed_tensor(
        &p,
        &b,
        &uniform_springs(b.len(), kn, kt, 0.0, 0.0),
        &RelaxedOptions::default(),
    )
    .unwrap();
    let tol = 1e-9 * kn / r;
    assert!((res.c[(0, 0)] - kn / (2.0 * r)).abs() < tol);
    assert!(res.c[(0, 1)].abs() < tol);
    assert!(
        (res.c[(3, 3)] - kt / (4.0 * r)).abs() < tol,
        "{}",
        res.c[(3, 3)]
    );
    // FCC: C11 = (kn+kt)/(√2R), C12 = (kn−kt)/(2√2R), C44 = (kn+kt)/(2√2R).
    let a = 2.0 * std::f64::consts::SQRT_2 * r;
    let p = lattice(&FCC, 3, a, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    assert_eq!(b.len(), 6 * p.len());
    let res = relaxed_tensor(
        &p,
        &b,
        &uniform_springs(b.len(), kn, kt, 0.0, 0.0),
        &RelaxedOptions::default(),
    )
    .unwrap();
    let s2r = std::f64::consts::SQRT_2 * r;
    assert!((res.c[(0, 0)] - (kn + kt) / s2r).abs() < tol);
    assert!((res.c[(0, 1)] - (kn - kt) / (2.0 * s2r)).abs() < tol);
    assert!((res.c[(3, 3)] - (kn + kt) / (2.0 * s2r)).abs() < tol);
}

/// Jittered FCC with a gap cutoff: a disordered network with Z around 6–12.
fn disordered(seed: u64, gap: f64) -> (Packing, BondSet) {
    let r = 1e-3;
    let a = 2.0 * std::f64::consts::SQRT_2 * r * 1.03;
    let p = lattice(&FCC, 5, a, r, 0.12, seed);
    let b = brute_bonds(&p, gap * r);
    (p, b)
}

#[test]
fn relaxed_is_below_voigt_symmetric_and_exact_without_fluctuations() {
    let (p, b) = disordered(1, 0.25);
    let k = uniform_springs(b.len(), 1e6, 0.8e6, 0.0, 0.0);
    let voigt = voigt_tensor(&b, &k, p.volume());
    let opts = RelaxedOptions::default();
    let res = relaxed_tensor(&p, &b, &k, &opts).unwrap();
    let scale = max_abs(&voigt);
    // symmetric to 1e-10 relative
    assert!(max_abs(&(res.c - res.c.transpose())) < 1e-10 * scale);
    // voigt − relaxed positive semi-definite, and strictly softer
    assert!(min_eigenvalue(&(voigt - res.c)) > -1e-10 * scale);
    assert!(res.c[(3, 3)] < 0.99 * voigt[(3, 3)]);
    // suppressing fluctuations returns the Voigt sum (all bonds active here)
    if res.null_space.removed_bonds == 0 {
        let affine = relaxed_tensor(
            &p,
            &b,
            &k,
            &RelaxedOptions {
                fluctuations: false,
                ..opts
            },
        )
        .unwrap();
        assert!(max_abs(&(affine.c - voigt)) < 1e-12 * scale);
    }
    // locking rotations or adding rotational springs lands between the two
    let locked = relaxed_tensor(
        &p,
        &b,
        &k,
        &RelaxedOptions {
            rotations: false,
            ..opts
        },
    )
    .unwrap();
    assert!(min_eigenvalue(&(locked.c - res.c)) > -1e-10 * scale);
    assert!(min_eigenvalue(&(voigt - locked.c)) > -1e-10 * scale);
    let kb = uniform_springs(b.len(), 1e6, 0.8e6, 1e6 * 1e-6 * 0.25, 1e6 * 1e-6 * 0.5);
    let bent = relaxed_tensor(&p, &b, &kb, &opts).unwrap();
    assert!(min_eigenvalue(&(bent.c - res.c)) > -1e-10 * scale);
    assert!(min_eigenvalue(&(voigt - bent.c)) > -1e-10 * scale);
}

#[test]
fn relaxed_is_thread_count_independent_and_lever_arms_agree_for_equal_spheres() {
    let (p, b) = disordered(2, 0.25);
    let k = uniform_springs(b.len(), 1e6, 0.5e6, 0.0, 0.0);
    let run = |t: usize, arm| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| {
                relaxed_tensor(
                    &p,
                    &b,
                    &k,
                    &RelaxedOptions {
                        lever_arm: arm,
                        ..Default::default()
                    },
                )
                .unwrap()
                .c
            })
    };
    let c1 = run(1, LeverArm::MidGap);
    assert_eq!(c1, run(2, LeverArm::MidGap));
    let c3 = run(2, LeverArm::Proportional);
    assert!(max_abs(&(c1 - c3)) < 1e-9 * max_abs(&c1));
}

#[test]
fn laf_energy_bounds_relaxed_and_decreases_with_shell_order() {
    let (p, b) = disordered(3, 0.2);
    let k = uniform_springs(b.len(), 1e6, 0.8e6, 0.0, 0.0);
    let relaxed = relaxed_tensor(&p, &b, &k, &RelaxedOptions::default())
        .unwrap()
        .c;
    let scale = max_abs(&relaxed);
    let mut previous: Option<Stiffness6> = None;
    for m in 1..=3 {
        let laf = laf_tensor(&p, &b, &k, LeverArm::MidGap, m).unwrap();
        // energy-based ≥ relaxed (PSD difference), and ≤ affine
        assert!(
            min_eigenvalue(&(laf.c_energy - relaxed)) > -1e-9 * scale,
            "m = {m}"
        );
        assert!(min_eigenvalue(&(laf.c_affine - laf.c_energy)) > -1e-9 * scale);
        if let Some(prev) = previous {
            // trace decreases toward the relaxed one
            assert!(
                laf.c_energy.trace() <= prev.trace() + 1e-9 * scale,
                "m = {m}"
            );
        }
        let rel_err = (laf.c_stress[(3, 3)] - relaxed[(3, 3)]).abs() / relaxed[(3, 3)];
        eprintln!(
            "m = {m}: energy C44/relaxed = {:.4}, stress C44/relaxed = {:.4} (|err| {rel_err:.3}), free particles per shell {:.1}",
            laf.c_energy[(3, 3)] / relaxed[(3, 3)],
            laf.c_stress[(3, 3)] / relaxed[(3, 3)],
            laf.mean_free_particles
        );
        previous = Some(laf.c_energy);
    }
}
