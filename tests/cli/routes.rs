//! `anisobond pack` with --route, --preset and --void-fraction, end to end.

use anisobond::packing::read_packing;
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_anisobond"))
}

/// `pack ARGS --quiet -o out` that must fail without writing `out`; its standard error.
fn failed_pack(args: &[&str], out: &Path) -> String {
    let run = bin()
        .arg("pack")
        .args(args)
        .args(["--quiet", "-o"])
        .arg(out)
        .output()
        .unwrap();
    assert!(!run.status.success(), "{args:?} succeeded");
    assert!(!out.exists(), "{args:?} wrote a file");
    String::from_utf8_lossy(&run.stderr).into_owned()
}

/// Σ(4/3)πR³ / V computed from the file's radii and cell.
fn solid_fraction_of(path: &Path) -> (usize, f64) {
    let p = read_packing(path).unwrap();
    let l = p.cell.expect("periodic").lengths;
    let vs: f64 = p.radii.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
    (p.len(), vs / (l.x * l.y * l.z))
}

#[test]
fn void_fraction_is_one_minus_solid_fraction() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.txt");
    let run = bin()
        .args([
            "pack",
            "--particles",
            "300",
            "--void-fraction",
            "0.45",
            "--quiet",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (n, phi) = solid_fraction_of(&out);
    assert_eq!(n, 300);
    assert!((phi - 0.55).abs() < 1e-6, "φ = {phi}");
}

#[test]
fn kumar_preset_with_a_route_reaches_its_density() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("k.txt");
    let run = bin()
        .args([
            "pack",
            "--preset",
            "kumar-2016",
            "--route",
            "weakly-jammed",
            "--particles",
            "600",
            "--quiet",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (n, phi) = solid_fraction_of(&out);
    assert_eq!(n, 600);
    // Kumar 2016 Sec. 3: D = 0.65 after the last affine step.
    assert!((phi - 0.65).abs() < 1e-6, "φ = {phi}");
    assert!(stdout.contains("weakly-jammed"), "{stdout}");
    assert!(stdout.contains("1.075"), "{stdout}");
}

#[test]
fn bad_fractions_fail_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bad.txt");
    for args in [
        vec!["--void-fraction", "0.4", "--solid-fraction", "0.6"],
        vec!["--void-fraction", "1.2"],
        vec!["--void-fraction", "0.2"], // φ = 0.8: beyond jamming for the random route
        vec!["--route", "jammed", "--particles", "5"],
    ] {
        let err = failed_pack(&args, &out);
        assert!(
            err.contains("fraction") || err.contains("particles"),
            "{args:?}: {err}"
        );
    }
}

/// `--jam-balance`: a malformed rule or one given to another route fails with a message
/// naming the option and writes nothing.
#[test]
fn bad_jam_balance_fails_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bad.txt");
    for (args, expect) in [
        (
            vec!["--route", "jammed", "--jam-balance", "median:1e-3"],
            "`mean:R` or `max:R`",
        ),
        (
            vec!["--route", "jammed", "--jam-balance", "max:lots"],
            "expected a ratio",
        ),
        (vec!["--route", "jammed", "--jam-balance", "0"], "(0, 0.1]"),
        (
            vec!["--route", "random", "--jam-balance", "1e-3"],
            "jammed route only",
        ),
    ] {
        let err = failed_pack(&[&args[..], &["--particles", "500"]].concat(), &out);
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(err.contains("jam-balance"), "{args:?}: {err}");
    }
}

/// `--jam-balance max:1e-3` (Kumar's rule) and the default both reach their bound, and the
/// summary line states the net forces the state was left with.
#[test]
fn jam_balance_rules_are_met_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    for (rule, mean_bound, largest_bound) in [(None, 2e-3, 1.0), (Some("max:1e-3"), 1.0, 1e-3)] {
        let out = dir.path().join("jam.txt");
        let mut cmd = bin();
        cmd.args([
            "pack",
            "--route",
            "jammed",
            "--particles",
            "600",
            "--seed",
            "3",
        ]);
        if let Some(rule) = rule {
            cmd.args(["--jam-balance", rule]);
        }
        let run = cmd.args(["--quiet", "-o"]).arg(&out).output().unwrap();
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(run.status.success(), "{rule:?}: {stdout}");
        // "net forces: mean 1.9e-3 × mean contact force, largest 4.0e-3 × largest …"
        let number_after = |key: &str| -> f64 {
            let at = stdout
                .find(key)
                .unwrap_or_else(|| panic!("{key} in {stdout}"))
                + key.len();
            stdout[at..]
                .split_whitespace()
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        let mean = number_after("net forces: mean ");
        let largest = number_after(", largest ");
        // One printed decimal: allow its rounding.
        assert!(mean <= mean_bound * 1.05, "{rule:?}: mean {mean}");
        assert!(
            largest <= largest_bound * 1.05,
            "{rule:?}: largest {largest}"
        );
        assert!(mean > 0.0 && largest > 0.0, "{stdout}");
    }
}
