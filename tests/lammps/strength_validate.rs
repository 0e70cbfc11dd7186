//! `validate lammps --strength` (issue 32 item 5): quasi-static direct tension of a bonded
//! simple-cubic bar (10 × 10 × 10 spheres of R = 1 mm, 2,700 bonds; isotropic springs,
//! Weibull-scattered tensile strengths, seeded) between held end layers, to failure, in
//! LAMMPS route (a) (`bpm/rotational break yes smooth no`, one bond type per bond with its
//! own limits) on one and two processes and in the integrator with the same law (d),
//! springs, damping and limits: the peak stress within 2 % and the first ten bonds to break
//! the same, in the same order (LAMMPS' own record of broken bonds, `store/local`). The same
//! in uniaxial compression (UCS) of the turned-lattice prism (`ucs_prism`: 1,027 spheres,
//! 2,635 bonds that break in shear), with frictional contacts after breaking in both
//! (`pair_style granular` hooke, and the integrator's contacts).

use super::export::one_lammps_at_a_time;
use crate::common::lammps::lmp;
use crate::common::strength_bar::{check_ucs_run, cubic_bar, run_strength, ucs_prism, R};
use anisobond::validate::lammps::{Lammps, LammpsValidateOptions};
use anisobond::validate::strength::StrengthTest;

#[test]
fn lammps_route_a_tension_peak_and_first_breaks_match_the_integrator_on_one_and_two_processes() {
    let test = "lammps_strength_validate";
    let Some(lmp) = lmp(test) else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let asm = cubic_bar(10);
    let mut opts = LammpsValidateOptions::new(std::path::absolute(&lmp).unwrap());
    opts.two_processes = true;
    let engine = Lammps(opts);
    let dir = tempfile::tempdir().unwrap();
    let t = StrengthTest::new(2, 0.5 * R, 5e-7, 6_000);
    let r = run_strength(test, &engine, dir.path(), &asm, &t);
    assert_eq!(r.measured.len(), 2);
    assert!(
        r.reference.breaks.len() >= 10,
        "the integrator broke only {} bonds",
        r.reference.breaks.len()
    );
    assert!(r.passed(), "{:?}", r.failures());
}

/// UCS on one and two processes: the prism pushed down 2e-6 of its gauge length per step for
/// 3,000 steps, the first peak and the first ten broken bonds against the integrator's.
/// Measured: peak relative difference 3.0e-5 on 1 and 2 processes, first ten the same.
#[test]
fn lammps_route_a_ucs_peak_and_first_breaks_match_the_integrator_on_one_and_two_processes() {
    let test = "lammps_ucs_validate";
    let Some(lmp) = lmp(test) else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let asm = ucs_prism();
    let mut opts = LammpsValidateOptions::new(std::path::absolute(&lmp).unwrap());
    opts.two_processes = true;
    let engine = Lammps(opts);
    let dir = tempfile::tempdir().unwrap();
    let t = StrengthTest::new(2, 1.5 * R, 2e-6, 3_000).compression();
    let r = run_strength(test, &engine, dir.path(), &asm, &t);
    assert_eq!(r.measured.len(), 2);
    for run in std::iter::once(&r.reference).chain(&r.measured) {
        check_ucs_run(run, &t);
    }
    // The deck loads in compression with contacts: the top layer moves down, broken pairs
    // meet pair_style granular.
    let deck = std::fs::read_to_string(dir.path().join("lammps-strength/in.strength")).unwrap();
    assert!(deck.contains("pair_style granular") && deck.contains("variable F equal c_ftop"));
    assert!(r.passed(), "{:?}", r.failures());
}
