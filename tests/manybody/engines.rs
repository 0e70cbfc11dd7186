//! The many-body term and YADE (docs/manybody.md, "YADE"): YADE's bond laws are pairwise,
//! so `export yade` writes a run.py that adds the term as anisobond_yade's PyRunner engine
//! (the real YADE runs it in tests/python/test_yade_manybody.py), and `validate yade`, which
//! does not assume the Python package inside YADE, refuses the term before writing anything.

use super::common::lattice::fcc_bonded;
use anisobond::export::yade::{write_assembly_export, YadeRunOptions};
use anisobond::model::Model;
use anisobond::validate::yade::{Yade, YadeValidationOptions};
use anisobond::validate::{validate, Problem};
use anisobond::{Assembly, Error};

const MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 1e-4\n[scheme]\nkind = \"isotropic\"\n\
normal = 2.0e9\nshear = 0.6e9\n[manybody]\nkind = \"isotropic\"\nbulk = 1.0e6\nshear = 0.0\n";

fn fcc_assembly(text: &str) -> Assembly {
    let (p, b) = fcc_bonded(1e-3);
    Assembly::with_bonds(p, Model::from_toml_str(text, "m.toml").unwrap(), b).unwrap()
}

#[test]
fn export_yade_runs_the_term_through_the_package() {
    let dir = tempfile::tempdir().unwrap();
    let asm = fcc_assembly(MODEL);
    write_assembly_export(dir.path(), &asm, &YadeRunOptions::default()).unwrap();
    let run = std::fs::read_to_string(dir.path().join("run.py")).unwrap();
    assert!(
        run.contains("\"--model\", os.path.join(HERE, \"model.toml\")"),
        "{run}"
    );
    assert!(run.contains("[manybody] term"), "{run}");
    // The model written beside it carries the term.
    let written = Model::from_path(&dir.path().join("model.toml")).unwrap();
    assert_eq!(written.manybody, asm.model.manybody);

    // Without the term, run.py keeps the table's springs (no --model).
    let plain = MODEL.split("[manybody]").next().unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_assembly_export(dir.path(), &fcc_assembly(plain), &YadeRunOptions::default()).unwrap();
    let run = std::fs::read_to_string(dir.path().join("run.py")).unwrap();
    assert!(!run.contains("--model"), "{run}");
}

#[test]
fn export_yade_refuses_a_packing_the_term_cannot_carry_and_writes_nothing() {
    // Refused rattlers: an FCC particle with its bonds thinned to two.
    let (p, b) = fcc_bonded(1e-3);
    let mut kept = anisobond::bonds::BondSet::default();
    let mut count = 0;
    for e in 0..b.len() {
        if b.i[e] == 0 || b.j[e] == 0 {
            count += 1;
            if count > 2 {
                continue;
            }
        }
        kept.push(b.i[e], b.j[e], b.branch(e), b.image[e]);
    }
    let text = format!("{MODEL}degenerate = \"refuse\"\n");
    let asm =
        Assembly::with_bonds(p, Model::from_toml_str(&text, "m.toml").unwrap(), kept).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("export");
    match write_assembly_export(&out, &asm, &YadeRunOptions::default()) {
        Err(Error::Degenerate(m)) => assert!(m.contains("particle 0"), "{m}"),
        other => panic!("expected Degenerate, got {other:?}"),
    }
    assert!(!out.exists());
}

