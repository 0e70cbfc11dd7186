//! Jaeger's single plane of weakness: the library's formula against its analytic minimum,
//! a dense scan of β (the U shape), and the joint criterion on the plane at that stress.

use anisobond::strength::criteria::{joint, JointLimits, LocalLoads, Mode};
use anisobond::strength::jaeger::{
    minimum_strength, peak_strength, sliding_strength, stresses_on_plane, weakest_angle,
};

const C_W: f64 = 2.0e6;
const MU_W: f64 = 0.6;
const SIGMA3: f64 = 5.0e6;

#[test]
fn minimum_is_at_45_plus_half_phi_with_the_closed_form_value() {
    let phi = MU_W.atan();
    let beta_min = std::f64::consts::FRAC_PI_4 + 0.5 * phi;
    assert!((weakest_angle(MU_W) - beta_min).abs() < 1e-15);
    // tan φ = 0.6: √(1 + μ²) + μ = √1.36 + 0.6, so the minimum is 2(c + μσ₃)(√1.36 + 0.6).
    let expected = 2.0 * (C_W + MU_W * SIGMA3) * (1.36f64.sqrt() + 0.6);
    assert!((minimum_strength(C_W, MU_W, SIGMA3) / expected - 1.0).abs() < 1e-15);
    let at_min = sliding_strength(C_W, MU_W, SIGMA3, beta_min).unwrap();
    assert!(
        (at_min / expected - 1.0).abs() < 1e-14,
        "{at_min} vs {expected}"
    );
    // A dense scan finds nothing lower, and its minimiser is within one step of 45° + φ/2.
    let n = 200_000;
    let (mut best, mut best_beta) = (f64::INFINITY, 0.0);
    for k in 1..n {
        let beta = k as f64 / n as f64 * std::f64::consts::FRAC_PI_2;
        if let Some(s) = sliding_strength(C_W, MU_W, SIGMA3, beta) {
            assert!(
                s >= expected * (1.0 - 1e-14),
                "β = {beta}: {s} < {expected}"
            );
            if s < best {
                best = s;
                best_beta = beta;
            }
        }
    }
    assert!((best_beta - beta_min).abs() <= std::f64::consts::FRAC_PI_2 / n as f64);
}

#[test]
fn the_curve_is_u_shaped_and_the_plane_cannot_slide_outside_phi_to_90() {
    let phi = MU_W.atan();
    let beta_min = weakest_angle(MU_W);
    let intact = 60.0e6;
    // Decreasing from φ_w to the minimum, increasing from it to 90°.
    let steps = 400;
    let mut previous = f64::INFINITY;
    for k in 1..steps {
        let beta = phi + (beta_min - phi) * k as f64 / steps as f64;
        let s = sliding_strength(C_W, MU_W, SIGMA3, beta).unwrap();
        assert!(s < previous, "not decreasing at β = {beta}");
        previous = s;
    }
    previous = minimum_strength(C_W, MU_W, SIGMA3);
    for k in 1..steps {
        let beta = beta_min + (std::f64::consts::FRAC_PI_2 - beta_min) * k as f64 / steps as f64;
        let s = sliding_strength(C_W, MU_W, SIGMA3, beta).unwrap();
        assert!(s > previous, "not increasing at β = {beta}");
        previous = s;
    }
    // Outside (φ_w, 90°) the plane cannot slide: the intact strength holds.
    for beta in [0.0, 0.5 * phi, phi, std::f64::consts::FRAC_PI_2] {
        assert_eq!(
            sliding_strength(C_W, MU_W, SIGMA3, beta),
            None,
            "β = {beta}"
        );
        assert_eq!(peak_strength(C_W, MU_W, SIGMA3, beta, intact), intact);
    }
    // Near the ends the sliding strength exceeds the intact one: the U is capped.
    let near_phi = phi + 1e-3;
    assert_eq!(peak_strength(C_W, MU_W, SIGMA3, near_phi, intact), intact);
    let at_min = peak_strength(C_W, MU_W, SIGMA3, beta_min, intact);
    assert!((at_min / minimum_strength(C_W, MU_W, SIGMA3) - 1.0).abs() < 1e-14);
}

#[test]
fn at_jaegers_stress_the_joint_criterion_is_exactly_at_its_shear_limit() {
    // Resolve σ₁ = σ₃ + (σ₁ − σ₃)_Jaeger on the plane (Mohr's circle) and hand it to the
    // joint criterion as forces on a unit area: τ = c_w + μ_w σ_n, index 1, shear.
    let lim = JointLimits {
        area: 1.0,
        tensile: 1.0e6,
        cohesion: C_W,
        friction: MU_W,
    };
    for beta_deg in [35.0f64, 45.0, 59.04, 70.0, 80.0] {
        let beta = beta_deg.to_radians();
        let diff = sliding_strength(C_W, MU_W, SIGMA3, beta).unwrap();
        let (sn, tau) = stresses_on_plane(SIGMA3 + diff, SIGMA3, beta);
        assert!(
            (tau - (C_W + MU_W * sn)).abs() < 1e-8 * tau,
            "β = {beta_deg}"
        );
        let at = |scale: f64| {
            joint(
                &lim,
                &LocalLoads {
                    normal: sn,
                    shear: tau * scale,
                    ..Default::default()
                },
            )
        };
        let f = at(1.0 + 1e-9);
        assert!(f.broken && f.mode == Mode::Shear, "β = {beta_deg}: {f:?}");
        assert!((f.index - 1.0).abs() < 1e-8);
        let below = at(1.0 - 1e-9);
        assert!(!below.broken, "β = {beta_deg}: {below:?}");
    }
}
