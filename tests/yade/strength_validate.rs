//! `validate yade --strength` (issue 32 item 5): quasi-static direct tension of the bonded
//! simple-cubic bar of tests/common/strength_bar.rs (10 × 10 × 10 spheres, 2,700 bonds; Weibull tensile
//! strengths) between held end layers, to failure, in YADE (CohFrictMat, fragile
//! CohFrictPhys with each bond's adhesions from `export yade`'s bonds.csv, Cundall damping)
//! and in the integrator with the same law (a), springs, adhesions and damping: the peak
//! stress within 2 % and the first ten bonds to break the same, in the same order (YADE's
//! own interactions, read in the same run).

use crate::common::strength_bar::{cubic_bar, R};
use crate::common::yade::yade_available;
use anisobond::validate::strength::StrengthTest;
use anisobond::validate::yade::{Yade, YadeValidationOptions};
use anisobond::validate::{validate_strength, Problem};

#[test]
fn yade_tension_peak_and_first_breaks_match_the_integrator() {
    let test = "yade_strength_validate";
    if !yade_available(test) {
        return;
    }
    let asm = cubic_bar(10);
    let engine = Yade(YadeValidationOptions::default());
    let dir = tempfile::tempdir().unwrap();
    let t = StrengthTest::new(2, 0.5 * R, 5e-7, 4_000);
    let r = validate_strength(&engine, &Problem::of(dir.path(), &asm), &t, &|m: &str| {
        eprintln!("{test}: {m}")
    })
    .expect("the strength test ran");
    eprintln!("{}", anisobond::validate::strength::summary(&r));
    assert!(
        r.reference.breaks.len() >= 10,
        "the integrator broke only {} bonds",
        r.reference.breaks.len()
    );
    assert!(r.passed(), "{:?}", r.failures());
}

/// The command: `validate yade FREE --model M --strength` passes and writes its report; asking
/// for more broken bonds in order than the run breaks fails with exit 7 (out of tolerance),
/// naming `first-breaks`.
#[test]
fn validate_yade_strength_command_passes_and_can_fail() {
    let test = "validate_yade_strength_command_passes_and_can_fail";
    if !yade_available(test) {
        return;
    }
    let asm = cubic_bar(6);
    let dir = tempfile::tempdir().unwrap();
    let packing = dir.path().join("free.txt");
    anisobond::packing::write_packing(&packing, &asm.packing).unwrap();
    let model = dir.path().join("model.toml");
    std::fs::write(&model, asm.model.to_toml_string()).unwrap();
    let run = |extra: &[&str], out: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_anisobond"))
            .args(["validate", "yade"])
            .arg(&packing)
            .arg("--model")
            .arg(&model)
            .args(["--strength", "--steps", "3000", "-o"])
            .arg(dir.path().join(out))
            .args(extra)
            .output()
            .unwrap()
    };
    let ok = run(&[], "ok");
    let text = String::from_utf8_lossy(&ok.stdout);
    eprintln!("{text}");
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("ok/strength-validation.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        (json["engine"].as_str(), json["passed"].as_bool()),
        (Some("yade"), Some(true))
    );
    let broken = json["reference"]["breaks"].as_array().unwrap().len();
    assert!(broken >= 10, "{broken} bonds broke");
    let more = (broken + 1).to_string();
    let tight = run(&["--compared", &more], "tight");
    assert_eq!(tight.status.code(), Some(7), "{tight:?}");
    assert!(String::from_utf8_lossy(&tight.stderr).contains("first-breaks"));
}
