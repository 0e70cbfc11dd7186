//! The `[strength]` table of a model file: read into the spec it describes, checked when the
//! model is read, refusals naming the file, the key and the line.

use anisobond::model::Model;
use anisobond::strength::schemes::StrengthScheme;
use anisobond::strength::{Scatter, Strength, StrengthSpec};
use anisobond::Vec3;
use std::path::Path;

const ELASTIC: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n";

fn read(strength: &str) -> anisobond::Result<Option<StrengthSpec>> {
    let text = format!("{ELASTIC}{strength}");
    let path = Path::new("rock.toml");
    // The model reads (and checks) the table too.
    Model::from_str_for(&text, path)?;
    Model::strength_from_str_for(&text, path)
}

#[test]
fn a_cross_anisotropic_table_with_planes_and_scatter_reads_as_written() {
    let spec = read(
        "[strength]\nstrike_deg = 90.0\ndip_deg = 30.0\n\
         [strength.bond]\ntensile = 5e6\ncohesion = 1e7\nfriction = 0.5\n\
         [strength.along]\ntensile = 2e6\ncohesion = 6e6\n\
         [[strength.planes]]\nnormal = [0, 0, 2]\nspacing = 2e-3\noffset = 1e-4\ntensile = 5e5\ncohesion = 1e6\nfriction = 0.6\n\
         [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 9\n",
    )
    .unwrap()
    .unwrap();
    match &spec.scheme {
        StrengthScheme::CrossAnisotropic(c) => {
            assert_eq!(
                c.across,
                Strength {
                    friction: 0.5,
                    ..Strength::new(5e6, 1e7)
                }
            );
            assert_eq!(c.along, Strength::new(2e6, 6e6));
            let want = Vec3::new(0.0, -0.5, 30f64.to_radians().cos());
            assert!((c.axis - want).norm() < 1e-15, "{:?}", c.axis);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(spec.planes.len(), 1);
    assert_eq!(spec.planes[0].normal, Vec3::z());
    assert_eq!(
        (spec.planes[0].spacing, spec.planes[0].offset),
        (2e-3, 1e-4)
    );
    assert_eq!(spec.planes[0].joint.friction, 0.6);
    assert_eq!(
        spec.scatter,
        Some(Scatter::Weibull {
            modulus: 5.0,
            seed: 9
        })
    );
    // Read from a file as from its text.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rock.toml");
    std::fs::write(
        &path,
        format!("{ELASTIC}[strength.bond]\ntensile = 1e6\ncohesion = 2e6\n"),
    )
    .unwrap();
    let from_file = Model::strength_from_path(&path).unwrap().unwrap();
    assert_eq!(
        from_file.scheme,
        StrengthScheme::Isotropic(Strength::new(1e6, 2e6))
    );
    // No table: None, and the model reads as before.
    assert_eq!(read("").unwrap(), None);
}

#[test]
fn a_json_model_carries_the_same_table() {
    let text = r#"{"bonding": {"rule": "gap", "value": 0.01},
        "scheme": {"kind": "isotropic", "normal": 2e6, "shear": 7e5},
        "geometry": {"convention": "spring"},
        "strength": {"bond": {"tensile": 1e6, "cohesion": 2e6, "friction": 0.3},
                     "scatter": {"distribution": "normal", "cv": 0.1, "seed": 4}}}"#;
    let path = Path::new("rock.json");
    Model::from_str_for(text, path).unwrap();
    let spec = Model::strength_from_str_for(text, path).unwrap().unwrap();
    let want = Strength {
        friction: 0.3,
        ..Strength::new(1e6, 2e6)
    };
    assert_eq!(spec.scheme, StrengthScheme::Isotropic(want));
    assert_eq!(spec.scatter, Some(Scatter::Normal { cv: 0.1, seed: 4 }));
    let bad = text.replace("\"seed\": 4", "\"seed\": 4, \"modulus\": 2");
    let e = Model::strength_from_str_for(&bad, path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("rock.json") && e.contains("modulus"), "{e}");
}

#[test]
fn cubic_and_isotropic_tables() {
    let spec = read(
        "[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n[strength.cubic]\nmodel = \"zener-below-1\"\na_tensile = 2.0\na_shear = 0.5\neuler_zyz_deg = [10, 20, 30]\n",
    )
    .unwrap()
    .unwrap();
    assert!(matches!(spec.scheme, StrengthScheme::Cubic(_)));
    let spec = read("[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n")
        .unwrap()
        .unwrap();
    assert_eq!(
        spec.scheme,
        StrengthScheme::Isotropic(Strength::new(5e6, 1e7))
    );
}

#[test]
fn bad_tables_are_refused_naming_key_and_line() {
    let cases: [(&str, &[&str]); 9] = [
        ("[strength.bond]\ntensile = 5e6\ncohesoin = 1e7\n", &["cohesoin", "rock.toml:"]),
        ("[strength.bond]\ntensile = 5e6\n", &["cohesion"]),
        ("[strength]\naxis = [0, 0, 1]\n", &["bond"]),
        ("[strength.bond]\ntensile = -5e6\ncohesion = 1e7\n", &["tensile", "rock.toml:1", "[strength.bond]"]),
        ("[strength]\naxis = [0, 0, 1]\n[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n", &["along"]),
        (
            "[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n[strength.along]\ntensile = 1\ncohesion = 1\n[strength.cubic]\nmodel = \"zener-above-1\"\na_tensile = 1\na_shear = 1\n",
            &["not both"],
        ),
        (
            "[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n[[strength.planes]]\nspacing = 1e-3\ntensile = 1\ncohesion = 1\n",
            &["planes]] #1", "normal"],
        ),
        (
            "[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n[strength.scatter]\ndistribution = \"weibull\"\ncv = 0.1\nseed = 1\n",
            &["modulus"],
        ),
        (
            "[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n[strength.scatter]\ndistribution = \"gauss\"\ncv = 0.1\nseed = 1\n",
            &["gauss", "weibull or normal"],
        ),
    ];
    for (table, words) in cases {
        let e = read(table).unwrap_err().to_string();
        for w in words {
            assert!(e.contains(w), "{table}: `{e}` lacks `{w}`");
        }
    }
    // The unknown key is reported at its own line (line 12 of the file).
    let e = read("[strength.bond]\ntensile = 5e6\ncohesoin = 1e7\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("rock.toml:12"), "{e}");
}

/// A model written back (calibrated models, exports' `model.toml`, `Model.save`) keeps its
/// `[strength]` table: the written text reads back into the same spec, in TOML and JSON.
#[test]
fn a_model_written_back_keeps_its_strength_table() {
    let strength = "[strength]\nstrike_deg = 90.0\ndip_deg = 30.0\n\
         [strength.bond]\ntensile = 5e6\ncohesion = 1e7\nfriction = 0.5\n\
         [strength.along]\ntensile = 2e6\ncohesion = 6e6\n\
         [[strength.planes]]\nnormal = [0, 0, 2]\nspacing = 2e-3\noffset = 1e-4\ntensile = 5e5\ncohesion = 1e6\nfriction = 0.6\n\
         [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 9\n";
    let text = format!("{ELASTIC}{strength}");
    let path = Path::new("rock.toml");
    let model = Model::from_str_for(&text, path).unwrap();
    assert!(model.strength.is_some());
    let want = Model::strength_from_str_for(&text, path).unwrap();
    let toml = model.to_toml_string();
    assert_eq!(
        Model::strength_from_str_for(&toml, path).unwrap(),
        want,
        "{toml}"
    );
    assert_eq!(Model::from_str_for(&toml, path).unwrap(), model);
    let json = model.to_json_string();
    let json_path = Path::new("rock.json");
    assert_eq!(
        Model::strength_from_str_for(&json, json_path).unwrap(),
        want,
        "{json}"
    );
    // And a model without one writes none.
    let plain = Model::from_str_for(ELASTIC, path).unwrap();
    assert!(!plain.to_toml_string().contains("strength"));
}
