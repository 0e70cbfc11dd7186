//! Typed errors of `validate lammps` (README "Errors and limits"): a program that fails as
//! LAMMPS is an engine failure (exit 6, naming LAMMPS), a validation that runs to the end with
//! a comparison outside its tolerance is exit 7; a refusal of the input stays exit 1.

use crate::common::lammps::lmp;
use crate::common::*;
use crate::export::one_lammps_at_a_time;

#[test]
fn engine_failure_out_of_tolerance_and_bad_input_have_their_own_exit_codes() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 300);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let o = d.join("out");
    // A "LAMMPS" that exits 1 without a word: the engine failed, not the input.
    let failing = cmd(
        "validate lammps {p} --model {m} --np 1 --lmp /bin/false -o {o}",
        &[("p", &p), ("m", &m), ("o", &o)],
    )
    .output()
    .unwrap();
    let err = stderr(&failing);
    assert_eq!(failing.status.code(), Some(6), "{err}");
    assert!(
        err.contains("LAMMPS") && err.contains("no error line"),
        "{err}"
    );
    assert!(!o.exists());
    // Bad input stays 1.
    let bad = cmd(
        "validate lammps {p} --model {m} --np 1 --tolerance 0 -o {o}",
        &[("p", &p), ("m", &m), ("o", &o)],
    )
    .output()
    .unwrap();
    assert_eq!(bad.status.code(), Some(1), "{}", stderr(&bad));
    // The real LAMMPS against a tolerance no run can meet: the validation ran and failed.
    let Some(lmp) = lmp("engine_failure_out_of_tolerance_and_bad_input_have_their_own_exit_codes")
    else {
        return;
    };
    let _one = one_lammps_at_a_time();
    let out = cmd(
        "validate lammps {p} --model {m} --np 1 --tolerance 1e-14 --lmp {lmp} -o {o}",
        &[("p", &p), ("m", &m), ("o", &o), ("lmp", &lmp)],
    )
    .output()
    .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(7), "{err}");
    assert!(err.contains("outside tolerance"), "{err}");
}
