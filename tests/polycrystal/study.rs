//! The polycrystal study (`anisobond::study::polycrystal`, `anisobond polycrystal`): a
//! one-grain identity polycrystal is its single crystal, isotropic grains change nothing,
//! each grain's directional modulus against the tensor turned as a whole, the stress
//! carried by stiff grains, the command against the library, refusals.

use super::common::bonded::generated;
use super::{cubic_model, isotropic_model, model};
use anisobond::prelude::*;
use anisobond::study::polycrystal::{run, PolycrystalOptions, PolycrystalReport};
use anisobond::tensor::rotate;

fn study(p: &Packing, m: &Model, opts: &PolycrystalOptions) -> PolycrystalReport {
    run(p, m, opts, OptionNames::Keywords, &|_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn matrix(r: &[[f64; 6]; 6]) -> Stiffness6 {
    Stiffness6::from_fn(|i, j| r[i][j])
}

/// One grain in the identity orientation (Bunge 0, 0, 0): the polycrystal's tensor is the
/// single crystal's bit for bit, its one grain carries the cell's mean stress, and its
/// longitudinal modulus is C₁₁ of the single crystal.
#[test]
fn one_identity_grain_is_the_single_crystal() {
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("euler.txt"), "0 0 0\n").unwrap();
    let path = dir.path().join("model.toml");
    let grains = "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"euler.txt\"\n";
    std::fs::write(&path, cubic_model("", grains)).unwrap();
    let p = generated(800, 3);
    let r = study(&p, &Model::from_path(&path).unwrap(), &Default::default());
    assert_eq!(r.tensor_pa, r.single_crystal_tensor_pa);
    assert_eq!(r.grains.len(), 1);
    let g = &r.grains[0];
    assert_eq!(g.particles, 800);
    assert!(
        (g.mean_stress_pa - r.cell_mean_stress_pa).abs() <= 1e-12 * r.cell_mean_stress_pa.abs()
    );
    let e = r.single_crystal_tensor_pa[0][0];
    assert!(
        (g.longitudinal_modulus_pa - e).abs() <= 1e-12 * e,
        "{} vs {e}",
        g.longitudinal_modulus_pa
    );
    assert_eq!(g.bunge_deg, [0.0, 0.0, 0.0]);
    // The cell's mean stress along the load is the relaxed tensor's C₁₁·ε (local fields'
    // identity, docs/references.md "Local fields").
    let c11 = r.tensor_pa[0][0];
    assert!((r.cell_mean_stress_pa - c11 * r.strain).abs() <= 1e-8 * c11 * r.strain);
}

/// Isotropic grains: the polycrystal is the isotropic assembly exactly, and every estimate
/// of the single crystal lies within rounding of its own isotropic projection.
#[test]
fn isotropic_grains_change_nothing() {
    let p = generated(800, 5);
    let m = model(&isotropic_model("[grains]\ncount = 12\nseed = 2\n"));
    let r = study(&p, &m, &Default::default());
    assert_eq!(r.tensor_pa, r.single_crystal_tensor_pa);
    assert_eq!(
        r.anisotropy.to_bits(),
        r.single_crystal_anisotropy.to_bits()
    );
    let s = &r.single_crystal;
    for (lo, hi) in [
        (s.reuss_shear_pa, s.voigt_shear_pa),
        (s.hs_lower_shear_pa, s.hs_upper_shear_pa),
    ] {
        assert!(lo <= hi * (1.0 + 1e-12));
    }
}

/// Each grain's longitudinal modulus is C′₁₁ of the single crystal's relaxed tensor turned
/// into the grain as a whole (rotate(C, gᵀ), the tensor module's path), not the study's own
/// route of turning the direction; with grains of a strongly transversely isotropic crystal
/// (Šmilauer's scheme, C11/C33 = 2.4), those stiff along the load carry more stress:
/// Pearson's r over 20 grains > 0.6, where uncorrelated grains would give r of standard
/// deviation 1/√19 = 0.23; the convergence series takes
/// its grain counts; the report is finite JSON with the documented keys.
#[test]
fn grains_stiff_along_the_load_carry_more_stress() {
    let p = generated(4000, 7);
    let m = model(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
         C11 = 13.0e9\nC33 = 5.5e9\nC13 = 2.8e9\nC12 = 4.0e9\naxis = [0.0, 0.0, 1.0]\n\
         [geometry]\nconvention = \"modulus\"\n[grains]\ncount = 20\nseed = 4\n",
    );
    let opts = PolycrystalOptions {
        grain_counts: vec![1, 4],
        ..Default::default()
    };
    let r = study(&p, &m, &opts);
    let grains = Assembly::new(p.clone(), m.clone())
        .unwrap()
        .grains()
        .unwrap()
        .clone();
    let c = matrix(&r.single_crystal_tensor_pa);
    for row in &r.grains {
        let g = grains.orientation[row.grain as usize];
        let turned = rotate(&c, &g.transpose());
        let e = turned[(0, 0)];
        assert!(
            (row.longitudinal_modulus_pa - e).abs() <= 1e-9 * e,
            "grain {}: {} vs {e}",
            row.grain,
            row.longitudinal_modulus_pa
        );
    }
    assert!(
        r.stress_stiffness_correlation > 0.3,
        "{}",
        r.stress_stiffness_correlation
    );
    assert_eq!(
        r.series.iter().map(|s| s.grains).collect::<Vec<_>>(),
        [1, 4]
    );
    let json: serde_json::Value = serde_json::from_str(&r.to_json().unwrap()).unwrap();
    for key in [
        "tensor_pa",
        "single_crystal",
        "bulk_pa",
        "shear_pa",
        "shear_vs_self_consistent",
        "stress_stiffness_correlation",
        "grains",
        "series",
    ] {
        assert!(json.get(key).is_some(), "{key}");
    }
    assert_eq!(r.to_csv().lines().count(), r.grains.len() + 1);
}

/// A model without `[grains]` and bad options are refused by name.
#[test]
fn refusals_name_what_is_wrong() {
    let p = generated(300, 1);
    let e = run(
        &p,
        &model(&cubic_model("", "")),
        &Default::default(),
        OptionNames::Flags,
        &|_| {},
    )
    .unwrap_err();
    assert!(matches!(e, Error::Model(_)), "{e}");
    let m = model(&cubic_model("", "[grains]\ncount = 2\n"));
    for (opts, name) in [
        (
            PolycrystalOptions {
                strain: 0.5,
                ..Default::default()
            },
            "--strain",
        ),
        (
            PolycrystalOptions {
                load_axis: 3,
                ..Default::default()
            },
            "--load-axis",
        ),
        (
            PolycrystalOptions {
                grain_counts: vec![0],
                ..Default::default()
            },
            "--grain-counts",
        ),
    ] {
        let e = run(&p, &m, &opts, OptionNames::Flags, &|_| {}).unwrap_err();
        assert!(
            matches!(e, Error::Invalid(_)) && e.to_string().contains(name),
            "{e}"
        );
    }
}

/// `anisobond polycrystal` writes the library's report: its polycrystal.json equals the
/// study's JSON of the same packing file and model byte for byte, with the CSV and PNG.
#[test]
fn the_command_writes_the_librarys_report() {
    let dir = super::common::tmp();
    let p = generated(600, 9);
    let pack = dir.path().join("p.txt");
    write_packing(&pack, &p).unwrap();
    let text = cubic_model("", "[grains]\ncount = 5\nseed = 1\n");
    let mpath = dir.path().join("m.toml");
    std::fs::write(&mpath, &text).unwrap();
    let out = dir.path().join("out");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_anisobond"))
        .args(["polycrystal"])
        .arg(&pack)
        .arg("--model")
        .arg(&mpath)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let read = anisobond::packing::read_packing(&pack).unwrap();
    let r = study(
        &read,
        &Model::from_path(&mpath).unwrap(),
        &Default::default(),
    );
    assert_eq!(
        std::fs::read_to_string(out.join("polycrystal.json")).unwrap(),
        r.to_json().unwrap()
    );
    assert_eq!(
        std::fs::read_to_string(out.join("polycrystal_grains.csv")).unwrap(),
        r.to_csv()
    );
    assert!(out.join("polycrystal.png").exists());
    // An option out of range: refused, nothing written.
    let bad = dir.path().join("bad");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_anisobond"))
        .args(["polycrystal"])
        .arg(&pack)
        .arg("--model")
        .arg(&mpath)
        .args(["--load-axis", "w", "-o"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!status.status.success());
    assert!(String::from_utf8_lossy(&status.stderr).contains("--load-axis"));
    assert!(!bad.exists());
}
