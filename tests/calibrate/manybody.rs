//! Calibration to the whole stable domain with the many-body term (issue 33 item 2,
//! docs/manybody.md "Calibration"): real crystals and a shale the springs alone cannot reach
//! are reached; a reachable target gets no term; an unstable one is refused by condition.
//!
//! Checks are independent of the calibration's own arithmetic: the written model is read back
//! from its file text, its springs integrated by the general mean-field code at a fixed high
//! order (not the calibration's adaptive loop), or, for the elliptic scheme, by Šmilauer's
//! 1/35 matrix (Eq. 10) applied to the lattice moduli; D comes from the file's `[manybody]`.

use crate::common::CUBIC_MODEL;
use anisobond::assembly::EqualSpheres;
use anisobond::calibrate::manybody::{solve_d, SolveOptions};
use anisobond::calibrate::{calibrate, CalibrateOn, Calibration, CubicOptions, Target};
use anisobond::homogenize::mean_field;
use anisobond::model::{Model, SchemeSpec};
use anisobond::schemes::{microplane_matrix, CrossAnisotropic};
use anisobond::tensor::{CubicProjection, Stiffness6};
use anisobond::Error;
use std::path::Path;

/// Cubic metals at room temperature (GPa): C11, C12, C44. Nickel, copper, iron and aluminium
/// as issue 33 gives them (handbook values, e.g. Simmons & Wang 1971); tungsten from Wang,
/// Gulick & Li, J. Appl. Phys. 138, 045902 (2025), ambient ultrasonic values (Zener 1.01;
/// the issue's C44 = 159 GPa is the exactly isotropic (C11 − C12)/2 = 159.2).
pub const CUBIC_METALS: [(&str, f64, f64, f64); 5] = [
    ("nickel", 247.0, 147.0, 125.0),
    ("copper", 168.0, 121.0, 75.0),
    ("iron", 231.4, 134.7, 116.4),
    ("aluminium", 107.3, 60.9, 28.3),
    ("tungsten", 523.5, 205.1, 160.8),
];

/// Cotton Valley shale, Thomsen (1986) "Weak elastic anisotropy", Geophysics 51, Table 1:
/// Vp0 = 4721 m/s, Vs0 = 2890 m/s, ε = 0.135, δ = 0.205, γ = 0.180, ρ = 2.64 g/cm³, turned
/// into (C11, C33, C13, C12, C44) in Pa by Thomsen's exact definitions (his Eqs. 8a–c, 9):
/// C33 = ρVp0², C44 = ρVs0², C11 = (1 + 2ε)C33, C66 = (1 + 2γ)C44, C12 = C11 − 2C66,
/// (C13 + C44)² = 2δ·C33(C33 − C44) + (C33 − C44)².
pub fn cotton_valley_shale() -> [f64; 5] {
    let (vp, vs, eps, delta, gamma, rho) = (4721.0, 2890.0, 0.135, 0.205, 0.180, 2640.0);
    let c33: f64 = rho * vp * vp;
    let c44 = rho * vs * vs;
    let c11 = (1.0 + 2.0 * eps) * c33;
    let c66 = (1.0 + 2.0 * gamma) * c44;
    let c13 = (2.0 * delta * c33 * (c33 - c44) + (c33 - c44).powi(2)).sqrt() - c44;
    [c11, c33, c13, c11 - 2.0 * c66, c44]
}

const SPHERES: EqualSpheres = EqualSpheres {
    coordination: 7.7,
    solid_fraction: 0.6,
    radius: 1e-3,
};

