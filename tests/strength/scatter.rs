//! Seeded scatter: the sample mean, CV, median and Weibull modulus recovered within
//! statistical bounds for a fixed seed; the same strengths on 1 and 2 rayon threads.

use anisobond::strength::scatter::gamma;
use anisobond::strength::{strengths_along, Scatter, Strength, StrengthSpec};
use anisobond::Vec3;

const N: u64 = 40_000;

fn sample(s: &Scatter) -> Vec<f64> {
    (0..N).map(|b| s.factor(b)).collect()
}

fn mean_cv(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt() / mean)
}

fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
}

#[test]
fn gamma_matches_known_values() {
    let sqrt_pi = std::f64::consts::PI.sqrt();
    for (x, want) in [
        (1.0, 1.0),
        (2.0, 1.0),
        (5.0, 24.0),
        (0.5, sqrt_pi),
        (1.5, 0.5 * sqrt_pi),
        (2.5, 0.75 * sqrt_pi),
    ] {
        assert!(
            (gamma(x) / want - 1.0).abs() < 1e-13,
            "Γ({x}) = {}",
            gamma(x)
        );
    }
}

#[test]
fn weibull_factors_recover_mean_cv_median_and_modulus() {
    // m = 2 (Rayleigh): scale λ = 1/Γ(3/2) = 2/√π, CV = √(4/π − 1), median λ√(ln 2).
    // m = 1 (exponential): mean 1, CV 1, median ln 2.
    let pi = std::f64::consts::PI;
    for (m, cv, med) in [
        (
            2.0,
            (4.0 / pi - 1.0).sqrt(),
            2.0 / pi.sqrt() * 2f64.ln().sqrt(),
        ),
        (1.0, 1.0, 2f64.ln()),
    ] {
        let x = sample(&Scatter::Weibull {
            modulus: m,
            seed: 11,
        });
        assert!(x.iter().all(|&v| v > 0.0 && v.is_finite()));
        let (mean, got_cv) = mean_cv(&x);
        // 4 standard errors: σ/√N for the mean.
        let se = cv / (N as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * se, "m = {m}: mean {mean}");
        assert!(
            (got_cv - cv).abs() < 0.03 * cv,
            "m = {m}: cv {got_cv} vs {cv}"
        );
        assert!((median(&x) / med - 1.0).abs() < 0.02, "m = {m}: median");
        // The modulus from the Weibull plot: ln(−ln(1 − F)) = m·ln x − m·ln λ, least squares
        // over the central 98 % of the order statistics.
        let mut v = x.clone();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let (mut sx, mut sy, mut sxx, mut sxy, mut k) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, xi) in v.iter().enumerate().take(n * 99 / 100).skip(n / 100) {
            let f = (i as f64 + 0.5) / n as f64;
            let (px, py) = (xi.ln(), (-(1.0 - f).ln()).ln());
            sx += px;
            sy += py;
            sxx += px * px;
            sxy += px * py;
            k += 1.0;
        }
        let slope = (k * sxy - sx * sy) / (k * sxx - sx * sx);
        assert!(
            (slope / m - 1.0).abs() < 0.03,
            "m = {m}: fitted modulus {slope}"
        );
    }
}

/// Standard normal density and, by Simpson's rule, its distribution function.
fn phi(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}
fn big_phi(z: f64) -> f64 {
    let (a, n) = (-12.0, 20_000);
    let h = (z - a) / n as f64;
    let mut s = phi(a) + phi(z);
    for k in 1..n {
        s += phi(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn normal_factors_recover_mean_and_cv_and_are_truncated_at_zero() {
    let x = sample(&Scatter::Normal { cv: 0.1, seed: 5 });
    let (mean, cv) = mean_cv(&x);
    assert!((mean - 1.0).abs() < 4.0 * 0.1 / (N as f64).sqrt(), "{mean}");
    assert!((cv - 0.1).abs() < 0.003, "{cv}");
    // cv = 0.6: about 5 % of the raw draws are ≤ 0 and are drawn again; the truncated mean
    // is 1 + cv·φ(1/cv)/Φ(1/cv) and the standard deviation cv·√(1 − zφ/Φ... ) is not needed.
    let cv = 0.6;
    let x = sample(&Scatter::Normal { cv, seed: 5 });
    assert!(x.iter().all(|&v| v > 0.0));
    let z = 1.0 / cv;
    let want = 1.0 + cv * phi(z) / big_phi(z);
    let (mean, _) = mean_cv(&x);
    assert!(
        (mean - want).abs() < 4.0 * cv / (N as f64).sqrt(),
        "{mean} vs {want}"
    );
    assert!(
        want - 1.0 > 10.0 * cv / (N as f64).sqrt(),
        "the shift is resolved"
    );
}

#[test]
fn factors_depend_on_seed_and_bond_only_and_not_on_threads() {
    let n = 50_000;
    let start: Vec<Vec3> = (0..n).map(|b| Vec3::new(b as f64, 0.0, 0.0)).collect();
    let branch: Vec<Vec3> = (0..n)
        .map(|b| Vec3::new(1.0, (b % 7) as f64, (b % 3) as f64))
        .collect();
    let spec = |seed| StrengthSpec {
        scatter: Some(Scatter::Weibull { modulus: 4.0, seed }),
        ..StrengthSpec::isotropic(Strength::new(1.0e6, 2.0e6)).unwrap()
    };
    let on = |threads: usize, seed: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| strengths_along(&spec(seed), &start, &branch).unwrap())
    };
    let one = on(1, 3);
    let two = on(2, 3);
    assert_eq!(one, two);
    // Each bond's factor is the scatter's factor of its index: the strengths scale by it.
    let s = Scatter::Weibull {
        modulus: 4.0,
        seed: 3,
    };
    for b in [0, 1, 17, n - 1] {
        assert_eq!(one.tensile[b], 1.0e6 * s.factor(b as u64));
        assert_eq!(one.cohesion[b], 2.0e6 * s.factor(b as u64));
    }
    assert_ne!(on(1, 4).tensile, one.tensile);
    // Refusals.
    assert!(Scatter::Weibull {
        modulus: 0.0,
        seed: 1
    }
    .checked()
    .is_err());
    assert!(Scatter::Normal { cv: -0.1, seed: 1 }.checked().is_err());
    assert!(Scatter::Normal {
        cv: f64::NAN,
        seed: 1
    }
    .checked()
    .is_err());
}
