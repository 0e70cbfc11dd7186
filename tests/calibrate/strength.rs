//! Strength calibration (`calibrate::calibrate_strength`, `anisobond calibrate-strength`):
//! a simple-cubic bar in direct tension, where the closed form gives the answer (peak =
//! σ_t·R²/(2R)² = σ_t/4 with YADE's adhesion σ_t·R² per bond), in one and two directions; a
//! random packing whose calibrated model file, run again by the lab, meets the target; the
//! refusals by name.

use crate::common::{bin, fails, stdout, write};
use anisobond::calibrate::{calibrate_strength, StrengthCalibrationOptions, StrengthTarget};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::study::strength_test::{run, StrengthTestOptions, TestKind};
use anisobond::study::OptionNames;
use anisobond::{Error, Vec3};

/// Radius of the lattice spheres (m).
const R: f64 = 1e-3;

/// A free simple-cubic block of touching spheres of radius [`R`], `n` × `n` × `nz`.
fn simple_cubic(n: usize, nz: usize) -> Packing {
    let mut x = Vec::new();
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                x.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let len = x.len();
    Packing::new(x, vec![R; len], None).unwrap()
}

/// Nearest-neighbour bonds with springs k_n = 2e6 N/m, k_s = 7e5 N/m (E = k_n/2R = 1e9 Pa
/// in the simple-cubic lattice) and the `[strength]` table `strength`.
fn lattice_model(strength: &str) -> Model {
    Model::from_toml_str(
        &format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
             normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n{strength}"
        ),
        "lattice.toml",
    )
    .unwrap()
}

/// The lab on an `n` × `n` × `nz` simple-cubic bar pulled along z, slowly enough that its
/// peak is the closed form's to ~1e-4.
fn bar_lab(n: usize, nz: usize) -> StrengthTestOptions {
    StrengthTestOptions {
        test: TestKind::Tension,
        packing: Some(simple_cubic(n, nz)),
        width_particles: 2.0 * n as f64,
        aspect: Some(nz as f64 / n as f64),
        end_layer: 0.5,
        loading_rate: 1e-6,
        max_strain: 2e-3,
        points: 4000,
        ..StrengthTestOptions::default()
    }
}

/// Direct tension of a 3 × 3 × 8 bar: only the z-chains carry the load, each breaking at
/// YADE's σ_t R², over the section (6R)²: peak = 9 σ_t R²/(36 R²) = σ_t/4. Calibrated to
/// 1 MPa from σ_t = 1.5 MPa, the fitted σ_t is 4 MPa to 1e-3 (and the cohesion keeps its
/// ratio to σ_t); the verification run's measured peak is within the tolerance.
#[test]
fn a_simple_cubic_bar_in_tension_calibrates_to_four_times_the_target() {
    let base = lattice_model("[strength.bond]\ntensile = 1.5e6\ncohesion = 3.0e8\n");
    let target = 1e6;
    let opts = StrengthCalibrationOptions {
        lab: bar_lab(3, 8),
        tolerance: 2e-4,
        max_iterations: 8,
    };
    let runs = std::sync::atomic::AtomicUsize::new(0);
    let cal = calibrate_strength(
        &base,
        &StrengthTarget::Tension(target),
        &opts,
        OptionNames::Flags,
        &|_| {
            runs.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        },
    )
    .unwrap();
    let s = &cal.fitted_strength.bond;
    println!(
        "fitted scale {:?}: σ_t = {:.6e} Pa (closed form 4 × target = {:.6e}), iterations {}, \
         runs {}, measured {:?}",
        cal.fitted_scale,
        s.tensile,
        4.0 * target,
        cal.iterations,
        cal.runs,
        cal.measured_peak_pa
    );
    assert!(
        (s.tensile / (4.0 * target) - 1.0).abs() < 1e-3,
        "{}",
        s.tensile
    );
    assert!((s.cohesion / s.tensile - 200.0).abs() < 1e-9);
    assert!((cal.measured_peak_pa[0] / target - 1.0).abs() <= 2e-4);
    assert_eq!(cal.runs, runs.load(std::sync::atomic::Ordering::Relaxed));
    assert_eq!(
        cal.runs,
        cal.iterations + 1,
        "one run per iteration + verification"
    );
    assert_eq!(cal.verification[0].stop, "drop");
    assert_eq!(cal.model.strength.as_ref(), Some(&cal.fitted_strength));
}