const CROSS_MODEL: &str = r#"
[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "cross-anisotropic"
C11 = 13.0e9
C33 = 5.5e9
C13 = 2.8e9
C12 = 4.0e9
axis = [0.0, 0.0, 1.0]
[geometry]
convention = "modulus"
"#;

fn cubic_base() -> Model {
    Model::from_str_for(CUBIC_MODEL, Path::new("m.toml")).unwrap()
}

/// The calibrated model written as TOML and read back (what `calibrate -o` leaves).
fn round_trip(m: &Model) -> Model {
    let p = Path::new("cal.toml");
    Model::from_str_for(&m.to_string_for(p), p).unwrap()
}

/// The mean-field tensor (crystal frame, identity rotation) of the written model: its
/// springs by the general orientation integral at a fixed high order, plus its D.
fn mean_field_of_file(m: &Model, prefactor: f64) -> Stiffness6 {
    let SchemeSpec::Cubic(c) = &m.scheme else {
        panic!("cubic springs expected")
    };
    assert_eq!(c.rotation, anisobond::Mat3::identity());
    let scheme = c.checked().unwrap();
    let springs = mean_field(&scheme, prefactor, 96);
    let d = m
        .manybody
        .as_ref()
        .expect("[manybody] written")
        .voigt()
        .unwrap();
    springs + d
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn cubic_metals_beyond_the_cauchy_line_are_reached_at_the_mean_field_level() {
    let base = cubic_base();
    let prefactor = SPHERES.prefactor(&base.geometry).unwrap();
    for (name, c11, c12, c44) in CUBIC_METALS {
        let text = format!("C11={c11}GPa,C12={c12}GPa,C44={c44}GPa");
        let target = Target::parse(&text).unwrap();
        let cal = calibrate(
            &base,
            &target,
            CalibrateOn::MeanField(SPHERES),
            &CubicOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let Calibration::ManyBody(mb) = &cal.calibration else {
            panic!("{name}: the springs alone cannot cross the Cauchy line, a term is needed")
        };
        assert!(
            mb.pairwise_refusal.contains("outside the domain"),
            "{name}: {}",
            mb.pairwise_refusal
        );
        assert_eq!(mb.volume_fraction, 1.0);
        let written = round_trip(&cal.model);
        let p = CubicProjection::from_stiffness(&mean_field_of_file(&written, prefactor));
        for (k, (got, want)) in [(p.c11, c11), (p.c12, c12), (p.c44, c44)]
            .iter()
            .enumerate()
        {
            let e = rel(*got, want * 1e9);
            assert!(
                e < 1e-9,
                "{name} constant {k}: {got:e} vs {want} GPa ({e:e})"
            );
        }
        // The springs and D are each positive definite (D ⪰ T/2 by the share rule).
        let d = written.manybody.as_ref().unwrap().voigt().unwrap();
        let t = p.to_matrix();
        let half = d - 0.5 * t;
        let min = half.symmetric_eigen().eigenvalues.min();
        assert!(
            min > -1e-9 * t.amax(),
            "{name}: D − T/2 has eigenvalue {min:e}"
        );
    }
}

#[test]
fn a_target_the_springs_reach_gets_no_term() {
    let base = cubic_base();
    // Zener 0.875, C12 < C44: inside the mean-field domain (tests/calibrate/cli.rs).
    let target = Target::parse("C11=100GPa,C12=20GPa,C44=35GPa").unwrap();
    let cal = calibrate(
        &base,
        &target,
        CalibrateOn::MeanField(SPHERES),
        &CubicOptions::default(),
    )
    .unwrap();
    assert!(matches!(cal.calibration, Calibration::Cubic(_)));
    assert!(cal.model.manybody.is_none());
    // A [manybody] of the base is not carried into a springs-only model.
    let mut with_term = base.clone();
    with_term.manybody = round_trip(
        &calibrate(
            &base,
            &Target::parse("C11=247GPa,C12=147GPa,C44=125GPa").unwrap(),
            CalibrateOn::MeanField(SPHERES),
            &CubicOptions::default(),
        )
        .unwrap()
        .model,
    )
    .manybody;
    assert!(with_term.manybody.is_some());
    let cal = calibrate(
        &with_term,
        &target,
        CalibrateOn::MeanField(SPHERES),
        &CubicOptions::default(),
    )
    .unwrap();
    assert!(cal.model.manybody.is_none());
}

#[test]
fn a_shale_with_five_independent_constants_is_reached_at_the_voigt_level() {
    let base = Model::from_str_for(CROSS_MODEL, Path::new("r.toml")).unwrap();
    let t = cotton_valley_shale();
    // Cross-check the conversion against Thomsen's own definition of ε and γ.
    assert!(rel((t[0] - t[1]) / (2.0 * t[1]), 0.135) < 1e-12);
    assert!(rel((0.5 * (t[0] - t[3]) - t[4]) / (2.0 * t[4]), 0.180) < 1e-12);
    // The shale's four constants need a negative lattice modulus, so the springs take the
    // isotropic Cauchy tensor; the illustrative rock's four are the springs' own, and only
    // its C44 (2 GPa, not the dependent 3.225 GPa) needs the term.
    for (t, why) in [
        (t, "cannot reproduce"),
        ([13.0e9, 5.5e9, 2.8e9, 4.0e9, 2.0e9], "dependent"),
    ] {
        five_constants_at_the_voigt_level(&base, t, why);
    }
}

fn five_constants_at_the_voigt_level(base: &Model, t: [f64; 5], why: &str) {
    let text = format!(
        "C11={},C33={},C13={},C12={},C44={}",
        t[0], t[1], t[2], t[3], t[4]
    );
    let cal = calibrate(
        base,
        &Target::parse(&text).unwrap(),
        CalibrateOn::MeanField(SPHERES),
        &CubicOptions::default(),
    )
    .unwrap();
    let Calibration::ManyBody(mb) = &cal.calibration else {
        panic!("{text}: a term is needed")
    };
    assert!(mb.pairwise_refusal.contains(why), "{}", mb.pairwise_refusal);
    let written = round_trip(&cal.model);
    let SchemeSpec::CrossAnisotropic(w) = &written.scheme else {
        panic!("cross-anisotropic springs expected")
    };
    // Springs: Šmilauer's microplane tensor μ·A·E′ (Eq. 10) of the written constants, μ = 1
    // (the Voigt level of the mean field without a packing).
    let e = CrossAnisotropic::from_target(w.c11, w.c33, w.c13, w.c12, w.axis, 1.0)
        .unwrap()
        .e_prime;
    let a = microplane_matrix();
    let springs: Vec<f64> = a
        .iter()
        .map(|row| row.iter().zip(&e).map(|(x, y)| x * y).sum())
        .collect();
    let d = written.manybody.as_ref().unwrap().voigt().unwrap();
    // Axis z: D's lab matrix is its own; (C11, C33, C13, C12, C44) at (0,0), (2,2), (0,2),
    // (0,1), (3,3).
    let dd = [d[(0, 0)], d[(2, 2)], d[(0, 2)], d[(0, 1)], d[(3, 3)]];
    for k in 0..5 {
        let got = springs[k] + dd[k];
        assert!(rel(got, t[k]) < 1e-9, "constant {k}: {got:e} vs {:e}", t[k]);
    }
    assert!((d[(5, 5)] - 0.5 * (dd[0] - dd[3])).abs() < 1e-6 * dd[0].abs());
}

#[test]
fn four_constants_with_the_dependent_c44_need_no_term() {
    let base = Model::from_str_for(CROSS_MODEL, Path::new("r.toml")).unwrap();
    // C44 = (C11 + C33)/4 − C13/2 = (13 + 5.5)/4 − 1.4 = 3.225 GPa.
    for text in [
        "C11=13e9,C33=5.5e9,C13=2.8e9,C12=4e9",
        "C11=13e9,C33=5.5e9,C13=2.8e9,C12=4e9,C44=3.225e9",
    ] {
        let cal = calibrate(
            &base,
            &Target::parse(text).unwrap(),
            CalibrateOn::MeanField(SPHERES),
            &CubicOptions::default(),
        )
        .unwrap();
        assert!(
            matches!(cal.calibration, Calibration::CrossMeanField),
            "{text}"
        );
        assert!(cal.model.manybody.is_none(), "{text}");
    }
}

#[test]
fn targets_outside_the_stable_domain_are_refused_by_condition() {
    for (text, why) in [
        ("C11=100e9,C12=100e9,C44=10e9", "C11 − C12 > 0"),
        ("C11=100e9,C12=-50e9,C44=10e9", "C11 + 2·C12 > 0"),
        ("C11=100e9,C12=30e9,C44=-1e9", "C44/C11 = -0.01 must be > 0"),
        (
            "C11=40e9,C33=30e9,C13=40e9,C12=10e9,C44=5e9",
            "must exceed 2·C13²",
        ),
        (
            "C11=40e9,C33=30e9,C13=5e9,C12=10e9,C44=0",
            "C44 = 0e0 must be > 0",
        ),
        ("C11=40e9,C33=30e9,C13=5e9,C12=50e9,C44=5e9", "C66"),
    ] {
        match Target::parse(text) {
            Err(Error::Invalid(m)) => assert!(m.contains(why), "{text}: {m}"),
            other => panic!("{text}: expected Error::Invalid, got {other:?}"),
        }
    }
}

#[test]
fn the_cli_writes_nickel_with_a_term_and_refuses_an_unstable_target_leaving_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    std::fs::write(&model, CUBIC_MODEL).unwrap();
    let out = dir.path().join("ni.toml");
    let o = crate::common::bin()
        .args(["calibrate", "--model"])
        .arg(&model)
        .args(["--target", "C11=247GPa,C12=147GPa,C44=125GPa", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("many-body term"), "{stdout}");
    let m = Model::from_path(&out).unwrap();
    assert!(m.manybody.is_some());
    let bad = dir.path().join("bad.toml");
    let o = crate::common::bin()
        .args(["calibrate", "--model"])
        .arg(&model)
        .args(["--target", "C11=100GPa,C12=-60GPa,C44=30GPa", "-o"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(Error::Invalid(String::new()).exit_code())
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("C11 + 2·C12 > 0"), "{err}");
    assert!(!bad.exists());
}

/// A stand-in for the relaxed tensor with the term: softer than the Voigt level (factor
/// 0.8 and a coupling between constants) and mildly nonlinear, as the fluctuations make it.
fn softened(p: &[f64], d: &[f64], phi: f64) -> Vec<f64> {
    let n = d.len();
    (0..n)
        .map(|i| {
            let coupling: f64 = (0..n).filter(|&j| j != i).map(|j| 0.03 * d[j]).sum();
            let nonlinear = 0.02 * d[i] * d[i] / (1.0 + d[i].abs());
            p[i] + phi * (0.8 * d[i] + coupling) + nonlinear
        })
        .collect()
}

#[test]
fn the_d_iteration_reaches_a_softened_coupled_map() {
    let phi = 0.93;
    // Cubic-sized and five-constant problems (units of 100 GPa).
    for (p, t) in [
        (vec![0.4, 0.2, 0.2], vec![2.47, 1.47, 1.25]),
        (
            vec![0.3, 0.25, 0.1, 0.05, 0.1],
            vec![0.747, 0.588, 0.253, 0.147, 0.220],
        ),
    ] {
        let d0: Vec<f64> = t.iter().zip(&p).map(|(t, p)| (t - p) / phi).collect();
        let mut calls = 0;
        let anisobond::calibrate::manybody::SolvedD {
            d,
            achieved,
            history,
        } = solve_d(
            &t,
            d0,
            phi,
            |d| {
                calls += 1;
                Ok(softened(&p, d, phi))
            },
            &SolveOptions {
                tolerance: 1e-6,
                max_evaluations: 40,
            },
        )
        .unwrap();
        assert_eq!(history.len(), calls);
        // Recompute independently of the iteration's own record.
        let again = softened(&p, &d, phi);
        for k in 0..t.len() {
            assert!(rel(again[k], t[k]) < 1e-6, "{k}: {} vs {}", again[k], t[k]);
            assert_eq!(again[k], achieved[k]);
        }
        assert!(calls < 20, "{calls} evaluations");
    }
    // Too few evaluations: NotConverged, not a wrong answer.
    let r = solve_d(
        &[1.0, 1.0, 1.0],
        vec![0.0; 3],
        1.0,
        |d| Ok(softened(&[0.1, 0.1, 0.1], d, 1.0)),
        &SolveOptions {
            tolerance: 1e-6,
            max_evaluations: 2,
        },
    );
    assert!(matches!(r, Err(Error::NotConverged(_))), "{r:?}");
}

#[test]
fn domain_draws_the_new_reach_and_places_a_target_beyond_the_cauchy_line() {
    let dir = tempfile::tempdir().unwrap();
    let o = crate::common::bin()
        .args([
            "domain",
            "--samples",
            "60",
            "--target",
            "C11=247GPa,C12=147GPa,C44=125GPa",
            "-o",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("beyond the Cauchy line C12 = C44, so with the many-body term"),
        "{out}"
    );
    // Every sample of the springs' domain lies on or below the Cauchy line (mean field).
    let csv = std::fs::read_to_string(dir.path().join("domain.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .skip(5)
            .take(2)
            .map(|v| v.parse().unwrap())
            .collect();
        assert!(f[0] <= f[1] + 1e-9, "{line}");
    }
    assert!(dir.path().join("domain.png").exists());
    // An unstable target is refused by condition, nothing written.
    let bad = dir.path().join("bad");
    let o = crate::common::bin()
        .args([
            "domain",
            "--samples",
            "10",
            "--target",
            "C11=1,C12=2,C44=1",
            "-o",
        ])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("C11 − C12 > 0"));
    assert!(!bad.exists());
}

/// Relaxed level on a 2,000-particle gap-bonded periodic packing: nickel and the shale reach
/// their targets to 0.1 % in every independent constant, checked by a NEW relaxed solve of the
/// written model file through `Assembly::tensor` (not the calibration's last iterate).
#[test]
fn nickel_and_the_shale_are_reached_on_the_relaxed_tensor() {
    use anisobond::assembly::{Assembly, Method};
    use anisobond::tensor::TransverseProjection;
    let (p, _) = crate::common::bonded::gap_bonded(2000, 11);
    let opts = CubicOptions {
        tolerance: 2e-4,
        max_iterations: 20,
        ..Default::default()
    };
    let cross = Model::from_str_for(CROSS_MODEL, Path::new("r.toml")).unwrap();
    let s = cotton_valley_shale();
    let cases = [
        (
            cubic_base(),
            "C11=247GPa,C12=147GPa,C44=125GPa".to_string(),
            vec![247e9, 147e9, 125e9],
        ),
        (
            cross,
            format!(
                "C11={},C33={},C13={},C12={},C44={}",
                s[0], s[1], s[2], s[3], s[4]
            ),
            s.to_vec(),
        ),
    ];
    for (base, text, want) in cases {
        let asm = Assembly::new(p.clone(), base.clone()).unwrap();
        let start = std::time::Instant::now();
        let cal = calibrate(
            &base,
            &Target::parse(&text).unwrap(),
            CalibrateOn::Relaxed(&asm),
            &opts,
        )
        .unwrap_or_else(|e| panic!("{text}: {e}"));
        let Calibration::ManyBody(mb) = &cal.calibration else {
            panic!("{text}: a term is needed on the relaxed tensor too")
        };
        eprintln!(
            "{text}: {} relaxed solves of the D iteration, {:.1} s; share {:.4}, φ {:.4}, D {:?}",
            mb.history.len(),
            start.elapsed().as_secs_f64(),
            mb.share,
            mb.volume_fraction,
            mb.d
        );
        let written = round_trip(&cal.model);
        let c = Assembly::new(p.clone(), written)
            .unwrap()
            .tensor(&Method::relaxed())
            .unwrap()
            .report
            .c;
        let c = Stiffness6::from_fn(|i, j| c[i][j]);
        let got = if want.len() == 3 {
            let q = CubicProjection::from_stiffness(&c);
            vec![q.c11, q.c12, q.c44]
        } else {
            let (q, _) = TransverseProjection::about_axis(&c, &anisobond::Vec3::z()).unwrap();
            vec![q.c11, q.c33, q.c13, q.c12, q.c44]
        };
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            eprintln!(
                "  constant {k}: relaxed {g:.6e} vs target {w:.6e} ({:+.2e})",
                (g - w) / w
            );
            assert!(rel(*g, *w) < 1e-3, "{text} constant {k}: {g:e} vs {w:e}");
        }
    }
}
