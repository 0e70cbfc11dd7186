//! Voigt sum over bonds against closed forms (docs/references.md "Relaxed (static) stiffness"
//! lattices and "Isotropic closed forms"; Kruyt 2014 Eq. 29; Kumar 2016 appendix).

use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::homogenize::voigt_tensor;
use anisobond::Vec3;
use rand::{Rng, SeedableRng};

fn springs(n: usize, kn: f64, kt: f64) -> BondStiffness {
    BondStiffness {
        radius: vec![1.0; n],
        kn: vec![kn; n],
        ks: vec![kt; n],
        kr: vec![0.0; n],
        ktw: vec![0.0; n],
    }
}

/// Periodic lattice with `cells`³ unit cells of edge `a`, one bond per neighbour vector.
fn lattice(basis: &[Vec3], neighbours: &[Vec3], cells: usize, a: f64) -> (BondSet, f64) {
    let mut bonds = BondSet::default();
    let n_sites = basis.len() * cells * cells * cells;
    // Only the bond vectors matter for the Voigt sum; each site owns half its neighbour
    // vectors (one of each ± pair).
    for k in 0..n_sites as u32 {
        for d in neighbours {
            bonds.push(k, k + 1, *d, [0, 0, 0]);
        }
    }
    let volume = (cells as f64 * a).powi(3);
    (bonds, volume)
}

#[test]
fn simple_cubic_lattice_matches_closed_form() {
    let r = 0.5e-3;
    let (kn, kt) = (2.0e6, 0.7e6);
    let l = 2.0 * r;
    let half = [Vec3::x() * l, Vec3::y() * l, Vec3::z() * l];
    let (bonds, v) = lattice(&[Vec3::zeros()], &half, 4, l);
    let c = voigt_tensor(&bonds, &springs(bonds.len(), kn, kt), v);
    let tol = 1e-12 * kn / r;
    assert!(
        (c[(0, 0)] - kn / (2.0 * r)).abs() < tol,
        "C11 {}",
        c[(0, 0)]
    );
    assert!(c[(0, 1)].abs() < tol, "C12 {}", c[(0, 1)]);
    assert!(
        (c[(3, 3)] - kt / (4.0 * r)).abs() < tol,
        "C44 {}",
        c[(3, 3)]
    );
    assert!((c[(5, 5)] - kt / (4.0 * r)).abs() < tol);
}

#[test]
fn fcc_lattice_matches_closed_form() {
    let r = 1.0e-3;
    let (kn, kt) = (3.0e6, 1.1e6);
    let a = 2.0 * std::f64::consts::SQRT_2 * r; // cubic cell edge, nearest distance 2R
    let h = a / 2.0;
    // The 6 of the 12 neighbour vectors with one sign each.
    let nb = [
        Vec3::new(h, h, 0.0),
        Vec3::new(h, -h, 0.0),
        Vec3::new(h, 0.0, h),
        Vec3::new(h, 0.0, -h),
        Vec3::new(0.0, h, h),
        Vec3::new(0.0, h, -h),
    ];
    let basis = [Vec3::zeros(); 4];
    let (bonds, v) = lattice(&basis, &nb, 3, a);
    let c = voigt_tensor(&bonds, &springs(bonds.len(), kn, kt), v);
    let s2r = std::f64::consts::SQRT_2 * r;
    let tol = 1e-12 * kn / r;
    assert!(
        (c[(0, 0)] - (kn + kt) / s2r).abs() < tol,
        "C11 {}",
        c[(0, 0)]
    );
    assert!(
        (c[(0, 1)] - (kn - kt) / (2.0 * s2r)).abs() < tol,
        "C12 {}",
        c[(0, 1)]
    );
    assert!(
        (c[(3, 3)] - (kn + kt) / (2.0 * s2r)).abs() < tol,
        "C44 {}",
        c[(3, 3)]
    );
    for (i, j) in [(0, 3), (0, 4), (3, 4), (3, 5)] {
        assert!(c[(i, j)].abs() < tol);
    }
}

/// A large random isotropic bond set of equal spheres approaches Kruyt 2014 Eq. 29:
/// K·R/k_n = φZ/(6π), G·R/k_n = φZ(1 + 1.5 k_t/k_n)/(10π), and ν = (1−α)/(4+α).
#[test]
fn random_isotropic_bonds_approach_kruyt_eq29() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let r: f64 = 1e-3;
    let (z, phi) = (6.0, 0.6);
    let n_bonds = 400_000usize;
    let n_particles = 2.0 * n_bonds as f64 / z;
    let volume = n_particles * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) / phi;
    for alpha in [0.0, 0.3, 1.0] {
        let (kn, kt) = (1e6, 1e6 * alpha);
        let mut bonds = BondSet::default();
        // Antithetic pairs (n, −n) are the same bond; use independent uniform normals.
        for b in 0..n_bonds {
            let u: f64 = rng.gen_range(-1.0..1.0);
            let ph: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let s = (1.0 - u * u).sqrt();
            let n = Vec3::new(s * ph.cos(), s * ph.sin(), u);
            bonds.push(b as u32, b as u32 + 1, n * 2.0 * r, [0, 0, 0]);
        }
        let c = voigt_tensor(&bonds, &springs(n_bonds, kn, kt), volume);
        // Isotropic part of an arbitrary C: K = (C11+C22+C33 + 2(C12+C13+C23))/9,
        // G = (C11+C22+C33 − (C12+C13+C23) + 3(C44+C55+C66))/15 (Voigt averages).
        let tr1 = c[(0, 0)] + c[(1, 1)] + c[(2, 2)];
        let tr2 = c[(0, 1)] + c[(0, 2)] + c[(1, 2)];
        let tr3 = c[(3, 3)] + c[(4, 4)] + c[(5, 5)];
        let k = (tr1 + 2.0 * tr2) / 9.0;
        let g = (tr1 - tr2 + 3.0 * tr3) / 15.0;
        let pi = std::f64::consts::PI;
        let k_exact = phi * z * kn / (6.0 * pi * r);
        let g_exact = phi * z * kn * (1.0 + 1.5 * alpha) / (10.0 * pi * r);
        assert!((k / k_exact - 1.0).abs() < 1e-9, "K {k} vs {k_exact}");
        assert!((g / g_exact - 1.0).abs() < 1e-9, "G {g} vs {g_exact}");
        let nu = (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g));
        assert!((nu - (1.0 - alpha) / (4.0 + alpha)).abs() < 1e-9, "ν {nu}");
        // Anisotropic remainder of a finite random set is statistical: O(1/√N_b).
        assert!((c[(0, 0)] - c[(1, 1)]).abs() / c[(0, 0)] < 0.01);
        assert!(c[(0, 3)].abs() / c[(0, 0)] < 0.01);
    }
}

#[test]
fn voigt_sum_is_thread_count_independent() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut bonds = BondSet::default();
    for b in 0..50_000u32 {
        let v = Vec3::new(
            rng.gen::<f64>() - 0.5,
            rng.gen::<f64>() - 0.5,
            rng.gen::<f64>() - 0.5,
        );
        bonds.push(b, b + 1, v, [0, 0, 0]);
    }
    let k = springs(bonds.len(), 1e6, 3e5);
    let run = |t| crate::common::on_threads(t, || voigt_tensor(&bonds, &k, 1.0));
    assert_eq!(run(1), run(2));
}
