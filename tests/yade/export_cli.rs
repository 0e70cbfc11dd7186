//! `anisobond export yade`: a bad packing or a bad model gives a clear error (file, line,
//! what was expected), a non-zero exit, and writes nothing into DIR; a good one writes
//! the five files, and `run.py` is valid Python that calls the embedded module.

use std::path::Path;
use std::process::Command;

const MODEL: &str = r#"
[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "isotropic"
normal = 1.0e13
shear = 3.0e12
"#;

fn write(p: &Path, s: &str) {
    std::fs::write(p, s).unwrap();
}

/// A small periodic simple-cubic packing: 4×4×4 spheres of radius 0.5 mm, spacing 1 mm.
fn cubic_packing() -> String {
    let mut s = String::from("# periodic 0.004 0.004 0.004\n");
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                s.push_str(&format!(
                    "{} {} {} 0.0005\n",
                    0.0005 + i as f64 * 1e-3,
                    0.0005 + j as f64 * 1e-3,
                    0.0005 + k as f64 * 1e-3
                ));
            }
        }
    }
    s
}

fn export(packing: &Path, model: &Path, dir: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_anisobond"))
        .args(["export", "yade"])
        .arg(packing)
        .arg("--model")
        .arg(model)
        .arg("-o")
        .arg(dir)
        .output()
        .unwrap()
}

fn entries(dir: &Path) -> Vec<String> {
    match std::fs::read_dir(dir) {
        Ok(rd) => {
            let mut v: Vec<String> = rd
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        }
        Err(_) => Vec::new(),
    }
}

#[test]
fn bad_inputs_fail_cleanly_and_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let good_packing = tmp.path().join("good.txt");
    let good_model = tmp.path().join("model.toml");
    write(&good_packing, &cubic_packing());
    write(&good_model, MODEL);

    let cases: Vec<(&str, String, String, &str)> = vec![
        (
            "packing line with three numbers",
            cubic_packing().replacen("0.0005 0.0005 0.0005 0.0005", "0.0005 0.0005 0.0005", 1),
            MODEL.to_string(),
            "bad.txt:2:",
        ),
        (
            "negative radius",
            cubic_packing() + "0.001 0.001 0.001 -0.5\n",
            MODEL.to_string(),
            "radius must be > 0",
        ),
        (
            "non-periodic packing",
            cubic_packing().replacen("# periodic 0.004 0.004 0.004\n", "", 1),
            MODEL.to_string(),
            "not periodic",
        ),
        (
            "model with an unknown key",
            cubic_packing(),
            MODEL.replace("shear = 3.0e12", "shear = 3.0e12\nsheer = 1"),
            "bad.toml",
        ),
        (
            "model with a negative bonding value",
            cubic_packing(),
            MODEL.replace("value = 0.17", "value = -1"),
            "bad.toml",
        ),
        (
            "model that bonds nothing",
            cubic_packing(),
            MODEL.replace(
                "rule = \"gap\"\nvalue = 0.17",
                "rule = \"factor\"\nvalue = 0.5",
            ),
            "bonds no pair",
        ),
    ];
    for (what, packing, model, expect) in cases {
        let p = tmp.path().join("bad.txt");
        let m = tmp.path().join("bad.toml");
        write(&p, &packing);
        write(&m, &model);
        let dir = tmp.path().join("out-fresh");
        let out = export(&p, &m, &dir);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{what}: exit status 0");
        assert!(
            stderr.contains("error:"),
            "{what}: no error message: {stderr}"
        );
        assert!(
            stderr.contains(expect),
            "{what}: message lacks `{expect}`: {stderr}"
        );
        assert!(
            entries(&dir).is_empty(),
            "{what}: files written: {:?}",
            entries(&dir)
        );
        eprintln!("{what}: {}", stderr.trim());

        // A previous complete export is left exactly as it was.
        let prev = tmp.path().join("out-prev");
        let ok = export(&good_packing, &good_model, &prev);
        assert!(
            ok.status.success(),
            "{}",
            String::from_utf8_lossy(&ok.stderr)
        );
        let before: Vec<Vec<u8>> = entries(&prev)
            .iter()
            .map(|f| std::fs::read(prev.join(f)).unwrap())
            .collect();
        let out = export(&p, &m, &prev);
        assert!(!out.status.success());
        let after: Vec<Vec<u8>> = entries(&prev)
            .iter()
            .map(|f| std::fs::read(prev.join(f)).unwrap())
            .collect();
        assert_eq!(
            before, after,
            "{what}: a failed export changed the previous files"
        );
    }
}

#[test]
fn good_export_writes_the_run_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("p.txt");
    let m = tmp.path().join("m.toml");
    write(&p, &cubic_packing());
    write(&m, MODEL);
    let dir = tmp.path().join("yade");
    let out = export(&p, &m, &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        entries(&dir),
        [
            "anisobond_yade.py",
            "bonds.csv",
            "model.toml",
            "packing.txt",
            "run.py"
        ]
    );
    // Simple cubic, spacing 2R, gap 0 ≤ 0.17 R̄: 3 bonds per sphere, 192 bonds.
    let bonds = std::fs::read_to_string(dir.join("bonds.csv")).unwrap();
    assert_eq!(bonds.lines().count(), 1 + 3 * 64);
    let module = std::fs::read_to_string(dir.join("anisobond_yade.py")).unwrap();
    assert_eq!(module, include_str!("../../yade-scripts/anisobond_yade.py"));
    let run = std::fs::read_to_string(dir.join("run.py")).unwrap();
    assert!(run.contains("anisobond_yade.main(DEFAULTS + sys.argv[1:])"));
    // run.py and the module are valid Python (when a python3 is around to say so).
    if let Ok(o) = Command::new("python3")
        .arg("-c")
        .arg("import ast,sys; [ast.parse(open(f).read(), f) for f in sys.argv[1:]]")
        .arg(dir.join("run.py"))
        .arg(dir.join("anisobond_yade.py"))
        .output()
    {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}
