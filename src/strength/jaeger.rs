//! Jaeger's single plane of weakness (Jaeger 1960; Jaeger, Cook & Zimmerman, *Fundamentals
//! of Rock Mechanics*, 4th ed., Sec. 10.4): the differential stress at which a rock with one
//! plane of weakness (cohesion c_w, friction μ_w = tan φ_w) slides on it, against β, the
//! angle between the plane's normal and σ₁ (compression positive):
//!
//! σ₁ − σ₃ = 2(c_w + μ_w σ₃) / ((1 − μ_w cot β) sin 2β),
//!
//! defined where the denominator is positive (φ_w < β < 90°); elsewhere the plane cannot
//! slide and the intact strength holds. The curve is U-shaped with its minimum
//! 2(c_w + μ_w σ₃)(√(1 + μ_w²) + μ_w) at β = 45° + φ_w/2.

/// σ₁ − σ₃ at which the plane slides, for β (radians) the angle between the plane's normal
/// and σ₁, or `None` where it cannot slide (β ≤ φ_w or β ≥ 90°: the denominator
/// (1 − μ_w cot β) sin 2β is not positive). Stresses in Pa, compression positive.
pub fn sliding_strength(c_w: f64, mu_w: f64, sigma3: f64, beta: f64) -> Option<f64> {
    let denominator = (1.0 - mu_w / beta.tan()) * (2.0 * beta).sin();
    if denominator > 0.0 && beta > 0.0 && beta < std::f64::consts::FRAC_PI_2 {
        Some(2.0 * (c_w + mu_w * sigma3) / denominator)
    } else {
        None
    }
}

/// The angle β (radians) of the weakest orientation, 45° + φ_w/2 with φ_w = atan μ_w.
pub fn weakest_angle(mu_w: f64) -> f64 {
    std::f64::consts::FRAC_PI_4 + 0.5 * mu_w.atan()
}

/// The minimum of [`sliding_strength`] over β: 2(c_w + μ_w σ₃)(√(1 + μ_w²) + μ_w).
pub fn minimum_strength(c_w: f64, mu_w: f64, sigma3: f64) -> f64 {
    2.0 * (c_w + mu_w * sigma3) * ((1.0 + mu_w * mu_w).sqrt() + mu_w)
}

/// The peak differential stress of the rock at β: the lesser of the sliding strength (where
/// the plane can slide) and the intact strength `intact` (Pa) — the U-shaped curve.
pub fn peak_strength(c_w: f64, mu_w: f64, sigma3: f64, beta: f64, intact: f64) -> f64 {
    match sliding_strength(c_w, mu_w, sigma3, beta) {
        Some(s) => s.min(intact),
        None => intact,
    }
}

/// Normal and shear stress (compression positive) on a plane whose normal makes angle β
/// with σ₁, under principal stresses σ₁ ≥ σ₃ (Mohr's circle): σ_n = (σ₁ + σ₃)/2 +
/// (σ₁ − σ₃)/2·cos 2β, τ = (σ₁ − σ₃)/2·sin 2β.
pub fn stresses_on_plane(sigma1: f64, sigma3: f64, beta: f64) -> (f64, f64) {
    let mean = 0.5 * (sigma1 + sigma3);
    let radius = 0.5 * (sigma1 - sigma3);
    (
        mean + radius * (2.0 * beta).cos(),
        radius * (2.0 * beta).sin(),
    )
}
