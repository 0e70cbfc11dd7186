//! `validate lammps --specimen` (issue 31 item 5): LAMMPS (BPM package, bpm/rotational with
//! one bond type per bond) builds the free bonded specimen of a 1,000-sphere packing with
//! the anisotropic cubic model (Truszkowska 2018 MRV, Zener > 1, parallel-bond moments),
//! holds its end layers (bonded: not integrated; frictionless: `fix setforce` on the axial
//! force), displaces the top one and relaxes it, on one and on two MPI processes; its
//! platen stiffness (the reaction `fix setforce` reports) must match the specimen solve
//! with bpm/rotational's midpoint contact point within 1e-3, for both platen kinds. The
//! comparison resolves the contact point: LAMMPS is several times closer to the midpoint
//! solve than to YADE's mid-gap one (which differs by ~1.5e-4 on this packing).

use super::export::one_lammps_at_a_time;
use crate::common::lammps::lmp;
use crate::common::specimen::{check_platen_stiffness, free_cubic_specimen};
use anisobond::homogenize::LeverArm;
use anisobond::specimen::{self, Platens};
use anisobond::validate::lammps::{Lammps, LammpsValidateOptions};
use anisobond::validate::specimen::SpecimenTest;
use anisobond::validate::{validate_specimen, Problem};

#[test]
fn lammps_platen_stiffness_matches_the_specimen_solve_on_one_and_two_processes() {
    let test = "lammps_platen_stiffness_matches_the_specimen_solve_on_one_and_two_processes";
    let Some(lmp) = lmp(test) else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let asm = free_cubic_specimen();
    let mut opts = LammpsValidateOptions::new(std::path::absolute(&lmp).unwrap());
    opts.two_processes = true;
    let engine = Lammps(opts);
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let dir = tempfile::tempdir().unwrap();
        let t = SpecimenTest::new(2, asm.packing.mean_radius(), platens);
        let r = validate_specimen(&engine, &Problem::of(dir.path(), &asm), &t, &|m: &str| {
            eprintln!("{test}: {m}")
        })
        .expect("the specimen test ran");
        assert_eq!(r.measured.len(), 2);
        check_platen_stiffness(test, "LAMMPS", platens, &r);
        assert!(r.passed(), "{:?}", r.failures());
        // The contact point is resolved: the mid-gap solve is several times farther off.
        let mut o = t.resolved(1e-5).solve_options(LeverArm::MidGap);
        o.platens = platens;
        let mid_gap = specimen::solve(&asm, &o).unwrap().platen_stiffness;
        let k = r.measured[0].stiffness();
        let (off_mid, off_half) = (
            ((k - mid_gap) / mid_gap).abs(),
            ((k - r.predicted.platen_stiffness) / r.predicted.platen_stiffness).abs(),
        );
        eprintln!("{test}: {platens:?}: LAMMPS vs mid-gap solve {off_mid:.3e}, vs midpoint {off_half:.3e}");
        assert!(
            off_mid > 5.0 * off_half,
            "mid-gap {off_mid:e}, midpoint {off_half:e}"
        );
    }
}
