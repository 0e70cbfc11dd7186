//! Polycrystals (issue 34, docs/polycrystal.md): grains, their orientations and springs by
//! grain, against the single crystal, brute-force nearest-centre searches, closed-form
//! rotations, sampling statistics and transverse isotropy of a fibre texture.
//! One module per concern; see tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod assignment;
mod boundary;
mod engine_grains;
mod engines;
mod exports;
mod fibre;
mod manybody;
mod orientation;
mod refusals;
mod single_crystal;
mod study;
mod threads;
mod vtk_cli;

use anisobond::prelude::*;

/// Truszkowska 2018's MRV cubic model (zener-above-1, gap 0.17 R̄), with `extra` appended
/// to the `[scheme]` table and `tables` after it.
pub fn cubic_model(extra: &str, tables: &str) -> String {
    format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\n\
         model = \"zener-above-1\"\na_n = 4.31\na_s = 10.0\nnormal = 1.0e13\n\
         shear = 3.55e12\n{extra}{tables}"
    )
}

/// An isotropic model (gap 0.17 R̄) with `tables` after the scheme.
pub fn isotropic_model(tables: &str) -> String {
    format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\n\
         normal = 1.0e13\nshear = 3.55e12\n{tables}"
    )
}

/// A model from TOML text, or the test fails with the refusal.
pub fn model(text: &str) -> Model {
    Model::from_toml_str(text, "model.toml").unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// `rotation = [[..], [..], [..]]` of `g`, every entry in its shortest round-trip form.
pub fn rotation_key(g: &Mat3) -> String {
    let row = |i: usize| format!("[{:?}, {:?}, {:?}]", g[(i, 0)], g[(i, 1)], g[(i, 2)]);
    format!("rotation = [{}, {}, {}]\n", row(0), row(1), row(2))
}

/// The bits of a tensor, for exact comparisons.
pub fn bits(c: &Stiffness6) -> Vec<u64> {
    c.iter().map(|x| x.to_bits()).collect()
}

/// The relaxed tensor of an assembly.
pub fn relaxed(a: &Assembly) -> Stiffness6 {
    let c = a
        .tensor(&Method::relaxed())
        .expect("relaxed tensor")
        .report
        .c;
    Stiffness6::from_fn(|i, j| c[i][j])
}
