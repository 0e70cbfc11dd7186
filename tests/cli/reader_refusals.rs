//! Issue 17 through the binary: bad packings, models and targets exit non-zero with the
//! file, line and expectation, and write nothing; BOM / CR-only inputs and `80 GPa` work.

use crate::common::{bin, write, CUBIC_MODEL as CUBIC};
use std::path::Path;
use std::process::Output;

/// Expect failure without a panic and without `output`; return stderr.
fn refused(out: Output, output: &Path) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "expected failure; stderr: {err}");
    assert!(!output.exists(), "{} was written", output.display());
    assert!(!err.contains("panicked"), "panic: {err}");
    err
}

const CROSS: &str = "[bonding]\nrule = \"factor\"\nvalue = 1.8\n[scheme]\n\
kind = \"cross-anisotropic\"\nC11 = 130e6\nC33 = 55e6\nC13 = 28e6\nC12 = 40e6\n";

fn tensor(packing: &Path, model: &Path, out: &Path) -> Output {
    bin()
        .arg("tensor")
        .arg(packing)
        .arg("--model")
        .arg(model)
        .args(["--method", "voigt", "-o"])
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn bad_packings_are_refused_with_file_and_line() {
    let d = tempfile::tempdir().unwrap();
    let m = write(d.path(), "m.toml", CUBIC);
    let out = d.path().join("t.json");
    let zero_atoms =
        "LIGGGHTS data\n\n0 atoms\n1 atom types\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n";
    for (name, text, needle) in [
        ("empty.txt", "", "empty.txt: no particles: expected lines `x y z r`"),
        ("comments.txt", "# nothing here\n", "comments.txt: no particles"),
        ("zero.data", zero_atoms, "zero.data: no particles: line 3 declares `0 atoms`"),
        (
            "huge.txt",
            "# periodic 1e300 1e300 1e300\n1 1 1 0.5\n",
            "huge.txt:1: the cell volume",
        ),
        (
            "image.data",
            "LIGGGHTS data\n\n1 atoms\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n\nAtoms # granular\n\n1 1 0.1 2500 0.5 0.5 0.5 0 0.5 0\n",
            "image.data:11: image flag iy (column 9) must be an integer",
        ),
        (
            "density.data",
            "LIGGGHTS data\n\n1 atoms\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n\nAtoms # granular\n\n1 1 0.1 -2500 0.5 0.5 0.5\n",
            "density.data:11: density (column 4) must be > 0",
        ),
        ("radius.txt", "0 0 0 1\n5 5 5 1e200\n", "radius.txt:2: the sphere volume"),
    ] {
        let p = write(d.path(), name, text);
        let err = refused(tensor(&p, &m, &out), &out);
        assert!(err.contains(needle), "{name}: {err}");
    }
}

#[test]
fn bom_and_cr_only_packings_and_models_work() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("p.txt");
    let o = bin()
        .args(["pack", "--particles", "300", "--seed", "4", "-o"])
        .arg(&p)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&p).unwrap();
    let mac = write(
        d.path(),
        "mac.txt",
        &format!("\u{feff}{}", text.replace('\n', "\r")),
    );
    let m = write(
        d.path(),
        "m.toml",
        &format!("\u{feff}{}", CUBIC.replace('\n', "\r")),
    );
    let (a, b) = (d.path().join("a.json"), d.path().join("b.json"));
    let plain = write(d.path(), "plain.toml", CUBIC);
    for (packing, model, out) in [(&p, &plain, &a), (&mac, &m, &b)] {
        let o = tensor(packing, model, out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn foreign_scheme_keys_are_refused_by_name_and_line() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("cal.toml");
    let iso = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\nnormal = 1e13\nshear = 3e12\neuler_zyz_deg = [0.0, 10.0, 0.0]\n";
    let m = write(d.path(), "iso.toml", iso);
    let o = bin()
        .args(["calibrate", "--model"])
        .arg(&m)
        .args(["--target", "C12/C11=0.2,C44/C11=0.35", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let err = refused(o, &out);
    assert!(
        err.contains("iso.toml:8: unknown field `euler_zyz_deg`"),
        "{err}"
    );
}

#[test]
fn calibrate_refuses_inadmissible_targets_before_writing() {
    let d = tempfile::tempdir().unwrap();
    let cross = write(d.path(), "cross.toml", CROSS);
    let cubic = write(d.path(), "cubic.toml", CUBIC);
    let out = d.path().join("cal.toml");
    for (model, target, needle) in [
        (
            &cross,
            "C11=40e9,C33=30e9,C13=40e9,C12=10e9",
            "(C11 + C12)·C33 = 1.5e21 must exceed 2·C13² = 3.2e21",
        ),
        (
            &cross,
            "C11=40e9,C33=-30e9,C13=1e9,C12=10e9",
            "C33 = -3e10 must be > 0",
        ),
        (
            &cross,
            "C11=0,C33=30e9,C13=1e9,C12=0",
            "C11 = 0e0 must be > 0",
        ),
        // Positive definite, but the elliptic scheme would need a negative lattice modulus.
        (
            &cross,
            "C11=130e6,C33=55e6,C13=50e6,C12=40e6",
            "needs a negative lattice modulus E_T^b'",
        ),
        (
            &cubic,
            "C11=100e9,C12=120e9,C44=40e9",
            "C12/C11 = 1.2 must be < 1",
        ),
        (
            &cubic,
            "C11=100e9,C12=30e9,C44=0",
            "C44/C11 = 0 must be > 0",
        ),
        (&cubic, "C11=1e308 GPa,C12=1,C44=1", "not finite"),
    ] {
        let o = bin()
            .args(["calibrate", "--model"])
            .arg(model)
            .args(["--target", target, "-o"])
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        let err = refused(o, &out);
        assert!(err.contains(needle), "{target}: {err}");
        assert!(!stdout.contains("calibrated"), "{stdout}");
    }
    // A space before the unit is fine.
    let o = bin()
        .args(["calibrate", "--model"])
        .arg(&cross)
        .args([
            "--target",
            "C11=130 MPa,C33=55 MPa,C13=28 MPa,C12=40 MPa",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.exists());
}

/// A bad key or value in a model file, given to `tensor`: the refusal names the file and the
/// line the bad text is on (counted here from the text), in TOML and JSON, and writes nothing.
#[test]
fn bad_model_keys_name_the_file_and_the_line() {
    let d = tempfile::tempdir().unwrap();
    let packing = crate::common::packing(d.path(), 100);
    let out = d.path().join("t.json");
    let json = "{\"scheme\": {\"kind\": \"isotropic\", \"normal\": 1e9, \"shear\": 1e8},\n\"geometry\": {\"convention\": \"spring\",\n\"moments\": 1}}";
    for (name, text, bad, expected) in [
        (
            "a.toml",
            CUBIC.replace("a_s = 10.0", "a_z = 10.0"),
            "a_z",
            "unknown field `a_z`",
        ),
        (
            "b.toml",
            CUBIC.replace("a_s = 10.0", "a_s = [10.0]"),
            "a_s",
            "`a_s`: invalid type: sequence, expected a number",
        ),
        (
            "c.toml",
            CUBIC.replace("zener-above-1", "zener"),
            "model",
            "`model`: unknown variant `zener`",
        ),
        (
            "d.toml",
            format!("{CUBIC}[geometry]\nconvention = true\n"),
            "convention",
            "`convention`: expected one of `area`",
        ),
        (
            "g.toml",
            CUBIC.replace("kind = \"cubic\"", "kind = 3"),
            "kind",
            "`kind`: invalid type: integer `3`, expected a string",
        ),
        (
            "h.toml",
            CUBIC.replace("a_s = 10.0", "a_s = 10.0\neuler_zyz_deg = [1, \"a\", 3]"),
            "euler",
            "`euler_zyz_deg`: invalid type: string \"a\", expected a number",
        ),
        (
            "e.json",
            CUBIC_JSON.replace("\"a_n\"", "\"a_m\""),
            "a_m",
            "unknown field `a_m`",
        ),
        ("f.json", json.to_string(), "moments", "`moments`: expected"),
    ] {
        let line = 1 + text.lines().position(|l| l.contains(bad)).unwrap();
        let m = write(d.path(), name, &text);
        let err = refused(tensor(&packing, &m, &out), &out);
        let at = format!("{}:{line}: ", m.display());
        assert!(
            err.contains(&format!("{at}{expected}")),
            "{name}: want `{at}{expected}` in {err}"
        );
    }
}

/// The demo's cubic model as JSON, a key on each line.
const CUBIC_JSON: &str = "{\"bonding\": {\"rule\": \"gap\", \"value\": 0.17},\n\"scheme\": {\"kind\": \"cubic\",\n\"model\": \"zener-above-1\",\n\"a_n\": 4.31,\n\"a_s\": 10.0,\n\"normal\": 1e13,\n\"shear\": 3.55e12}}\n";