/// Along and across a cross-anisotropic axis x–z at 30° from z: the lab loads the bar along
/// the axis (β = −30°) and across it (β = 60°), and in each only the chains along the load
/// carry it, at the strength of their own direction: fitted along σ_t = 4 T_along and
/// across σ_t = 4 T_across (to 1e-3), from a start with the ratio the other way round.
#[test]
fn two_directions_calibrate_along_and_across_the_axis() {
    let s30 = 30f64.to_radians();
    let base = lattice_model(&format!(
        "[strength]\naxis = [{:?}, 0.0, {:?}]\n[strength.bond]\ntensile = 3.0e6\n\
         cohesion = 1.0e9\n[strength.along]\ntensile = 5.0e6\ncohesion = 1.0e9\n",
        s30.sin(),
        s30.cos()
    ));
    let (along, across) = (0.8e6, 1.5e6);
    let opts = StrengthCalibrationOptions {
        lab: bar_lab(3, 8),
        tolerance: 2e-4,
        max_iterations: 8,
    };
    // The lab turns the whole model: a stiffness turned by −30° is still isotropic, but the
    // bar's lattice is not turned, so this only holds for the strength axis.
    let cal = calibrate_strength(
        &base,
        &StrengthTarget::TensionAlongAcross { along, across },
        &opts,
        OptionNames::Flags,
        &|_| {},
    )
    .unwrap();
    let t = &cal.fitted_strength;
    let fitted_along = t.along.as_ref().unwrap().tensile;
    println!(
        "fitted scales {:?}: along σ_t {fitted_along:.6e}, across σ_t {:.6e}; bedding {:?}; \
         iterations {}, runs {}, measured {:?}",
        cal.fitted_scale,
        t.bond.tensile,
        cal.bedding_deg,
        cal.iterations,
        cal.runs,
        cal.measured_peak_pa
    );
    assert!((cal.bedding_deg[0] + 30.0).abs() < 1e-9 && (cal.bedding_deg[1] - 60.0).abs() < 1e-9);
    assert!(
        (fitted_along / (4.0 * along) - 1.0).abs() < 1e-3,
        "{fitted_along}"
    );
    assert!(
        (t.bond.tensile / (4.0 * across) - 1.0).abs() < 1e-3,
        "{}",
        t.bond.tensile
    );
    for (m, goal) in cal.measured_peak_pa.iter().zip([along, across]) {
        assert!((m / goal - 1.0).abs() <= 2e-4, "{m} vs {goal}");
    }
    assert_eq!(cal.runs, 2 * cal.iterations + 2);
}

/// The default lab's model (gap 0.17 R̄, moduli 1e10 and 3e9 Pa) with σ_t = 5 MPa, c = 10 MPa.
const RANDOM_MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\n\
    kind = \"isotropic\"\nnormal = 1.0e10\nshear = 3.0e9\n[geometry]\nconvention = \"modulus\"\n\
    [strength.bond]\ntensile = 5.0e6\ncohesion = 1.0e7\n";

/// A random periodic packing: `anisobond calibrate-strength` fits the direct tensile
/// strength of a prism cut from it to 1.2 MPa and writes the model; a second, independent
/// lab run of the written file (read from disk, run by the library) peaks within the
/// tolerance of the target, as the command's verification run said; the input model file
/// is left as it was.
#[test]
fn a_random_packing_calibrated_by_the_command_is_met_by_a_new_lab_run_of_the_written_file() {
    let dir = crate::common::tmp();
    let d = dir.path();
    let packing = crate::common::packing(d, 400);
    let model = write(d, "rock.toml", RANDOM_MODEL);
    let (out, report) = (d.join("calibrated.toml"), d.join("report.json"));
    let lab = [
        "--width-particles",
        "6",
        "--loading-rate",
        "1e-5",
        "--max-strain",
        "0.01",
    ];
    let o = bin()
        .args(["calibrate-strength", "--model"])
        .arg(&model)
        .arg("--packing")
        .arg(&packing)
        .args(["--target", "tension=1.2MPa"])
        .args(lab)
        .arg("-o")
        .arg(&out)
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    let text = stdout(&o);
    println!("{text}");
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
    assert!(text.contains("(verification)"), "{text}");
    assert_eq!(std::fs::read_to_string(&model).unwrap(), RANDOM_MODEL);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let measured = json["measured_peak_pa"][0].as_f64().unwrap();
    assert!((measured / 1.2e6 - 1.0).abs() <= 0.01, "{measured}");
    let written = Model::from_path(&out).unwrap();
    let fitted = written.strength.as_ref().unwrap().bond.tensile;
    let scale = json["fitted_scale"][0].as_f64().unwrap();
    assert!(
        (fitted / (5e6 * scale) - 1.0).abs() < 1e-12,
        "{fitted} vs scale {scale}"
    );
    let again = run(
        &StrengthTestOptions {
            test: TestKind::Tension,
            packing: Some(anisobond::packing::read_packing(&packing).unwrap()),
            model: Some(written),
            width_particles: 6.0,
            loading_rate: 1e-5,
            max_strain: 0.01,
            ..StrengthTestOptions::default()
        },
        &|_| {},
    )
    .unwrap();
    println!(
        "independent run: peak {:.6e} Pa ({} broken, stop {}), command's measured {measured:.6e}",
        again.peak_stress_pa, again.cracks.total, again.stop
    );
    assert_eq!(again.stop, "drop");
    assert!((again.peak_stress_pa / 1.2e6 - 1.0).abs() <= 0.01);
}

