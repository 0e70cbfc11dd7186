//! `validate yade --specimen` (issue 31 item 5): YADE builds the free bonded specimen of a
//! 1,000-sphere packing with the anisotropic cubic model (Truszkowska 2018 MRV, Zener > 1,
//! parallel-bond moments), holds and moves its end layers by `blockedDOFs` and velocity,
//! relaxes it with Cundall damping, and its platen stiffness must match the specimen solve
//! within 1e-3, for frictionless and for bonded platens. The check can fail: the two
//! platen kinds differ by far more than the tolerance, and YADE's value set against the
//! other kind's solve is out of tolerance; a tolerance below the measured difference makes
//! the command exit 7.
//!
//! Skipped with a printed reason only when `yade` is not on PATH; with CI set, a missing
//! `yade` fails.

use crate::common::specimen::free_cubic_specimen;
use crate::common::yade::yade_available;
use crate::common::AssemblyFiles;
use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::specimen::Platens;
use anisobond::validate::specimen::SpecimenTest;
use anisobond::validate::yade::{Yade, YadeValidationOptions};
use anisobond::validate::{validate_specimen, Problem};
use std::process::Command;

#[test]
fn yade_platen_stiffness_matches_the_specimen_solve() {
    let test = "yade_platen_stiffness_matches_the_specimen_solve";
    if !yade_available(test) {
        return;
    }
    let asm = free_cubic_specimen();
    let mean = asm.packing.mean_radius();
    let engine = Yade(YadeValidationOptions::default());
    let mut stiffness = Vec::new();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let dir = tempfile::tempdir().unwrap();
        let t = SpecimenTest::new(2, mean, platens);
        let r = validate_specimen(&engine, &Problem::of(dir.path(), &asm), &t, &|m: &str| {
            eprintln!("{test}: {m}")
        })
        .expect("the specimen test ran");
        let c = &r.checks[0];
        eprintln!(
            "{test}: {platens:?} platens: YADE {:.7e} N/m, solve {:.7e} N/m, relative \
             difference {:.3e} (tolerance {:.0e}), {} steps, YADE {:.1} s, layers {} + {}",
            r.measured[0].stiffness(),
            r.predicted.platen_stiffness,
            c.value,
            t.tolerance,
            r.measured[0].steps,
            r.measured[0].seconds,
            r.measured[0].bottom.len(),
            r.measured[0].top.len()
        );
        assert_eq!(c.id, "platen-stiffness");
        assert!(c.not_converged.is_none(), "YADE did not settle: {c:?}");
        assert!(r.passed(), "{:?}", r.failures());
        assert!(c.value <= 1e-3);
        stiffness.push((r.measured[0].stiffness(), r.predicted.platen_stiffness));
    }
    // The check discriminates the boundary conditions: bonded platens are stiffer than
    // frictionless ones by far more than the tolerance, and YADE's frictionless value is
    // out of tolerance against the bonded solve.
    let (frictionless, bonded) = (stiffness[0], stiffness[1]);
    let gap = (bonded.1 - frictionless.1) / frictionless.1;
    assert!(gap > 0.02, "platen kinds differ by only {gap:.3e}");
    assert!(((frictionless.0 - bonded.1) / bonded.1).abs() > 1e-2);
}

