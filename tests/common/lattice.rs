//! Lattice packings, brute-force bonding and uniform springs for the relaxed-solver tests.

use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::tensor::Stiffness6;
use anisobond::Vec3;
use rand::{Rng, SeedableRng};

/// All pairs with surface gap ≤ `gap`, by brute force over the minimum image.
pub fn brute_bonds(p: &Packing, gap: f64) -> BondSet {
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

/// The same springs on every bond (radius 1).
pub fn uniform_springs(n: usize, kn: f64, ks: f64, kr: f64, ktw: f64) -> BondStiffness {
    BondStiffness {
        radius: vec![1.0; n],
        kn: vec![kn; n],
        ks: vec![ks; n],
        kr: vec![kr; n],
        ktw: vec![ktw; n],
    }
}

/// `cells`³ copies of `basis` (fractions of the lattice constant `a`), spheres of radius `r`,
/// jittered by up to ±`jitter`·a/2 (seeded), in a periodic cube.
pub fn lattice(
    basis: &[[f64; 3]],
    cells: usize,
    a: f64,
    r: f64,
    jitter: f64,
    seed: u64,
) -> Packing {
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

/// Face-centred cubic basis.
pub const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];

/// Simple cubic: 4³ touching spheres of radius `r` (bond length 2r), bonded by brute force.
pub fn simple_cubic_bonded(r: f64) -> (Packing, BondSet) {
    let p = lattice(&[[0.0; 3]], 4, 2.0 * r, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    (p, b)
}

/// FCC: 3³ cells of touching spheres of radius `r` (a = 2√2 r), bonded by brute force.
pub fn fcc_bonded(r: f64) -> (Packing, BondSet) {
    let a = 2.0 * std::f64::consts::SQRT_2 * r;
    let p = lattice(&FCC, 3, a, r, 0.0, 0);
    let b = brute_bonds(&p, 1e-3 * r);
    (p, b)
}

/// Jittered FCC (`cells`³ cells, R = 1 mm, a = 2√2 R·1.03, jitter 0.12) bonded with the gap
/// cutoff `gap`·R: a disordered network (Z ≈ 6–12 for gap 0.25; a small gap leaves pruned
/// particles, two-bond particles with a free rotation, and other local modes).
pub fn disordered_fcc(cells: usize, seed: u64, gap: f64) -> (Packing, BondSet) {
    let r = 1e-3;
    let a = 2.0 * std::f64::consts::SQRT_2 * r * 1.03;
    let p = lattice(&FCC, cells, a, r, 0.12, seed);
    let b = brute_bonds(&p, gap * r);
    (p, b)
}

/// Largest |entry|.
pub fn max_abs(c: &Stiffness6) -> f64 {
    c.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// Smallest eigenvalue of the symmetric part.
pub fn min_eigenvalue(c: &Stiffness6) -> f64 {
    let s = (c + c.transpose()) * 0.5;
    nalgebra::SymmetricEigen::new(s).eigenvalues.min()
}
