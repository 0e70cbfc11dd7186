//! The laboratory with breaking bonds: direct tension of a simple-cubic prism peaks at the
//! bonds per section × the bond's limit over the area (closed form), every break in tension.

use crate::{simple_cubic, spring_model, R};
use anisobond::study::strength_test::{run, StrengthTestOptions, TestKind};

#[test]
fn direct_tension_of_a_simple_cubic_prism_peaks_at_bonds_times_limit_over_area() {
    // 4 × 4 × 10 touching spheres, k_n = 2e6 N/m: E = k_n/(2R) = 1e9 Pa. YADE's normal
    // adhesion of a bond is σ_t·min(R_i, R_j)² (docs/strength.md): the 16 chains of the
    // section each carry at most σ_t R², over the area (8R)² of the spheres' extent:
    // σ_peak = 16 σ_t R²/(64 R²) = σ_t/4, at a strain of σ_peak/E = 1e-3 for σ_t = 4 MPa.
    let (n, sigma_t) = (4usize, 4e6);
    let strength = format!("[strength.bond]\ntensile = {sigma_t:e}\ncohesion = 1.0e9\n");
    let opts = StrengthTestOptions {
        test: TestKind::Tension,
        packing: Some(simple_cubic(n, 10)),
        model: Some(spring_model(2e6, &strength)),
        width_particles: 2.0 * n as f64,
        aspect: Some(20.0 / (2.0 * n as f64)),
        end_layer: 0.5,
        loading_rate: 1e-6,
        max_strain: 2e-3,
        points: 2000,
        ..StrengthTestOptions::default()
    };
    let r = run(&opts, &|_| {}).unwrap();
    let area = (2.0 * R * n as f64).powi(2);
    let closed = (n * n) as f64 * sigma_t * R * R / area;
    assert!((r.area_m2.unwrap() / area - 1.0).abs() < 1e-12);
    println!(
        "peak {:.6e} Pa (closed form {closed:.6e}) at strain {:.4e}; {} broken ({:?}), \
         stop {}, kinetic/elastic at the peak {:.2e}",
        r.peak_stress_pa,
        r.strain_at_peak,
        r.cracks.total,
        r.cracks,
        r.stop,
        r.kinetic_over_elastic_at_peak
    );
    assert!(r.breakage);
    assert!(
        (r.peak_stress_pa / closed - 1.0).abs() < 5e-3,
        "{}",
        r.peak_stress_pa
    );
    // It failed: the stress dropped below half the peak, every break in tension.
    assert_eq!(r.stop, "drop");
    assert!(r.cracks.total > 0 && r.cracks.total == r.cracks.tension);
    assert_eq!(r.curve.last().unwrap().broken, r.cracks.total);
    assert!((r.broken_fraction - r.cracks.total as f64 / r.bonds as f64).abs() < 1e-15);
    // The bonds' states follow the events: broken at a time ≤ the run's end, mode 1.
    let s = &r.bond_states;
    let broken: Vec<usize> = (0..r.bonds).filter(|&b| s.broken_at[b].is_some()).collect();
    assert_eq!(broken.len(), r.cracks.total);
    assert!(broken.iter().all(|&b| s.mode[b] == 1));
    // Before the first break the curve is elastic: the fitted E is k_n/(2R).
    assert!((r.modulus_pa.unwrap() / 1e9 - 1.0).abs() < 0.01);
}

#[test]
fn bedding_angle_turns_the_strength_with_the_model() {
    // A cross-anisotropic strength about z: σ_t = 4 MPa for bonds along the axis, 8 MPa
    // across it. In tension along z only the z-chains carry load: at β = 0 they are along
    // the axis (peak σ_t/4 = 1 MPa), at β = 90° the axis is x and they are across it
    // (2 MPa) — the stiffness being isotropic, only the strength turned.
    let strength = "[strength]\naxis = [0.0, 0.0, 1.0]\n[strength.bond]\ntensile = 8.0e6\n\
                    cohesion = 1.0e9\n[strength.along]\ntensile = 4.0e6\ncohesion = 1.0e9\n";
    let peak = |beta: f64| {
        let opts = StrengthTestOptions {
            test: TestKind::Tension,
            packing: Some(simple_cubic(3, 8)),
            model: Some(spring_model(2e6, strength)),
            bedding_deg: beta,
            width_particles: 6.0,
            aspect: Some(16.0 / 6.0),
            end_layer: 0.5,
            loading_rate: 1e-6,
            max_strain: 3e-3,
            points: 3000,
            ..StrengthTestOptions::default()
        };
        run(&opts, &|_| {}).unwrap().peak_stress_pa
    };
    let (p0, p90) = (peak(0.0), peak(90.0));
    println!("peak at β = 0: {p0:.6e} Pa, at β = 90°: {p90:.6e} Pa");
    assert!((p0 / 1e6 - 1.0).abs() < 5e-3, "{p0}");
    assert!((p90 / 2e6 - 1.0).abs() < 5e-3, "{p90}");
}
