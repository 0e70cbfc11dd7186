//! `validate lammps --strength --bond-style anisobond` (issue 32 item 5): the bar of
//! tests/lammps/strength_validate.rs (10 × 10 × 10 spheres, 2,700 bonds, Weibull tensile
//! strengths) pulled to failure by anisobond's plugin (`bond_style anisobond … break yes
//! strengths bond-strengths.csv record broken.txt`) on one and two processes and by the
//! integrator with law (d), the same springs, damping and limits: the peak stress within 2 %
//! and the first ten bonds to break the same, in the same order (the plugin's own record of
//! its broken bonds, gathered on process 0). The same in uniaxial compression (UCS) of the
//! turned-lattice prism (`ucs_prism`, 1,027 spheres, 2,635 bonds), where broken pairs become
//! `pair_style granular` contacts in the plugin (it takes them out of the special lists on
//! every process) and the integrator's contacts.

use super::export::one_lammps_at_a_time;
use super::plugin::{lammps, Lammps};
use crate::common::strength_bar::{check_ucs_run, cubic_bar, run_strength, ucs_prism, R};
use anisobond::export::lammps::LammpsBondStyle;
use anisobond::validate::lammps::{Lammps as Engine, LammpsValidateOptions};
use anisobond::validate::strength::StrengthTest;

#[test]
fn plugin_tension_peak_and_first_breaks_match_the_integrator_on_one_and_two_processes() {
    let test = "plugin_strength_validate";
    let Some(Lammps { lmp, so }) = lammps(test) else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let asm = cubic_bar(10);
    let mut opts = LammpsValidateOptions::new(std::path::absolute(&lmp).unwrap());
    opts.two_processes = true;
    opts.export.bond_style = LammpsBondStyle::Anisobond { plugin: so };
    let dir = tempfile::tempdir().unwrap();
    let t = StrengthTest::new(2, 0.5 * R, 5e-7, 6_000);
    let r = run_strength(test, &Engine(opts), dir.path(), &asm, &t);
    assert_eq!(r.measured.len(), 2);
    for m in &r.measured {
        assert!(m.program.contains("bond_style anisobond"), "{}", m.program);
    }
    assert!(
        r.reference.breaks.len() >= 10,
        "the integrator broke only {} bonds",
        r.reference.breaks.len()
    );
    // The record is the plugin's: every line a bond of the bar, as many as LAMMPS lost.
    let record =
        std::fs::read_to_string(dir.path().join("lammps-plugin-strength/broken-np2.txt")).unwrap();
    let rows = record.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(rows, r.measured[1].breaks.len(), "{record}");
    assert!(r.passed(), "{:?}", r.failures());
}

/// UCS with the plugin on one and two processes: the prism pushed down 2e-6 of its gauge
/// length per step for 3,000 steps (as route (a)'s UCS test), the first peak and the first ten
/// broken bonds against the integrator's.
#[test]
fn plugin_ucs_peak_and_first_breaks_match_the_integrator_on_one_and_two_processes() {
    let test = "plugin_ucs_validate";
    let Some(Lammps { lmp, so }) = lammps(test) else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let asm = ucs_prism();
    let mut opts = LammpsValidateOptions::new(std::path::absolute(&lmp).unwrap());
    opts.two_processes = true;
    opts.export.bond_style = LammpsBondStyle::Anisobond { plugin: so };
    let dir = tempfile::tempdir().unwrap();
    let t = StrengthTest::new(2, 1.5 * R, 2e-6, 3_000).compression();
    let r = run_strength(test, &Engine(opts), dir.path(), &asm, &t);
    assert_eq!(r.measured.len(), 2);
    for run in std::iter::once(&r.reference).chain(&r.measured) {
        check_ucs_run(run, &t);
    }
    let deck =
        std::fs::read_to_string(dir.path().join("lammps-plugin-strength/in.strength")).unwrap();
    assert!(
        deck.contains("bond_style anisobond") && deck.contains("pair_style granular"),
        "{deck}"
    );
    assert!(r.passed(), "{:?}", r.failures());
}