/// Refusals by name, before or instead of a result: a target the bar cannot carry before the
/// largest strain (E ε_max = 1e9 × 2e-3 = 2 MPa < 5 MPa), a model without [strength], two
/// directions on an isotropic table or about an axis out of the x–z plane, an iteration
/// budget too small (NotConverged naming the last error), a tolerance out of range.
#[test]
fn unreachable_targets_and_bad_inputs_are_refused_by_name() {
    let opts = StrengthCalibrationOptions {
        lab: bar_lab(3, 8),
        tolerance: 1e-3,
        max_iterations: 8,
    };
    let iso = lattice_model("[strength.bond]\ntensile = 1.5e6\ncohesion = 3.0e8\n");
    let go = |m: &Model, t: StrengthTarget, o: &StrengthCalibrationOptions| {
        calibrate_strength(m, &t, o, OptionNames::Flags, &|_| {}).unwrap_err()
    };
    let e = go(&iso, StrengthTarget::Tension(5e6), &opts);
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("--max-strain") && m.contains("5e6")),
        "{e}"
    );
    let e = go(&lattice_model(""), StrengthTarget::Tension(1e6), &opts);
    assert!(
        matches!(&e, Error::Model(m) if m.contains("[strength]")),
        "{e}"
    );
    let two = StrengthTarget::TensionAlongAcross {
        along: 1e6,
        across: 1e6,
    };
    let e = go(&iso, two, &opts);
    assert!(
        matches!(&e, Error::Model(m) if m.contains("[strength.along]")),
        "{e}"
    );
    let tilted = lattice_model(
        "[strength]\naxis = [0.0, 1.0, 1.0]\n[strength.bond]\ntensile = 1e6\ncohesion = 1e9\n\
         [strength.along]\ntensile = 1e6\ncohesion = 1e9\n",
    );
    let e = go(&tilted, two, &opts);
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("x-z plane")),
        "{e}"
    );
    let once = StrengthCalibrationOptions {
        max_iterations: 1,
        ..opts.clone()
    };
    let e = go(&iso, StrengthTarget::Tension(1e6), &once);
    assert!(
        matches!(&e, Error::NotConverged(m) if m.contains("tension peak") && m.contains("--max-iterations")),
        "{e}"
    );
    let loose = StrengthCalibrationOptions {
        tolerance: 0.5,
        ..opts.clone()
    };
    let e = go(&iso, StrengthTarget::Tension(1e6), &loose);
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("--tolerance")),
        "{e}"
    );
    let e = go(&iso, StrengthTarget::Ucs(-1.0), &opts);
    assert!(matches!(&e, Error::Invalid(m) if m.contains("ucs")), "{e}");
}

