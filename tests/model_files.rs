//! Model files: SPEC layout parses; every bad input is a clear error naming the file, the
//! line where it can, and what was expected.

use anisobond::bonds::BondingRule;
use anisobond::model::{Model, SchemeSpec};
use anisobond::Error;

const SPEC_EXAMPLE: &str = r#"
[bonding]
rule = "gap"
value = 0.17

[scheme]
kind = "cubic"
model = "zener-above-1"
extended = false
a_n = 4.31
a_s = 10.0
normal = 1.0e13
shear = 3.55e12
rotation = [[1,0,0],[0,1,0],[0,0,1]]

[geometry]
convention = "area"
bond_radius = "min"
"#;

#[test]
fn spec_example_parses() {
    let m = Model::from_toml_str(SPEC_EXAMPLE, "model.toml").unwrap();
    assert_eq!(m.bonding, BondingRule::Gap(0.17));
    match m.scheme {
        SchemeSpec::Cubic {
            a_n,
            a_s,
            normal,
            shear,
            extended,
            ..
        } => {
            assert_eq!(
                (a_n, a_s, normal, shear, extended),
                (4.31, 10.0, 1e13, 3.55e12, false)
            );
        }
        _ => panic!("not cubic"),
    }
    assert_eq!(m, Model::truszkowska_mrv());
}

#[test]
fn toml_round_trip() {
    let m = Model::truszkowska_mrv();
    let again = Model::from_toml_str(&m.to_toml_string(), "x").unwrap();
    assert_eq!(m, again);
}

#[test]
fn json_model_parses() {
    let json = r#"{"bonding": {"rule": "factor", "value": 1.8},
        "scheme": {"kind": "cross-anisotropic", "C11": 130e6, "C33": 55e6, "C13": 28e6, "C12": 40e6,
                   "strike_deg": 0.0, "dip_deg": 0.0}}"#;
    let m = Model::from_json_str(json, "m.json").unwrap();
    assert_eq!(m.bonding, BondingRule::Factor(1.8));
    match m.scheme {
        SchemeSpec::CrossAnisotropic { axis, .. } => {
            assert!((axis - anisobond::Vec3::z()).norm() < 1e-15)
        }
        _ => panic!(),
    }
    assert_eq!(
        m.geometry.convention,
        anisobond::schemes::Convention::Modulus
    );
}

fn err(text: &str) -> String {
    Model::from_toml_str(text, "bad.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_models_are_clear_errors() {
    // a ≤ 0
    let e = err(&SPEC_EXAMPLE.replace("a_n = 4.31", "a_n = 0.0"));
    assert!(e.contains("bad.toml") && e.contains("a_n"), "{e}");
    // syntax error: reports the line
    let e =
        Model::from_toml_str("[scheme]\nkind = \"cubic\"\na_n = = 3\n", "bad.toml").unwrap_err();
    match e {
        Error::Parse { line, ref path, .. } => {
            assert_eq!(line, 3);
            assert_eq!(path, "bad.toml");
        }
        other => panic!("{other}"),
    }
    // unknown key, with its line
    let e = Model::from_toml_str(
        &SPEC_EXAMPLE.replace("a_s = 10.0", "a_z = 10.0"),
        "bad.toml",
    )
    .unwrap_err();
    assert!(matches!(e, Error::Parse { line: 11, .. }), "{e}");
    // unknown kind / model / rule
    assert!(
        err(&SPEC_EXAMPLE.replace("kind = \"cubic\"", "kind = \"hexagonal\""))
            .contains("expected cubic")
    );
    assert!(err(&SPEC_EXAMPLE.replace("zener-above-1", "zener-above-2")).contains("zener-above-1"));
    assert!(
        err(&SPEC_EXAMPLE.replace("rule = \"gap\"", "rule = \"radius\"")).contains("expected gap")
    );
    // extended model at a_s = 10 has negative shear stiffness near <110>: refused
    let e = err(&SPEC_EXAMPLE.replace("extended = false", "extended = true"));
    assert!(
        e.to_lowercase().contains("negative") && e.to_lowercase().contains("shear"),
        "{e}"
    );
    // non-orthogonal rotation
    let e = err(&SPEC_EXAMPLE.replace("[[1,0,0],[0,1,0],[0,0,1]]", "[[1,0,0],[0,2,0],[0,0,1]]"));
    assert!(
        e.to_lowercase().contains("orthogonal") || e.to_lowercase().contains("rotation"),
        "{e}"
    );
    // NaN magnitude
    let e = err(&SPEC_EXAMPLE.replace("normal = 1.0e13", "normal = nan"));
    assert!(e.contains("normal"), "{e}");
    // cross-anisotropic target that is not positive definite is refused when built
    let cross = "[bonding]\nrule=\"factor\"\nvalue=1.8\n[scheme]\nkind=\"cross-anisotropic\"\nC11=1e6\nC33=1e6\nC13=5e6\nC12=0.0\n";
    let m = Model::from_toml_str(cross, "c.toml").unwrap();
    let p = anisobond::packing::Packing::new(
        vec![
            anisobond::Vec3::zeros(),
            anisobond::Vec3::new(2.0, 0.0, 0.0),
        ],
        vec![1.0, 1.0],
        None,
    )
    .unwrap();
    let mut b = anisobond::bonds::BondSet::default();
    b.push(0, 1, anisobond::Vec3::new(2.0, 0.0, 0.0), [0, 0, 0]);
    let e = m
        .build_scheme(Some((&p, &b)))
        .err()
        .expect("refused")
        .to_string();
    assert!(e.to_lowercase().contains("positive definite"), "{e}");
}

#[test]
fn euler_and_matrix_rotation_agree() {
    // The paper's Eq. 31 matrix, printed to 4 decimals, is accepted after
    // re-orthonormalisation and agrees with the exact Euler form to print precision.
    let printed = SPEC_EXAMPLE.replace(
        "[[1,0,0],[0,1,0],[0,0,1]]",
        "[[-0.3062,-0.9186,0.2500],[0.8839,-0.1768,0.4330],[-0.3536,0.3536,0.8660]]",
    );
    let euler = SPEC_EXAMPLE.replace(
        "rotation = [[1,0,0],[0,1,0],[0,0,1]]",
        "euler_zyz_deg = [60.0, 30.0, 45.0]",
    );
    let (a, b) = (
        Model::from_toml_str(&printed, "a").unwrap(),
        Model::from_toml_str(&euler, "b").unwrap(),
    );
    match (a.scheme, b.scheme) {
        (SchemeSpec::Cubic { rotation: ra, .. }, SchemeSpec::Cubic { rotation: rb, .. }) => {
            assert!((ra - rb).abs().max() < 1e-4, "{ra} vs {rb}");
        }
        _ => panic!(),
    }
}
