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

/// A bedded model whose UCS re-hardens after its first drop (broken pairs locking up as
/// frictional contacts): the reported peak is the first one, below the curve's global
/// maximum, both recomputed here from the recorded curve; E is fitted under the first peak.
#[test]
fn ucs_that_re_hardens_reports_the_first_peak_below_the_global_maximum() {
    let model = anisobond::model::Model::from_toml_str(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
         C11 = 13.0e9\nC33 = 5.5e9\nC13 = 2.8e9\nC12 = 4.0e9\naxis = [0.0, 0.0, 1.0]\n\
         [geometry]\nconvention = \"modulus\"\n[strength]\naxis = [0.0, 0.0, 1.0]\n\
         [strength.bond]\ntensile = 6.0e6\ncohesion = 12.0e6\nfriction = 0.5\n\
         [strength.along]\ntensile = 3.0e6\ncohesion = 8.0e6\nfriction = 0.5\n\
         [[strength.planes]]\nnormal = [0.0, 0.0, 1.0]\nspacing = 4.0e-3\noffset = 0.0\n\
         tensile = 1.0e6\ncohesion = 1.5e6\nfriction = 0.5\n",
        "bedded.toml",
    )
    .unwrap();
    let opts = StrengthTestOptions {
        model: Some(model),
        cell_particles: 600,
        width_particles: 8.0,
        loading_rate: 1e-4,
        ..StrengthTestOptions::default()
    };
    let r = run(&opts, &|_| {}).unwrap();
    println!(
        "first peak {:.6e} Pa at strain {:.4e}; largest {:.6e} Pa at {:.4e}; stop {}, \
         {} broken of {}",
        r.peak_stress_pa,
        r.strain_at_peak,
        r.max_stress_pa,
        r.strain_at_max,
        r.stop,
        r.cracks.total,
        r.bonds
    );
    assert!(r.peak_dropped);
    assert!(r.peak_stress_pa < r.max_stress_pa);
    assert!(r.strain_at_peak < r.strain_at_max);
    // Brute force on the curve: the first row with broken bonds below 0.95 × the largest
    // stress up to it; the first peak is the largest stress before that row.
    let c = &r.curve;
    let largest = |k: usize| c[..=k].iter().map(|p| p.stress_pa).fold(f64::MIN, f64::max);
    let drop = (0..c.len())
        .find(|&k| c[k].broken > 0 && c[k].stress_pa < 0.95 * largest(k))
        .unwrap();
    assert_eq!(r.peak_stress_pa, largest(drop - 1));
    assert_eq!(r.max_stress_pa, largest(c.len() - 1));
    // E's window is 10–50 % of the first peak, before it.
    let at = c
        .iter()
        .position(|p| p.stress_pa == r.peak_stress_pa)
        .unwrap();
    let window = c[..=at]
        .iter()
        .filter(|p| p.stress_pa >= 0.1 * r.peak_stress_pa && p.stress_pa <= 0.5 * r.peak_stress_pa)
        .count();
    assert_eq!(r.fit_points, window);
}
