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
