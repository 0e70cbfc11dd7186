//! `anisobond cavity` end to end: the files it writes against the library's own solve of
//! the same packing, and its refusals (nothing written).

use crate::common::{bin, entries, fails, packing, succeeds, tmp, write};
use anisobond::cavity::{lame_wall_displacement, Cavity, CavityGeometry};
use anisobond::prelude::*;

const ISOTROPIC: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\nnormal = 1.0e13\nshear = 0.4e13\n";

#[test]
fn cavity_command_writes_the_library_solution() {
    let dir = tmp();
    let pk = packing(dir.path(), 600);
    let model = write(dir.path(), "iso.toml", ISOTROPIC);
    let out = dir.path().join("out");
    let text = succeeds(
        bin()
            .arg("cavity")
            .arg(&pk)
            .arg("--model")
            .arg(&model)
            .args(["--hole-radius", "6e-3", "--outer-radius", "14e-3", "-o"])
            .arg(&out),
    );
    assert!(text.contains("Lamé"), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cavity.json")).unwrap()).unwrap();
    // the library on the same files
    let src = Assembly::from_files(&pk, &model).unwrap();
    let r = src.packing.mean_radius();
    let cav = Cavity::new(
        &src,
        CavityGeometry {
            inner_radius: 6e-3,
            outer_radius: 14e-3,
            clamp_width: src.bonds.length.iter().copied().fold(0.0, f64::max),
            ray_spacing: 0.25 * r,
        },
    )
    .unwrap();
    let s = cav.solve_static(1e6).unwrap();
    let u = json["wall_displacement_m"].as_f64().unwrap();
    assert!((u - s.wall_displacement).abs() < 1e-12 * u.abs());
    let lame = json["lame_wall_displacement_m"].as_f64().unwrap();
    let (lambda, mu) = (
        json["lame_lambda_pa"].as_f64().unwrap(),
        json["lame_mu_pa"].as_f64().unwrap(),
    );
    let again = lame_wall_displacement(1e6, 6e-3, 14e-3, lambda, mu);
    assert!((lame - again).abs() < 1e-12 * lame);
    assert_eq!(json["christoffel_in_plane"].as_array().unwrap().len(), 12);
    // the continuum of the full relaxed tensor: near Lamé for these nearly isotropic bonds,
    // its ratio the DEM's, four wall bins
    let c = &json["continuum"];
    let fe = c["wall_displacement_m"].as_f64().unwrap();
    assert!(
        (fe / lame - 1.0).abs() < 0.03,
        "continuum {fe:e}, Lamé {lame:e}"
    );
    assert!((c["dem_over_continuum"].as_f64().unwrap() * fe / u - 1.0).abs() < 1e-12);
    assert_eq!(c["wall_bins_20deg"].as_array().unwrap().len(), 4);
    let csv = std::fs::read_to_string(out.join("particles.csv")).unwrap();
    assert!(csv.starts_with("id,x [m],y [m],z [m],radius [m]"));
    assert_eq!(csv.lines().count(), cav.cut.packing.len() + 1);
    assert!(out.join("cavity.vtu").exists());
    // the wave run (a hole wide enough for a front): three fronts with finite speeds, a 2-step VTK series and PNG snapshots
    let out = dir.path().join("waves");
    succeeds(
        bin()
            .arg("cavity")
            .arg(&pk)
            .arg("--model")
            .arg(&model)
            .args(["--hole-radius", "8e-3", "--outer-radius", "40e-3"])
            .args(["--waves", "--snapshots", "2", "-o"])
            .arg(&out),
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cavity.json")).unwrap()).unwrap();
    let fronts = json["waves"]["fronts"].as_array().unwrap();
    assert_eq!(fronts.len(), 3);
    for f in fronts {
        let v = f["front_speed_m_per_s"].as_f64().unwrap();
        let c = f["christoffel_m_per_s"].as_f64().unwrap();
        assert!(v > 0.5 * c && v < 2.0 * c, "{f}");
    }
    for name in [
        "cavity.pvd",
        "cavity_0000.vtu",
        "cavity_0001.vtu",
        "snapshot_0001.png",
    ] {
        assert!(out.join("waves").join(name).exists(), "{name}");
    }
    let pvd = std::fs::read_to_string(out.join("waves/cavity.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 2);
}

#[test]
fn cavity_command_refuses_bad_options_and_writes_nothing() {
    let dir = tmp();
    let pk = packing(dir.path(), 300);
    let model = write(dir.path(), "iso.toml", ISOTROPIC);
    let out = dir.path().join("out");
    let before = entries(dir.path());
    for (args, says) in [
        (vec!["--pressure", "nan"], "pressure"),
        (vec!["--hole-radius=-1"], "--hole-radius"),
        (vec!["--density", "0"], "--density"),
        (
            vec!["--hole-radius", "5e-3", "--outer-radius", "4e-3"],
            "hole radius",
        ),
    ] {
        let e = fails(
            bin()
                .arg("cavity")
                .arg(&pk)
                .arg("--model")
                .arg(&model)
                .args(&args)
                .arg("-o")
                .arg(&out),
        );
        assert!(e.contains(says), "{args:?}: {e}");
        assert_eq!(entries(dir.path()), before);
    }
}
