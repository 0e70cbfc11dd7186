//! Seeded random scatter of bond strengths: each bond's strengths (not its friction) are
//! multiplied by a random factor of mean 1 (before truncation), drawn from a generator
//! seeded by the seed and the bond's index alone, so that the factors do not depend on the
//! thread count or on the order in which bonds are visited.

use crate::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The distribution of the strength factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scatter {
    /// Weibull with modulus (shape) m and mean 1: scale λ = 1/Γ(1 + 1/m), factor
    /// λ·(−ln(1 − u))^(1/m) for u uniform in [0, 1).
    Weibull {
        /// Weibull modulus m > 0.
        modulus: f64,
        /// Seed.
        seed: u64,
    },
    /// Normal with mean 1 and coefficient of variation `cv`, truncated at zero: a draw ≤ 0
    /// is drawn again (so the mean is slightly above 1 when cv is large: 1 + cv·φ(1/cv)/Φ(1/cv)).
    Normal {
        /// Coefficient of variation (standard deviation / mean) ≥ 0.
        cv: f64,
        /// Seed.
        seed: u64,
    },
}

/// The generator of bond `index`: ChaCha8 keyed by the seed, its stream chosen by the
/// index (independent streams, no correlation between neighbouring bonds).
fn bond_rng(seed: u64, index: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

/// Γ(x) for x ≥ 1 by the Lanczos approximation (g = 7, 9 terms; relative error ~1e-15).
pub fn gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return std::f64::consts::PI / ((std::f64::consts::PI * x).sin() * gamma(1.0 - x));
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (k, c) in C.iter().enumerate().skip(1) {
        a += c / (x + k as f64);
    }
    (2.0 * std::f64::consts::PI).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

impl Scatter {
    /// Refuses a Weibull modulus not finite and > 0 or a CV not finite and ≥ 0.
    pub fn checked(self) -> Result<Scatter> {
        match self {
            Scatter::Weibull { modulus, .. } if !(modulus.is_finite() && modulus > 0.0) => {
                Err(Error::Model(format!(
                    "strength scatter: Weibull modulus = {modulus}, expected a finite value > 0"
                )))
            }
            Scatter::Normal { cv, .. } if !(cv.is_finite() && cv >= 0.0) => Err(Error::Model(
                format!("strength scatter: cv = {cv}, expected a finite value >= 0"),
            )),
            ok => Ok(ok),
        }
    }

    /// The strength factor of bond `index` (> 0).
    pub fn factor(&self, index: u64) -> f64 {
        match *self {
            Scatter::Weibull { modulus, seed } => {
                let mut rng = bond_rng(seed, index);
                let scale = 1.0 / gamma(1.0 + 1.0 / modulus);
                loop {
                    // Inverse CDF; a draw of exactly 0 (u = 0) is drawn again, so every
                    // factor is > 0.
                    let u: f64 = rng.gen();
                    let f = scale * (-(-u).ln_1p()).powf(1.0 / modulus);
                    if f > 0.0 {
                        return f;
                    }
                }
            }
            Scatter::Normal { cv, seed } => {
                let mut rng = bond_rng(seed, index);
                loop {
                    // Box–Muller: u1 in (0, 1] so that ln(u1) is finite.
                    let u1: f64 = 1.0 - rng.gen::<f64>();
                    let u2: f64 = rng.gen();
                    let z = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                    let f = 1.0 + cv * z;
                    if f > 0.0 {
                        return f;
                    }
                }
            }
        }
    }
}
