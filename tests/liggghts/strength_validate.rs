//! `validate liggghts --strength` (issue 32 item 5): quasi-static direct tension of the bonded
//! simple-cubic bar of tests/common/strength_bar.rs (10 × 10 × 10 spheres, 2,700 bonds;
//! Weibull tensile strengths) between held end layers, to failure, in the LIGGGHTS driver
//! (`pair_style anisobond table bonds.csv breaks FILE`: YADE's law and CohFrict criterion, the
//! adhesions `export yade` writes) on one and two MPI processes, and in the integrator with the
//! same law (a) (incremental moments), springs, adhesions and time step; both undamped. The
//! peak stress within 2 % and the first ten bonds to break the same, in the same order (the
//! pair style's own record of which bond broke when). The same in uniaxial compression (UCS)
//! of the turned-lattice prism of tests/common/strength_bar.rs (`ucs_prism`: 1,027 spheres,
//! 2,635 bonds that break in shear), the pair style with `contacts KN KS MU` (broken bonds and
//! spheres that come into touch are the integrator's frictional contacts) and the integrator
//! with its contacts on.

use crate::common::liggghts::*;
use crate::common::strength_bar::{check_ucs_run, cubic_bar, run_strength, ucs_prism, R};
use anisobond::validate::liggghts::{Liggghts, Programs, ValidateOptions};
use anisobond::validate::strength::StrengthTest;
use anisobond::validate::{validate_strength, Problem};

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];

fn engine() -> Liggghts {
    Liggghts {
        programs: Programs {
            driver: driver(),
            liggghts: "liggghts".into(),
        },
        options: ValidateOptions::default(),
    }
}

#[test]
fn liggghts_tension_peak_and_first_breaks_match_the_integrator_on_one_and_two_processes() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let asm = cubic_bar(10);
    let dir = fresh_dir("strength_validate");
    let t = StrengthTest::new(2, 0.5 * R, 5e-7, 4_000);
    let r = run_strength("liggghts_strength", &engine(), &dir, &asm, &t);
    assert!(
        r.reference.breaks.len() >= 10,
        "the integrator broke only {} bonds",
        r.reference.breaks.len()
    );
    assert_eq!(r.measured.len(), 2);
    assert_eq!(r.measured[1].processes, 2);
    // The same first breaks on one and two processes, steps included.
    assert_eq!(r.measured[0].breaks[..10], r.measured[1].breaks[..10]);
    let log = std::fs::read_to_string(dir.join("liggghts-strength/log-np2.liggghts")).unwrap();
    assert!(log.contains("MPI processor grid"), "{log}");
    assert!(r.passed(), "{:?}", r.failures());
}

/// UCS: the prism pushed down 2e-6 of its gauge length per step for 3,000 steps (the first
/// peak near step 1,000, then softening), undamped in both, the pair style's contacts against
/// the integrator's: the first peak within 2 % and the first ten broken bonds the same, in
/// order, on one and two processes; the two LIGGGHTS runs break the same first ten at the
/// same steps.
#[test]
fn liggghts_ucs_peak_and_first_breaks_match_the_integrator_with_contacts() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let asm = ucs_prism();
    let dir = fresh_dir("strength_validate_ucs");
    let t = StrengthTest::new(2, 1.5 * R, 2e-6, 3_000).compression();
    let r = run_strength("liggghts_ucs", &engine(), &dir, &asm, &t);
    check_ucs_run(&r.reference, &t);
    assert_eq!(r.measured.len(), 2);
    for m in &r.measured {
        check_ucs_run(m, &t);
    }
    assert_eq!(r.measured[0].breaks[..10], r.measured[1].breaks[..10]);
    // The deck asked for the contacts, with the integrator's law for new pairs.
    let deck = std::fs::read_to_string(dir.join("liggghts-strength/strength.in")).unwrap();
    assert!(deck.contains(" contacts 2e6 7e5 5e-1\n"), "{deck}");
    assert!(r.passed(), "{:?}", r.failures());
}

/// A model without `[strength]` is refused before anything runs, naming the option.
#[test]
fn liggghts_strength_refuses_a_model_without_strength() {
    let mut asm = cubic_bar(4);
    asm.model.strength = None;
    let dir = tempfile::tempdir().unwrap();
    let eng = Liggghts {
        programs: Programs {
            driver: "anisobond-liggghts".into(),
            liggghts: "liggghts".into(),
        },
        options: ValidateOptions::default(),
    };
    let t = StrengthTest::new(2, 0.5 * R, 5e-7, 100);
    let e = validate_strength(&eng, &Problem::of(dir.path(), &asm), &t, &|_: &str| {}).unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(
        e.to_string().contains("validate liggghts --strength"),
        "{e}"
    );
    assert!(!dir.path().join("liggghts-strength").exists());
}
