//! `validate lammps --strength` (issue 32 item 5): quasi-static direct tension of a bonded
//! simple-cubic bar (10 × 10 × 10 spheres of R = 1 mm, 2,700 bonds; isotropic springs,
//! Weibull-scattered tensile strengths, seeded) between held end layers, to failure, in
//! LAMMPS route (a) (`bpm/rotational break yes smooth no`, one bond type per bond with its
//! own limits) on one and two processes and in the integrator with the same law (d),
//! springs, damping and limits: the peak stress within 2 % and the first ten bonds to break
//! the same, in the same order (LAMMPS' own record of broken bonds, `store/local`).

use super::export::{lmp, one_lammps_at_a_time};
use crate::common::strength_bar::{cubic_bar, R};
use anisobond::validate::lammps::{Lammps, LammpsValidateOptions};
use anisobond::validate::strength::StrengthTest;
use anisobond::validate::{validate_strength, Problem};

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
    let r = validate_strength(&engine, &Problem::of(dir.path(), &asm), &t, &|m: &str| {
        eprintln!("{test}: {m}")
    })
    .expect("the strength test ran");
    eprintln!("{}", anisobond::validate::strength::summary(&r));
    assert_eq!(r.measured.len(), 2);
    assert!(
        r.reference.breaks.len() >= 10,
        "the integrator broke only {} bonds",
        r.reference.breaks.len()
    );
    assert!(r.passed(), "{:?}", r.failures());
}
