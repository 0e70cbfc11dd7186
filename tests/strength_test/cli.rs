//! `anisobond strength-test` end to end: the four files, the Brazilian disc's σ_t =
//! 2P/(πDt) recomputed from its own curve, refusals naming the flag and leaving nothing.

use crate::common::{bin, tmp};
use std::path::Path;
use std::process::Output;

/// `anisobond strength-test ARGS -o OUT`.
fn lab(args: &[&str], out: &Path) -> Output {
    bin()
        .arg("strength-test")
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

/// A small, quick run.
const SMALL: [&str; 8] = [
    "--cell-particles",
    "400",
    "--width-particles",
    "6",
    "--max-strain",
    "2e-3",
    "--loading-rate",
    "1e-4",
];

#[test]
fn strength_test_writes_json_csv_png_and_vtk() {
    let dir = tmp();
    let out = dir.path().join("lab");
    let o = lab(&SMALL, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "strength_test.json",
        "strength_test.csv",
        "strength_test.png",
        "strength_test_bonds.vtu",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("strength_test.json")).unwrap())
            .unwrap();
    let csv = std::fs::read_to_string(out.join("strength_test.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(header.contains("stress [Pa]") && header.contains("strain"));
    // max_stress_pa is the largest stress of the CSV's curve; peak_stress_pa its first
    // peak, recomputed here by brute force: the largest stress before the first row with
    // broken bonds whose stress is below 0.95 × the largest stress of the rows up to it.
    let cols: Vec<&str> = header.split(',').collect();
    let at = |name: &str| cols.iter().position(|h| *h == name).unwrap();
    let (sc, bc) = (at("stress [Pa]"), at("broken_bonds"));
    let rows: Vec<(f64, usize)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (v[sc].parse().unwrap(), v[bc].parse().unwrap())
        })
        .collect();
    let largest = |r: &[(f64, usize)]| r.iter().map(|x| x.0).fold(f64::NEG_INFINITY, f64::max);
    let drop_row =
        (0..rows.len()).find(|&k| rows[k].1 > 0 && rows[k].0 < 0.95 * largest(&rows[..=k]));
    let first = largest(&rows[..drop_row.unwrap_or(rows.len())]);
    assert_eq!(json["max_stress_pa"].as_f64().unwrap(), largest(&rows));
    assert_eq!(json["peak_stress_pa"].as_f64().unwrap(), first);
    assert_eq!(json["peak_dropped"].as_bool().unwrap(), drop_row.is_some());
    assert_eq!(json["peak_drop"].as_f64().unwrap(), 0.05);
    let vtu = std::fs::read_to_string(out.join("strength_test_bonds.vtu")).unwrap();
    for field in ["\"state\"", "\"break_time\"", "\"mode\""] {
        assert!(vtu.contains(field), "{field}");
    }
    let png = image::open(out.join("strength_test.png")).unwrap();
    assert!(png.width() > 100);
}

#[test]
fn brazilian_stress_is_two_p_over_pi_d_t() {
    let dir = tmp();
    let out = dir.path().join("disc");
    let o = lab(&[&["--test", "brazilian"], &SMALL[..]].concat(), &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("strength_test.json")).unwrap())
            .unwrap();
    let (d, t) = (
        json["length_m"].as_f64().unwrap(),
        json["thickness_m"].as_f64().unwrap(),
    );
    assert!(json["modulus_pa"].is_null() && json["area_m2"].is_null());
    let csv = std::fs::read_to_string(out.join("strength_test.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (fs, ss) = (at("force [N]"), at("stress [Pa]"));
    let mut rows = 0;
    for l in csv.lines().skip(1) {
        let v: Vec<f64> = l
            .split(',')
            .map(|x| x.parse().unwrap_or(f64::NAN))
            .collect();
        let expected = 2.0 * v[fs] / (std::f64::consts::PI * d * t);
        assert!((v[ss] - expected).abs() <= 1e-12 * expected.abs().max(1e-300));
        rows += 1;
    }
    assert!(rows > 10);
    assert!(json["peak_stress_pa"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_options_are_refused_naming_the_flag_and_leave_nothing() {
    let dir = tmp();
    for (args, flag) in [
        (&["--stop-fraction", "1.5"][..], "--stop-fraction"),
        (&["--loading-rate", "0"][..], "--loading-rate"),
        (&["--max-strain", "0.7"][..], "--max-strain"),
        (&["--width-particles", "nan"][..], "--width-particles"),
        (&["--local-damping", "1"][..], "--local-damping"),
        (&["--peak-drop", "0.6"][..], "--peak-drop"),
        (&["--peak-drop", "0"][..], "--peak-drop"),
        (&["--end-layer", "30"][..], "--end-layer"),
        (&["--points", "3"][..], "--points"),
    ] {
        let out = dir.path().join("bad");
        let o = lab(args, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} accepted");
        assert!(err.contains(flag), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
    // A model file that does not exist: named, nothing written.
    let out = dir.path().join("bad");
    let o = lab(&["--model", "/nonexistent/model.toml"], &out);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/model.toml"));
    assert!(!out.exists());
}
