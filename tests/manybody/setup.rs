//! Packings and tensors the many-body tests share.

use anisobond::bonds::BondSet;
use anisobond::manybody::{
    DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions, StrainMeasure,
};
use anisobond::packing::Packing;
use anisobond::tensor::{rotation_x, rotation_y, rotation_z, Stiffness6};
use anisobond::{Mat3, Vec3};
use rand::{Rng, SeedableRng};

/// A crystal orientation with no symmetry left (so every one of D's 21 entries is used).
pub fn general_rotation() -> Mat3 {
    rotation_z(0.3) * rotation_y(-0.7) * rotation_x(1.1)
}

/// Nickel-like cubic D (Pa), rotated by [`general_rotation`].
pub fn cubic_d() -> LocalTensor {
    LocalTensor::Cubic {
        c11: 247e9,
        c12: 147e9,
        c44: 125e9,
        rotation: general_rotation(),
    }
}

/// The term with `measure`, degenerate particles excluded.
pub fn term(p: &Packing, b: &BondSet, d: &LocalTensor, measure: StrainMeasure) -> ManyBody {
    ManyBody::new(
        p,
        b,
        d,
        &ManyBodyOptions {
            measure,
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        },
    )
    .unwrap()
}

/// Engineering Voigt vector of a symmetric strain tensor.
pub fn voigt_of(e: &Mat3) -> nalgebra::Vector6<f64> {
    nalgebra::Vector6::new(
        e[(0, 0)],
        e[(1, 1)],
        e[(2, 2)],
        2.0 * e[(1, 2)],
        2.0 * e[(0, 2)],
        2.0 * e[(0, 1)],
    )
}

/// The stress tensor of a Voigt stress vector.
pub fn tensor_of(s: &nalgebra::Vector6<f64>) -> Mat3 {
    Mat3::new(s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2])
}

/// A symmetric strain with every component non-zero, of size `size`.
pub fn general_strain(size: f64) -> Mat3 {
    Mat3::new(1.0, 0.4, -0.3, 0.4, -0.6, 0.25, -0.3, 0.25, 0.8) * size
}

/// Positions displaced by up to ±`amp`/2 per component (seeded) and mapped by `h`, and the
/// branch vectors of that state in the cell deformed by `h`.
pub fn perturbed(
    mb: &ManyBody,
    p: &Packing,
    h: &Mat3,
    amp: f64,
    seed: u64,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let x: Vec<Vec3> = p
        .positions
        .iter()
        .map(|x| {
            h * (x + Vec3::new(
                rng.gen::<f64>() - 0.5,
                rng.gen::<f64>() - 0.5,
                rng.gen::<f64>() - 0.5,
            ) * amp)
        })
        .collect();
    let l = mb.branch_vectors(&x, h).unwrap();
    (x, l)
}

/// Largest |entry| of a 6×6.
pub fn max_abs6(c: &Stiffness6) -> f64 {
    c.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// A gap-bonded random packing (`n`, `seed`) with every tenth particle left with two bonds
/// (its first two), so that the term has degenerate particles to exclude next to others.
pub fn thinned(n: usize, seed: u64) -> (Packing, BondSet) {
    let (p, b) = super::common::bonded::gap_bonded(n, seed);
    let mut kept = vec![0u32; p.len()];
    let mut out = BondSet::default();
    for e in 0..b.len() {
        let ends = [b.i[e] as usize, b.j[e] as usize];
        if ends.iter().any(|&q| q % 10 == 0 && kept[q] >= 2) {
            continue;
        }
        for q in ends {
            kept[q] += 1;
        }
        out.push(b.i[e], b.j[e], b.branch(e), b.image[e]);
    }
    (p, out)
}
