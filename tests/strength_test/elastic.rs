//! The elastic part of the laboratory: E and ν from the initial slope against the exact
//! static solve ([`anisobond::specimen::solve`]) and the simple-cubic closed form; the
//! bedding rotation turning stiffness with the model.

use crate::{simple_cubic, spring_model, R};
use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::specimen::{solve, Platens, SpecimenOptions};
use anisobond::study::strength_test::{run, StrengthTestOptions, TestKind};

/// UCS options for a 5 × 5 × 10 simple-cubic block cut whole (width 10 R̄ and length
/// 20 R̄ hold every centre), loaded to a strain of 1e-3.
fn lattice_ucs(model: Model) -> StrengthTestOptions {
    StrengthTestOptions {
        test: TestKind::Ucs,
        packing: Some(simple_cubic(5, 10)),
        model: Some(model),
        width_particles: 10.0,
        aspect: Some(2.0),
        end_layer: 0.5,
        loading_rate: 1e-6,
        max_strain: 1e-3,
        ..StrengthTestOptions::default()
    }
}

#[test]
fn ucs_modulus_of_a_simple_cubic_prism_is_the_static_solve_and_the_closed_form() {
    let kn = 2e6;
    let model = spring_model(kn, "");
    let report = run(&lattice_ucs(model.clone()), &|_| {}).unwrap();
    assert_eq!(report.particles, 250);
    // The exact static solve of the same block between bonded platens, made here.
    let block = Assembly::new(simple_cubic(5, 10), model).unwrap();
    let mut so = SpecimenOptions::new(2, 0.5 * R);
    so.platens = Platens::Bonded;
    let exact = solve(&block, &so).unwrap();
    // Closed form: 5 × 5 chains of 9 springs in series over the 10 R × 10 R section,
    // gauge 18 R: E = 25 k_n/9 × 18 R/(100 R²) = k_n/(2R).
    let closed = kn / (2.0 * R);
    assert!((exact.young / closed - 1.0).abs() < 1e-9, "{}", exact.young);
    let e = report.modulus_pa.unwrap();
    println!(
        "E fitted {e:.6e} Pa on {} points, static {:.6e} Pa, closed form {closed:.6e} Pa; \
         kinetic/elastic at the peak {:.2e}",
        report.fit_points, exact.young, report.kinetic_over_elastic_at_peak
    );
    assert!(
        (e / exact.young - 1.0).abs() < 0.01,
        "{e} vs {}",
        exact.young
    );
    assert!((e / closed - 1.0).abs() < 0.01);
    // A simple-cubic lattice has no lateral coupling: ν = 0.
    assert!(report.poisson.unwrap().abs() < 0.01, "{:?}", report.poisson);
    assert!(report.kinetic_over_elastic_at_peak < 1e-2);
    assert_eq!(report.static_modulus_pa, Some(exact.young));
}

#[test]
fn direct_tension_modulus_equals_the_ucs_modulus_of_the_lattice() {
    // Linear springs: pulling gives the same slope as pushing, and the stress is reported
    // positive in the test's own sense.
    let model = spring_model(2e6, "");
    let ucs = run(&lattice_ucs(model.clone()), &|_| {}).unwrap();
    let tension = run(
        &StrengthTestOptions {
            test: TestKind::Tension,
            ..lattice_ucs(model)
        },
        &|_| {},
    )
    .unwrap();
    let (a, b) = (ucs.modulus_pa.unwrap(), tension.modulus_pa.unwrap());
    assert!(tension.peak_stress_pa > 0.0);
    assert!((a / b - 1.0).abs() < 1e-3, "{a} vs {b}");
}

/// A cross-anisotropic model (Šmilauer's scheme) whose axis is `axis`.
fn cross_model(axis: &str) -> Model {
    Model::from_toml_str(
        &format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
             C11 = 130e6\nC33 = 55e6\nC13 = 28e6\nC12 = 40e6\naxis = {axis}\n\
             [geometry]\nconvention = \"modulus\"\n"
        ),
        "cross.toml",
    )
    .unwrap()
}

#[test]
fn bedding_angle_turns_the_stiffness_with_the_model() {
    // β = 90° turns the axis z to x: the same specimen as a model written with axis x at
    // β = 0, so the same curve; and a different one from β = 0 with axis z.
    let opts = |model: Model, beta: f64| StrengthTestOptions {
        model: Some(model),
        bedding_deg: beta,
        cell_particles: 600,
        width_particles: 8.0,
        max_strain: 2e-4,
        loading_rate: 1e-4,
        ..StrengthTestOptions::default()
    };
    let turned = run(&opts(cross_model("[0.0, 0.0, 1.0]"), 90.0), &|_| {}).unwrap();
    let written = run(&opts(cross_model("[1.0, 0.0, 0.0]"), 0.0), &|_| {}).unwrap();
    let upright = run(&opts(cross_model("[0.0, 0.0, 1.0]"), 0.0), &|_| {}).unwrap();
    let (t, w, u) = (
        turned.modulus_pa.unwrap(),
        written.modulus_pa.unwrap(),
        upright.modulus_pa.unwrap(),
    );
    println!("E: turned {t:.6e}, written {w:.6e}, upright {u:.6e} Pa");
    assert!((t / w - 1.0).abs() < 1e-9, "{t} vs {w}");
    assert!((t / u - 1.0).abs() > 0.05, "{t} vs {u}");
}