/// The command refuses an unreachable target with exit status 1 (bad input), one that does
/// not converge with 5, and leaves no output file behind either time.
#[test]
fn the_command_refuses_with_its_exit_status_and_writes_nothing() {
    let dir = crate::common::tmp();
    let d = dir.path();
    let model = write(
        d,
        "bar.toml",
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
         normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n\
         [strength.bond]\ntensile = 1.5e6\ncohesion = 3.0e8\n",
    );
    let packing = d.join("bar.txt");
    anisobond::packing::write_packing(&packing, &simple_cubic(3, 8)).unwrap();
    let out = d.join("cal.toml");
    let base = |target: &str, iterations: &str| {
        let mut c = bin();
        c.args(["calibrate-strength", "--model"])
            .arg(&model)
            .arg("--packing")
            .arg(&packing)
            .args(["--target", target, "--max-iterations", iterations])
            .args([
                "--width-particles",
                "6",
                "--aspect",
                "2.6667",
                "--end-layer",
                "0.5",
            ])
            .args([
                "--loading-rate",
                "1e-6",
                "--max-strain",
                "2e-3",
                "--points",
                "4000",
            ])
            .arg("-o")
            .arg(&out);
        c
    };
    let e = fails(&mut base("tension=5MPa", "8"));
    assert!(e.contains("--max-strain"), "{e}");
    assert_eq!(
        base("tension=5MPa", "8").output().unwrap().status.code(),
        Some(1)
    );
    let o = base("tension=1MPa", "1").output().unwrap();
    assert_eq!(o.status.code(), Some(5), "{}", crate::common::stderr(&o));
    assert!(crate::common::stderr(&o).contains("--max-iterations"));
    assert!(!out.exists());
    crate::common::holds_exactly(d, &["bar.toml", "bar.txt"]);
}

/// A UCS target (docs/calibrate-strength.md): a prism cut from a random periodic packing is
/// calibrated to 1.3 × the UCS of the starting table (measured here first), with the
/// first-peak definition of the lab (`peak_drop` 0.05); the calibrated model is written to a
/// file, read back from disk and run again by the lab: that independent run fails (its stress
/// drops after the peak) and its first peak is within the calibration's tolerance of the
/// target, and the fitted table is the start's scaled by the reported scale.
#[test]
fn a_ucs_target_is_met_by_a_new_lab_run_of_the_written_model_file() {
    let dir = crate::common::tmp();
    let d = dir.path();
    let packing = anisobond::packing::read_packing(&crate::common::packing(d, 400)).unwrap();
    let base = Model::from_toml_str(RANDOM_MODEL, "rock.toml").unwrap();
    let lab = StrengthTestOptions {
        test: TestKind::Ucs,
        packing: Some(packing),
        width_particles: 6.0,
        loading_rate: 1e-5,
        max_strain: 0.01,
        ..StrengthTestOptions::default()
    };
    let start = run(
        &StrengthTestOptions {
            model: Some(base.clone()),
            ..lab.clone()
        },
        &|_| {},
    )
    .unwrap();
    assert_eq!(start.stop, "drop");
    let target = 1.3 * start.peak_stress_pa;
    let opts = StrengthCalibrationOptions {
        lab: lab.clone(),
        tolerance: 0.01,
        max_iterations: 10,
    };
    let cal = calibrate_strength(
        &base,
        &StrengthTarget::Ucs(target),
        &opts,
        OptionNames::Flags,
        &|_| {},
    )
    .unwrap();
    println!(
        "start UCS {:.6e} Pa, target {target:.6e} Pa; fitted scale {:?}, {} iterations, \
         measured {:?}",
        start.peak_stress_pa, cal.fitted_scale, cal.iterations, cal.measured_peak_pa
    );
    assert_eq!(cal.kind, "ucs");
    let s = cal.fitted_scale[0];
    let t = &cal.fitted_strength.bond;
    assert!((t.tensile / (5e6 * s) - 1.0).abs() < 1e-12);
    assert!((t.cohesion / (1e7 * s) - 1.0).abs() < 1e-12);
    // The written file, read back and run by the lab on its own.
    let file = d.join("calibrated-ucs.toml");
    std::fs::write(&file, cal.model.to_string_for(&file)).unwrap();
    let written = Model::from_path(&file).unwrap();
    let again = run(
        &StrengthTestOptions {
            model: Some(written),
            ..lab
        },
        &|_| {},
    )
    .unwrap();
    println!(
        "independent run: first peak {:.6e} Pa at strain {:.3e} (largest {:.6e} Pa), {} \
         broken, stop {}",
        again.peak_stress_pa,
        again.strain_at_peak,
        again.max_stress_pa,
        again.cracks.total,
        again.stop
    );
    assert_eq!(again.stop, "drop");
    assert!(again.peak_dropped);
    assert!(
        (again.peak_stress_pa / target - 1.0).abs() <= opts.tolerance,
        "{} vs {target}",
        again.peak_stress_pa
    );
}