#[test]
fn validate_yade_refuses_the_term_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let asm = fcc_assembly(MODEL);
    let problem = Problem::of(dir.path(), &asm);
    let engine = Yade(YadeValidationOptions::default());
    match validate(&engine, &problem, &|_| {}) {
        Err(Error::Invalid(m)) => {
            assert!(
                m.contains("[manybody]") && m.contains("validate lammps"),
                "{m}"
            )
        }
        other => panic!("expected Invalid, got {:?}", other.map(|r| r.passed())),
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn free_specimen_validations_refuse_the_term_in_every_engine() {
    // The refusal is the engines' common one (validate_specimen / validate_strength), so
    // one engine shows it; it comes before any deck is written.
    use anisobond::specimen::Platens;
    use anisobond::validate::specimen::SpecimenTest;
    use anisobond::validate::strength::StrengthTest;
    use anisobond::validate::{validate_specimen, validate_strength};
    let dir = tempfile::tempdir().unwrap();
    let asm = fcc_assembly(MODEL);
    let problem = Problem::of(dir.path(), &asm);
    let engine = Yade(YadeValidationOptions::default());
    let specimen = validate_specimen(
        &engine,
        &problem,
        &SpecimenTest::new(2, 1e-3, Platens::Frictionless),
        &|_| {},
    );
    let strength = validate_strength(
        &engine,
        &problem,
        &StrengthTest::new(2, 1e-3, 1e-5, 100),
        &|_| {},
    );
    for (what, r) in [
        ("specimen test", specimen.map(|r| r.passed())),
        ("strength test", strength.map(|r| r.passed())),
    ] {
        match r {
            Err(Error::Invalid(m)) => {
                assert!(m.contains("[manybody]") && m.contains(what), "{m}")
            }
            other => panic!("{what}: expected Invalid, got {other:?}"),
        }
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn free_specimen_studies_refuse_the_term_instead_of_dropping_it() {
    // The specimen solve and the cavity cut a free body: the term's default volumes need a
    // periodic cell, so they refuse rather than solve the springs alone.
    let asm = fcc_assembly(MODEL);
    let specimen =
        anisobond::specimen::solve(&asm, &anisobond::specimen::SpecimenOptions::new(2, 1e-3));
    let cavity = anisobond::cavity::Cavity::new(
        &asm,
        anisobond::cavity::CavityGeometry {
            inner_radius: 1e-3,
            outer_radius: 3e-3,
            clamp_width: 1e-3,
            ray_spacing: 2e-4,
        },
    );
    for (what, r) in [
        ("specimen solve", specimen.err()),
        ("cavity study", cavity.err()),
    ] {
        match r {
            Some(Error::Model(m)) => assert!(m.contains("[manybody]") && m.contains(what), "{m}"),
            other => panic!("{what}: expected a Model refusal, got {other:?}"),
        }
    }
}

#[test]
fn the_dynamic_tensor_method_carries_the_term() {
    // The integrator's element tests with the term on FCC (centro-symmetric: relaxed =
    // Voigt = springs + D) against the relaxed tensor with the term.
    use anisobond::assembly::{Method, MethodKind, MethodOptions};
    let text = MODEL.replace("bulk = 1.0e6\nshear = 0.0", "bulk = 2.0e6\nshear = 0.5e6");
    let asm = fcc_assembly(&text);
    let relaxed = asm.tensor(&Method::relaxed()).unwrap().report.c;
    let dynamic = asm
        .tensor(&MethodOptions::default().method(MethodKind::Dynamic))
        .unwrap()
        .report
        .c;
    let without = fcc_assembly(MODEL.split("[manybody]").next().unwrap())
        .tensor(&Method::relaxed())
        .unwrap()
        .report
        .c;
    let scale = relaxed
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let diff = (0..6)
        .flat_map(|i| (0..6).map(move |j| (i, j)))
        .map(|(i, j)| (dynamic[i][j] - relaxed[i][j]).abs())
        .fold(0.0_f64, f64::max);
    assert!(
        diff < 5e-3 * scale,
        "dynamic vs relaxed: {diff:e} of {scale:e}"
    );
    // The term is not negligible here: C12 moves by K' − 2G'/3 ≈ 1.67 MPa.
    assert!((relaxed[0][1] - without[0][1] - (2.0e6 - 2.0 * 0.5e6 / 3.0)).abs() < 1e-6 * scale);
}
