//! The registry of names (issue 30 item 2): every tensor method and scheme kind is parsed back
//! from its name, an unknown name is refused listing every name, and the CLI's `--method`
//! accepts exactly the registry's methods.

use crate::common::bin;
use anisobond::assembly::{MethodKind, MethodOptions};
use anisobond::schemes::SchemeKind;
use anisobond::Error;

#[test]
fn every_name_parses_back_and_an_unknown_one_lists_them_all() {
    for &k in MethodKind::ALL {
        assert_eq!(k.name().parse::<MethodKind>().unwrap(), k);
        assert_eq!(MethodOptions::default().method(k).kind(), k);
        assert!(!k.description().is_empty());
    }
    for &k in SchemeKind::ALL {
        assert_eq!(k.to_string().parse::<SchemeKind>().unwrap(), k);
    }
    match "relax".parse::<MethodKind>() {
        Err(Error::Invalid(m)) => assert_eq!(
            m,
            "method `relax`: expected mean-field, voigt, relaxed, prestressed, laf or dynamic"
        ),
        other => panic!("{other:?}"),
    }
}

/// `tensor --method` takes every name of the registry and no other (clap's own list, read
/// from the refusal of a name that is not one).
#[test]
fn the_cli_accepts_exactly_the_registry() {
    let out = bin()
        .args(["tensor", "--model", "m.toml", "--method", "relax"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    let names: Vec<&str> = MethodKind::ALL.iter().map(|m| m.name()).collect();
    assert!(
        err.contains(&format!("[possible values: {}]", names.join(", "))),
        "{err}"
    );
}
