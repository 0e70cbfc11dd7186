//! `validate liggghts --specimen` (issue 31 item 5): the LIGGGHTS driver (`pair_style
//! anisobond`, incremental moments, mid-gap contact points) builds the free bonded specimen
//! of a 1,000-sphere packing with the anisotropic cubic model (Truszkowska 2018 MRV, Zener >
//! 1, parallel-bond moments), holds its end layers (bonded: the top one `fix freeze`, the
//! bottom one not integrated; frictionless: `fix setforce` on the axial force), moves the
//! top one by velocity and relaxes with the pair style's viscous damping, on one and on two
//! MPI processes; its platen stiffness must match the specimen solve within 1e-3 for both
//! platen kinds. The check can fail: the two platen kinds differ by far more, and the
//! frictionless measurement is out of tolerance against the bonded solve.

use crate::common::liggghts::*;
use crate::common::specimen::{check_platen_stiffness, free_cubic_specimen};
use anisobond::specimen::Platens;
use anisobond::validate::liggghts::{Liggghts, Programs, ValidateOptions};
use anisobond::validate::specimen::SpecimenTest;
use anisobond::validate::{validate_specimen, Problem};

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];

#[test]
fn liggghts_platen_stiffness_matches_the_specimen_solve_on_one_and_two_processes() {
    let test = "liggghts_platen_stiffness_matches_the_specimen_solve_on_one_and_two_processes";
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping {test}: {r}");
        return;
    }
    let asm = free_cubic_specimen();
    let engine = Liggghts {
        programs: Programs {
            driver: driver(),
            liggghts: "liggghts".into(),
        },
        options: ValidateOptions {
            processes: 2,
            ..ValidateOptions::default()
        },
    };
    let mut measured = Vec::new();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let dir = fresh_dir(&format!("specimen-{platens:?}"));
        let t = SpecimenTest::new(2, asm.packing.mean_radius(), platens);
        let r = validate_specimen(&engine, &Problem::of(&dir, &asm), &t, &|m: &str| {
            eprintln!("{test}: {m}")
        })
        .expect("the specimen test ran");
        assert_eq!(r.measured.len(), 2);
        check_platen_stiffness(test, "LIGGGHTS", platens, &r);
        assert!(r.passed(), "{:?}", r.failures());
        measured.push((r.measured[0].stiffness(), r.predicted.platen_stiffness));
    }
    let (frictionless, bonded) = (measured[0], measured[1]);
    assert!((bonded.1 - frictionless.1) / frictionless.1 > 0.02);
    assert!(((frictionless.0 - bonded.1) / bonded.1).abs() > 1e-2);
}
