//! Orientations: the Bunge matrix against its closed form and hand-computed cases, uniform
//! SO(3) sampling against the Haar moments, fibre orientations against their definition,
//! and seeded reproducibility.

use super::common::bonded::generated;
use super::{isotropic_model, model};
use anisobond::grains::{bunge_deg, fibre_orientation, uniform_orientation};
use anisobond::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The Bunge matrix written out (Bunge 1982 Eq. 2.39; rows the crystal axes in sample
/// coordinates): angles in degrees.
fn closed_form(phi1: f64, big_phi: f64, phi2: f64) -> Mat3 {
    let (s1, c1) = phi1.to_radians().sin_cos();
    let (s, c) = big_phi.to_radians().sin_cos();
    let (s2, c2) = phi2.to_radians().sin_cos();
    Mat3::new(
        c1 * c2 - s1 * s2 * c,
        s1 * c2 + c1 * s2 * c,
        s2 * s,
        -c1 * s2 - s1 * c2 * c,
        -s1 * s2 + c1 * c2 * c,
        c2 * s,
        s1 * s,
        -c1 * s,
        c,
    )
}

#[test]
fn bunge_matrix_is_the_closed_form_and_maps_sample_to_crystal() {
    for a in [
        [0.0, 0.0, 0.0],
        [30.0, 40.0, 50.0],
        [200.0, 135.0, 10.0],
        [-75.0, 91.0, 333.0],
    ] {
        let g = bunge_deg(a[0], a[1], a[2]);
        let h = closed_form(a[0], a[1], a[2]);
        assert!((g - h).amax() < 1e-15, "{a:?}: {g} vs {h}");
        assert!((g.transpose() * g - Mat3::identity()).amax() < 1e-15);
        assert!((g.determinant() - 1.0).abs() < 1e-15);
    }
    // By hand: φ1 = 90° turns the crystal frame +90° about z: the crystal x axis is the
    // sample y axis, so the sample x axis has crystal coordinates (0, −1, 0).
    let g = bunge_deg(90.0, 0.0, 0.0);
    assert!((g * Vec3::x() - Vec3::new(0.0, -1.0, 0.0)).amax() < 1e-15);
    assert!((g * Vec3::y() - Vec3::new(1.0, 0.0, 0.0)).amax() < 1e-15);
    // Φ = 90°: the crystal z axis (third row of g) is the sample −y axis.
    let g = bunge_deg(0.0, 90.0, 0.0);
    assert!((g.row(2).transpose() - Vec3::new(0.0, -1.0, 0.0)).amax() < 1e-15);
}

/// Haar moments of uniform rotations: E[R] = 0 (each entry's variance 1/3) and
/// E[R_ij²] = 1/3 (variance 1/5 − 1/9 = 4/45); a sampler uniform in the Euler angles
/// instead would give E[R_33²] = 1/2. Bounds: 5 standard errors over N samples.
#[test]
fn uniform_rotations_have_the_haar_moments() {
    let n = 20000;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let samples: Vec<Mat3> = (0..n).map(|_| uniform_orientation(&mut rng)).collect();
    let mean = samples.iter().fold(Mat3::zeros(), |a, r| a + r) / n as f64;
    let squares = samples
        .iter()
        .fold(Mat3::zeros(), |a, r| a + r.component_mul(r))
        / n as f64;
    let n = n as f64;
    for k in 0..9 {
        assert!(
            mean[k].abs() < 5.0 * (1.0 / (3.0 * n)).sqrt(),
            "E[R]: {mean}"
        );
        assert!(
            (squares[k] - 1.0 / 3.0).abs() < 5.0 * (4.0 / (45.0 * n)).sqrt(),
            "E[R²]: {squares}"
        );
    }
    for r in &samples {
        assert!((r.transpose() * r - Mat3::identity()).amax() < 1e-12);
        assert!(r.determinant() > 0.0);
    }
    // Seeded: the same stream gives the same rotations.
    let mut again = ChaCha8Rng::seed_from_u64(1);
    assert_eq!(uniform_orientation(&mut again), samples[0]);
}

/// A fibre orientation with no spread puts the crystal direction on the sample axis
/// (gᵀ·d = a) and turns about it uniformly: the crystal's other axes average to 0.
#[test]
fn fibre_orientations_put_the_direction_on_the_axis() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let a = Vec3::new(1.0, 2.0, 2.0) / 3.0;
    let d = Vec3::new(1.0, 1.0, 0.0).normalize();
    let n = 4000;
    let mut mean_x = Vec3::zeros();
    for _ in 0..n {
        let g = fibre_orientation(&mut rng, &a, &d, 0.0);
        assert!((g.transpose() * d - a).amax() < 1e-14);
        assert!((g.transpose() * g - Mat3::identity()).amax() < 1e-14);
        mean_x += g.transpose() * Vec3::new(1.0, -1.0, 0.0).normalize();
    }
    // A crystal direction across the fibre: uniform on the circle about a, mean 0
    // (each sample-frame component of variance ≤ 1/2).
    assert!((mean_x / n as f64).amax() < 5.0 * (0.5 / n as f64).sqrt());
    // A spread σ: the tilt of d off a has E[θ²] = 2σ² (Rayleigh), within 5 standard errors.
    let sigma: f64 = 5.0;
    let n = 4000;
    let theta2: Vec<f64> = (0..n)
        .map(|_| {
            let g = fibre_orientation(&mut rng, &Vec3::z(), &Vec3::z(), sigma);
            let t = (g.transpose() * Vec3::z())
                .dot(&Vec3::z())
                .clamp(-1.0, 1.0)
                .acos();
            t.to_degrees().powi(2)
        })
        .collect();
    let m = theta2.iter().sum::<f64>() / n as f64;
    // θ² of a Rayleigh(σ) variable is exponential with mean 2σ² and standard deviation 2σ².
    let expected = 2.0 * sigma * sigma;
    assert!(
        (m - expected).abs() < 5.0 * expected / (n as f64).sqrt(),
        "{m} vs {expected}"
    );
}

/// The grains of a seeded model are reproducible; another seed gives others.
#[test]
fn seeded_grains_are_reproducible() {
    let p = generated(500, 31);
    let grains = |seed: u64| {
        let text = isotropic_model(&format!("[grains]\ncount = 20\nseed = {seed}\n"));
        Assembly::new(p.clone(), model(&text))
            .unwrap()
            .grains()
            .unwrap()
            .clone()
    };
    let (a, b, c) = (grains(9), grains(9), grains(10));
    assert_eq!(a, b);
    assert_ne!(a.orientation, c.orientation);
    assert_ne!(a.grain, c.grain);
}
