//! Issue 29 (hostile input) for the cavity: sizes, ray counts, step counts and snapshot
//! counts derived from float options are estimated and refused before anything is
//! allocated (CLI: naming the options, exit non-zero, nothing left behind; library: the
//! same refusals for Python's `Assembly.cavity`), and a snapshot count is honoured exactly.

use crate::common::{bin, entries, fails, packing, tmp, write};
use crate::lame::{geometry, isotropic_model, source};
use anisobond::cavity::WaveOptions;
use anisobond::cavity::{Cavity, CavityGeometry};
use anisobond::dem::LawKind;
use std::time::{Duration, Instant};

const ISOTROPIC: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\nnormal = 1.0e13\nshear = 0.4e13\n";

/// A4, A5, A6, A11 end to end: each case fails within seconds (the reports: SIGABRT after
/// 30 s with a staging folder left, a capacity-overflow panic, runs that never end, 1e8
/// snapshots silently becoming 100), names its options, and leaves the folder as it was.
#[test]
fn cavity_refuses_absurd_sizes_without_output() {
    let dir = tmp();
    let pk = packing(dir.path(), 300);
    let model = write(dir.path(), "iso.toml", ISOTROPIC);
    let out = dir.path().join("out");
    let before = entries(dir.path());
    for (args, says) in [
        (
            vec!["--outer-radius", "1"],
            vec!["--outer-radius", "GiB of memory"],
        ),
        (
            vec!["--clamp-width", "1"],
            vec!["--clamp-width", "GiB of memory"],
        ),
        (
            vec!["--ray-spacing", "1e-12"],
            vec!["--ray-spacing", "ray tests, beyond the limit of 1e10"],
        ),
        (
            vec!["--hole-radius", "5e-3", "--outer-radius", "5.00001e-3"],
            vec!["--outer-radius", "too close to 1"],
        ),
        (
            vec!["--waves", "--ramp-time", "1e300"],
            vec!["--ramp-time", "beyond the limit of 1e12"],
        ),
        (
            vec!["--waves", "--snapshots", "100000000"],
            vec![
                "--snapshots",
                "100000000 snapshots asked",
                "at most one snapshot per step",
            ],
        ),
    ] {
        let t = Instant::now();
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
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{args:?}: {:?}",
            t.elapsed()
        );
        for s in says {
            assert!(e.contains(s), "{args:?}: {e}");
        }
        assert_eq!(entries(dir.path()), before, "{args:?}");
    }
}

/// The library's estimate, which `Cavity::new` (and so Python's `Assembly.cavity`) checks
/// before cutting: the expected sphere count n·π((b + w)² − a²)·L_z/V against the slab
/// actually cut (within 5 %), and a geometry of `--outer-radius 1` refused by `Cavity::new`
/// itself as [`anisobond::Error::Invalid`].
#[test]
fn the_size_estimate_matches_the_cut_and_refuses_huge_slabs() {
    let src = source(1000, 7, isotropic_model());
    let g = geometry(&src, 10.0, 24.0);
    let size = g.check(&src).unwrap();
    let cav = Cavity::new(&src, g).unwrap();
    let cut = cav.cut.packing.len() as f64;
    assert!(
        (size.spheres / cut - 1.0).abs() < 0.05,
        "estimate {} spheres, cut {cut}",
        size.spheres
    );
    let huge = CavityGeometry {
        outer_radius: 1.0,
        ..g
    };
    let t = Instant::now();
    let err = Cavity::new(&src, huge).err().expect("refused");
    assert!(matches!(err, anisobond::Error::Invalid(_)), "{err}");
    assert!(err.to_string().contains("spheres"), "{err}");
    assert!(t.elapsed() < Duration::from_secs(5));
}

/// A11 in the library: more snapshots than time steps, and runs beyond the step limit, are
/// refused by `check_waves` (which `run_waves` calls first); up to one per step is accepted.
#[test]
fn wave_options_are_checked_against_the_steps() {
    let src = source(1000, 7, isotropic_model());
    let r = src.packing.mean_radius();
    let cav = Cavity::new(&src, geometry(&src, 8.0, 20.0)).unwrap();
    let opts = |snapshots: usize, duration: f64| WaveOptions {
        pressure: 1e6,
        ramp_time: 0.5 * duration,
        duration,
        material_density: 2600.0,
        law: LawKind::Yade,
        directions: vec![0.0],
        probe_radii: vec![10.0 * r, 16.0 * r],
        probe_half_angle: 15f64.to_radians(),
        snapshots,
    };
    let (dt, _) = cav.check_waves(&opts(0, 1.0)).unwrap();
    let (_, steps) = cav.check_waves(&opts(3, 9.5 * dt)).unwrap();
    assert_eq!(steps, 10);
    assert!(cav.check_waves(&opts(10, 9.5 * dt)).is_ok());
    for err in [
        cav.check_waves(&opts(11, 9.5 * dt)).unwrap_err(),
        cav.run_waves(&opts(11, 9.5 * dt)).expect_err("refused"),
    ] {
        assert!(matches!(err, anisobond::Error::Invalid(_)), "{err}");
        assert!(err.to_string().contains("11 snapshots asked"), "{err}");
    }
    for d in [1e300, f64::INFINITY] {
        let err = cav.check_waves(&opts(3, d)).unwrap_err();
        assert!(matches!(err, anisobond::Error::Invalid(_)), "{err}");
    }
    let err = cav.check_waves(&opts(3, 1e300)).unwrap_err();
    assert!(
        err.to_string().contains("beyond the limit of 1e12"),
        "{err}"
    );
}

/// A11 end to end: `--snapshots 25` writes exactly 25 VTK files and PNGs, the k-th at step
/// ⌊k·steps/25⌋ (k = 1…25) of the run's own step count and time step in cavity.json (before,
/// one every ⌊steps/25⌋ steps: 30 snapshots for this run's 121 steps).
#[test]
fn cavity_waves_write_exactly_the_snapshots_asked() {
    let dir = tmp();
    let pk = packing(dir.path(), 600);
    let model = write(dir.path(), "iso.toml", ISOTROPIC);
    let out = dir.path().join("waves");
    crate::common::succeeds(
        bin()
            .arg("cavity")
            .arg(&pk)
            .arg("--model")
            .arg(&model)
            .args(["--hole-radius", "8e-3", "--outer-radius", "40e-3"])
            .args(["--waves", "--snapshots", "25", "-o"])
            .arg(&out),
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cavity.json")).unwrap()).unwrap();
    let w = &json["waves"];
    let steps = w["steps"].as_u64().unwrap() as usize;
    let dt = w["time_step_s"].as_f64().unwrap();
    let times = w["snapshot_times_s"].as_array().unwrap();
    assert_eq!(times.len(), 25);
    for (j, t) in times.iter().enumerate() {
        let after = (j + 1) * steps / 25;
        let t = t.as_f64().unwrap();
        assert!(
            (t / (after as f64 * dt) - 1.0).abs() < 1e-9,
            "snapshot {j}: {t:e} s, expected step {after} of {steps}"
        );
    }
    let pvd = std::fs::read_to_string(out.join("waves/cavity.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 25);
    for k in 0..25 {
        assert!(out.join(format!("waves/cavity_{k:04}.vtu")).exists());
        assert!(out.join(format!("waves/snapshot_{k:04}.png")).exists());
    }
    assert!(!out.join("waves/cavity_0025.vtu").exists());
}
