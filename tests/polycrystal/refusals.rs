//! Refusals: bad `[grains]` keys at their line, grain files that do not fit, and what
//! cannot honour grains yet (many-body term, mean field, calibration, column springs).

use super::common::bonded::generated;
use super::{cubic_model, isotropic_model};
use anisobond::prelude::*;

/// The refusal of a model text, which must be a parse error at `line` naming `key`.
fn refused_at(text: &str, line: usize, key: &str) {
    match Model::from_toml_str(text, "model.toml") {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.starts_with(&format!("model.toml:{line}:")), "{m}\n{text}");
            assert!(m.contains(key), "{m} lacks {key}");
        }
        other => panic!("expected a parse error at line {line}, got {other:?}\n{text}"),
    }
}

#[test]
fn bad_grains_keys_are_named_at_their_line() {
    // Line 8 is `[grains]` (the bonding and scheme take lines 1–7); its keys follow.
    let t = |body: &str| isotropic_model(&format!("[grains]\n{body}"));
    assert_eq!(t("").lines().position(|l| l == "[grains]"), Some(7));
    refused_at(&t("count = 5\ncolour = 3\n"), 10, "colour");
    refused_at(&t("count = 2.5\n"), 9, "count");
    refused_at(&t("count = -3\n"), 9, "count");
    refused_at(&t("count = 4\nseed = \"x\"\n"), 10, "seed");
    refused_at(
        &t("count = 4\norientation = \"texture\"\n"),
        10,
        "orientation",
    );
    refused_at(&t("count = 4\nspread_deg = [1]\n"), 10, "spread_deg");
    // Keys that do not go together: refused at the table, naming the key.
    for (body, key) in [
        ("count = 4\nmean_size = 3\n", "exactly one of"),
        ("orientation = \"random\"\n", "exactly one of"),
        ("count = 0\n", "count = 0"),
        ("count = 4\naxis = [1, 0, 0]\n", "`axis`"),
        (
            "count = 4\norientation = \"fibre\"\neuler_file = \"e.txt\"\n",
            "`euler_file`",
        ),
        (
            "count = 4\norientation = \"euler-file\"\n",
            "needs `euler_file`",
        ),
        (
            "count = 4\norientation = \"fibre\"\nspread_deg = -1\n",
            "spread_deg",
        ),
        (
            "count = 4\norientation = \"fibre\"\naxis = [0, 0, 0]\n",
            "axis",
        ),
        ("count = 4\nboundary_factor = 0\n", "boundary_factor"),
        (
            "count = 4\nboundary_strength_factor = 0\n",
            "boundary_strength_factor",
        ),
        (
            "count = 4\nboundary_strength_factor = -0.5\n",
            "boundary_strength_factor",
        ),
        (
            "count = 4\nboundary_strength_factor = inf\n",
            "boundary_strength_factor",
        ),
        (
            "count = 4\nboundary_strength_factor = \"weak\"\n",
            "boundary_strength_factor",
        ),
        ("count = 4\nboundary = \"harmonic\"\n", "boundary"),
    ] {
        match Model::from_toml_str(&t(body), "model.toml") {
            Err(e @ Error::Parse { .. }) => {
                let m = e.to_string();
                assert!(m.starts_with("model.toml:"), "{m}");
                assert!(m.contains(key), "{m} lacks {key}");
            }
            other => panic!("{body}: expected a parse error, got {other:?}"),
        }
    }
    // The same in JSON: the key named.
    let json = "{\"scheme\": {\"kind\": \"isotropic\", \"normal\": 1, \"shear\": 1}, \
                \"grains\": {\"count\": 3, \"colour\": 1}}";
    let e = Model::from_json_str(json, "model.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("colour") && e.starts_with("model.json:1:"),
        "{e}"
    );
}

#[test]
fn grain_files_that_do_not_fit_are_refused_naming_file_and_line() {
    let p = generated(300, 61);
    let dir = super::common::tmp();
    let path = dir.path().join("model.toml");
    std::fs::write(&path, isotropic_model("[grains]\nfile = \"ids.txt\"\n")).unwrap();
    let ids = dir.path().join("ids.txt");
    let build = || Assembly::new(p.clone(), Model::from_path(&path).unwrap());
    // One id short.
    std::fs::write(&ids, "0\n".repeat(p.len() - 1)).unwrap();
    match build() {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.contains("ids.txt") && m.contains("299 grain ids"), "{m}");
            assert!(m.contains("300 particles"), "{m}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    // A bad line, named with its number.
    std::fs::write(&ids, format!("# ids\n{}1.5\n", "0\n".repeat(10))).unwrap();
    match build() {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.contains("ids.txt:12:") && m.contains("1.5"), "{m}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    // An Euler file with a grain too few for the map (ids 0..=2: three grains).
    std::fs::write(&ids, "0\n1\n2\n".repeat(p.len() / 3)).unwrap();
    std::fs::write(dir.path().join("euler.txt"), "0 0 0\n10 20 30\n").unwrap();
    std::fs::write(
        &path,
        isotropic_model(
            "[grains]\nfile = \"ids.txt\"\norientation = \"euler-file\"\neuler_file = \"euler.txt\"\n",
        ),
    )
    .unwrap();
    match build() {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.contains("euler.txt") && m.contains("2 grains"), "{m}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    std::fs::write(dir.path().join("euler.txt"), "0 0 0\n10 20\n5 5 5\n").unwrap();
    match build() {
        Err(e @ Error::Parse { .. }) => assert!(e.to_string().contains("euler.txt:2:"), "{e}"),
        other => panic!("expected a parse error, got {other:?}"),
    }
    // More grains than particles.
    std::fs::write(&path, isotropic_model("[grains]\ncount = 301\n")).unwrap();
    assert!(matches!(build(), Err(Error::Model(_))));
}

#[test]
fn what_cannot_honour_grains_refuses_them() {
    let grains = "[grains]\ncount = 5\n";
    // ([grains] with [manybody] is a polycrystal's term: tests/polycrystal/manybody.rs.)
    let model = Model::from_toml_str(&cubic_model("", grains), "model.toml").unwrap();
    // One scheme, the column springs and calibration: Error::Model.
    assert!(matches!(model.build_scheme(None), Err(Error::Model(_))));
    assert!(matches!(
        model.springs_for(&[Vec3::z()], &[1.0], &[1.0], &[2.0], None),
        Err(Error::Model(_))
    ));
    let target = anisobond::calibrate::Target::CrossAnisotropic {
        c11: 3e10,
        c33: 2e10,
        c13: 5e9,
        c12: 6e9,
        c44: None,
    };
    let on = anisobond::calibrate::CalibrateOn::MeanField(anisobond::assembly::EqualSpheres {
        coordination: 6.0,
        solid_fraction: 0.6,
        radius: 1e-3,
    });
    let options = anisobond::calibrate::CubicOptions::default();
    assert!(matches!(
        anisobond::calibrate::calibrate(&model, &target, on, &options),
        Err(Error::Model(_))
    ));
    // The mean field of one orientation: refused by method, naming it; the bond sums run.
    let a = Assembly::new(generated(400, 62), model).unwrap();
    match a.tensor(&Method::MeanField) {
        Err(Error::Invalid(m)) => {
            assert!(m.contains("mean-field") && m.contains("[grains]"), "{m}")
        }
        other => panic!("expected Error::Invalid, got {other:?}"),
    }
    a.tensor(&Method::Voigt).unwrap();
    a.tensor(&Method::Laf {
        shell: 1,
        energy: false,
        lever_arm: Default::default(),
    })
    .unwrap();
}
