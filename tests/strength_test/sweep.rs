//! The bedding sweep (`study::strength_sweep`, `anisobond strength-test --bedding-sweep`):
//! with the example transversely isotropic rock (a family of weak bedding planes), the UCS
//! at an intermediate angle lies below both ends (the planes slide there, not at β = 0 or
//! 90°); every angle's row is exactly a single lab run at that angle (the sweep equals its
//! parts); the command writes its three files and refuses a bad list by its flag.

use crate::common::{bin, tmp};
use anisobond::model::Model;
use anisobond::study::strength_sweep::{run, StrengthSweepOptions};
use anisobond::study::strength_test::{self, StrengthTestOptions, TestKind};
use std::path::PathBuf;

/// examples/transversely_isotropic_rock.toml.
fn rock_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/transversely_isotropic_rock.toml")
}

/// A small, fast lab: 1,000 generated spheres, a 10 R̄ prism (about 280 particles) and disc.
fn small_lab() -> StrengthTestOptions {
    StrengthTestOptions {
        model: Some(Model::from_path(&rock_path()).unwrap()),
        cell_particles: 1000,
        width_particles: 10.0,
        loading_rate: 1e-4,
        ..StrengthTestOptions::default()
    }
}

#[test]
fn ucs_of_the_bedded_rock_is_lowest_at_an_intermediate_angle_and_rows_are_single_runs() {
    let opts = StrengthSweepOptions {
        lab: small_lab(),
        angles_deg: vec![0.0, 45.0, 90.0],
    };
    let r = run(&opts, &|_| {}).unwrap();
    for row in &r.rows {
        println!(
            "β = {:>4}°: UCS {:.4e} Pa (×{:.3}, dropped {}), E {:?}, ν {:?}, Brazilian \
             {:.4e} Pa (×{:.3}); cracks UCS {:?}",
            row.bedding_deg,
            row.ucs_pa,
            row.ucs_ratio,
            row.ucs_peak_dropped,
            row.modulus_pa,
            row.poisson,
            row.brazilian_pa,
            row.brazilian_ratio,
            row.ucs_cracks
        );
    }
    let ucs: Vec<f64> = r.rows.iter().map(|x| x.ucs_pa).collect();
    assert!(r.rows.iter().all(|x| x.ucs_peak_dropped));
    assert!(ucs[1] < ucs[0] && ucs[1] < ucs[2], "{ucs:?}");
    // The stiffness turns with the bedding: E across the bedding (β = 0, C33-like) is below
    // E along it (β = 90°, C11-like).
    assert!(r.rows[0].modulus_pa.unwrap() < r.rows[2].modulus_pa.unwrap());
    // Ratios over the first angle's values.
    for x in &r.rows {
        assert_eq!(x.ucs_ratio, x.ucs_pa / r.rows[0].ucs_pa);
        assert_eq!(x.brazilian_ratio, x.brazilian_pa / r.rows[0].brazilian_pa);
    }
    // The sweep equals its parts: single lab runs at β = 0 and 90° give the same rows.
    for (k, beta) in [(0usize, 0.0), (2, 90.0)] {
        for test in [TestKind::Ucs, TestKind::Brazilian] {
            let single = strength_test::run(
                &StrengthTestOptions {
                    test,
                    bedding_deg: beta,
                    ..small_lab()
                },
                &|_| {},
            )
            .unwrap();
            let row = &r.rows[k];
            if test == TestKind::Ucs {
                assert_eq!(single.peak_stress_pa, row.ucs_pa, "UCS at {beta}");
                assert_eq!(single.modulus_pa, row.modulus_pa);
                assert_eq!(single.cracks, row.ucs_cracks);
            } else {
                assert_eq!(single.peak_stress_pa, row.brazilian_pa, "disc at {beta}");
                assert_eq!(single.cracks, row.brazilian_cracks);
            }
        }
    }
}

#[test]
fn the_sweep_command_writes_its_files_and_refuses_a_bad_list() {
    let dir = tmp();
    let out = dir.path().join("sweep");
    let o = bin()
        .args(["strength-test", "--bedding-sweep", "0:90:90", "--model"])
        .arg(rock_path())
        .args([
            "--cell-particles",
            "400",
            "--width-particles",
            "6",
            "--loading-rate",
            "1e-4",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("strength_sweep.json")).unwrap())
            .unwrap();
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["bedding_deg"].as_f64().unwrap(), 90.0);
    let csv = std::fs::read_to_string(out.join("strength_sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);
    // The CSV's UCS column is the JSON's.
    let ucs: f64 = csv
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(ucs, rows[1]["ucs_pa"].as_f64().unwrap());
    assert!(image::open(out.join("strength_sweep.png")).unwrap().width() > 100);
    for bad in [
        &["--bedding-sweep", "0:0:90"][..],
        &["--bedding-sweep", "0,x"][..],
    ] {
        let out = dir.path().join("bad");
        let o = bin()
            .arg("strength-test")
            .args(bad)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(!o.status.success());
        assert!(String::from_utf8_lossy(&o.stderr).contains("--bedding-sweep"));
        assert!(!out.exists());
    }
    // With --bedding-deg the sweep is refused by clap, naming both.
    let o = bin()
        .args([
            "strength-test",
            "--bedding-sweep",
            "0,90",
            "--bedding-deg",
            "30",
            "-o",
        ])
        .arg(dir.path().join("bad"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--bedding-deg"));
}