#[test]
fn validate_yade_specimen_command_passes_and_can_fail() {
    let test = "validate_yade_specimen_command_passes_and_can_fail";
    if !yade_available(test) {
        return;
    }
    let asm = free_cubic_specimen();
    let dir = tempfile::tempdir().unwrap();
    let files = AssemblyFiles::write(dir.path(), &asm);
    let run = |extra: &[&str], out: &str| {
        files.validate(
            "yade",
            &["--specimen", "--platens", "bonded"],
            &dir.path().join(out),
            extra,
        )
    };
    let ok = run(&[], "ok");
    let text = String::from_utf8_lossy(&ok.stdout);
    eprintln!("{text}");
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(text.contains("PASSED"));
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("ok/specimen-validation.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["engine"], "yade");
    assert_eq!(json["passed"], true);
    let (k_yade, k_solve) = (
        json["platen_stiffness_engine_N_per_m"].as_f64().unwrap(),
        json["platen_stiffness_solve_N_per_m"].as_f64().unwrap(),
    );
    assert!(((k_yade - k_solve) / k_solve).abs() <= 1e-3);
    assert!(dir.path().join("ok/yade-specimen/platen.py").is_file());
    // A tolerance below the measured difference (~6e-7) but above YADE's remaining change
    // (~2e-9, so the check is judged): out of tolerance, exit 7.
    let tight = run(&["--specimen-tolerance", "1e-7"], "tight");
    assert_eq!(tight.status.code(), Some(7), "{:?}", tight);
    assert!(String::from_utf8_lossy(&tight.stderr).contains("platen-stiffness"));
}

#[test]
fn the_specimen_test_refuses_a_periodic_packing() {
    let packing = crate::common::bonded::generated(200, 1);
    let asm = Assembly::new(packing, Model::truszkowska_mrv()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let t = SpecimenTest::new(2, asm.packing.mean_radius(), Platens::Bonded);
    let e = validate_specimen(
        &Yade(YadeValidationOptions::default()),
        &Problem::of(dir.path(), &asm),
        &t,
        &|_: &str| {},
    )
    .unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(e.to_string().contains("--free"), "{e}");
    let mut bad = t;
    bad.strain = Some(0.5);
    let e = validate_specimen(
        &Yade(YadeValidationOptions::default()),
        &Problem::of(dir.path(), &asm),
        &bad,
        &|_: &str| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("strain"), "{e}");
}

/// `anisobond_yade.platen_test` refuses a `max_steps`, `tolerance` or `depth` no run can
/// use with a `ValueError` naming the argument, in YADE on a scene it would otherwise run:
/// two unbonded spheres (before, `max_steps=0` returned NaN forces, a negative depth
/// divided by an empty layer and a zero force divided the settling estimate by zero).
#[test]
fn platen_test_refuses_bad_arguments_by_name() {
    let test = "platen_test_refuses_bad_arguments_by_name";
    if !yade_available(test) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("refuse.py");
    let module = concat!(env!("CARGO_MANIFEST_DIR"), "/yade-scripts");
    std::fs::write(
        &script,
        format!(
            "import sys\nsys.path.insert(0, {module:?})\nimport anisobond_yade as ab\n\
             from yade import O, utils\n\
             O.bodies.append([utils.sphere((0, 0, 0), 1e-3), utils.sphere((0, 0, 3e-3), 1e-3)])\n\
             O.dt = 1e-7\n\
             cases = [('max_steps', dict(max_steps=0)), ('max_steps', dict(max_steps=2.5)),\n\
             \x20        ('tolerance', dict(tolerance=0.0)), ('tolerance', dict(tolerance=float('nan'))),\n\
             \x20        ('tolerance', dict(tolerance=1.5)), ('depth', dict(depth=-1e-3)),\n\
             \x20        ('depth', dict(depth=float('inf')))]\n\
             for name, kw in cases:\n\
             \x20   try:\n\
             \x20       ab.platen_test(check_every=10, **kw)\n\
             \x20       print('ACCEPTED', name, kw)\n\
             \x20   except ValueError as e:\n\
             \x20       print('REFUSED', name, e)\n\
             \x20   except Exception as e:\n\
             \x20       print('CRASHED', name, type(e).__name__, e)\n"
        ),
    )
    .unwrap();
    let out = Command::new("yade")
        .args(["-n", "-x"])
        .arg(&script)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| {
            ["REFUSED", "ACCEPTED", "CRASHED"]
                .iter()
                .any(|p| l.starts_with(p))
        })
        .collect();
    assert_eq!(
        lines.len(),
        7,
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for line in lines {
        let mut words = line.split_whitespace();
        let (verdict, name) = (words.next().unwrap(), words.next().unwrap());
        assert_eq!(verdict, "REFUSED", "{line}");
        let message: Vec<&str> = words.collect();
        assert_eq!(
            message.first(),
            Some(&name),
            "the refusal names {name}: {line}"
        );
    }
}
