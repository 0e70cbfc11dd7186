//! The `anisobond` command end to end: outputs in the SPEC forms, and every bad input a
//! clear error (file, line, what was expected), a non-zero exit, and no output file.

use crate::common::{bin, on_model, packing, tmp, write, CUBIC_MODEL as MODEL};
use std::path::Path;
use std::process::Command;

/// Run, expect failure; return stderr.
fn fails(cmd: &mut Command, must_not_exist: &Path) -> String {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {err}"
    );
    assert!(
        !must_not_exist.exists(),
        "{} was written",
        must_not_exist.display()
    );
    assert!(!err.contains("panicked"), "panic: {err}");
    err
}

#[test]
fn bonds_and_tensor_outputs_follow_the_spec() {
    let d = tmp();
    let p = packing(d.path(), 300);
    let m = write(d.path(), "model.toml", MODEL);
    let csv = d.path().join("bonds.csv");
    let out = on_model("bonds", &p, &m)
        .arg("-o")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz"
    );
    // Every row: i < j, unit normal, k = magnitude·π·min(R)²·factor ≥ the smallest factor.
    let (bonds, k) = anisobond::bonds::read_bond_table(&csv).unwrap();
    assert!(bonds.len() > 300);
    let pk = anisobond::packing::read_packing(&p).unwrap();
    for b in 0..bonds.len() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        assert!(i < j);
        let rb = pk.radii[i].min(pk.radii[j]);
        assert!((k.radius[b] - rb).abs() < 1e-15 * rb);
        let area = std::f64::consts::PI * rb * rb;
        // Table values against the closed-form factor range of zener-above-1 (REFERENCES):
        // f_n ∈ [0.7427, 2.6484] (a_n = 4.31), f_s ∈ [0.5671, 4.6416] (a_s = 10).
        let fnn = k.kn[b] / (1e13 * area);
        let fs = k.ks[b] / (3.55e12 * area);
        assert!((0.7426..=2.6485).contains(&fnn), "f_n {fnn}");
        assert!((0.5670..=4.6417).contains(&fs), "f_s {fs}");
        assert_eq!((k.kr[b], k.ktw[b]), (0.0, 0.0));
    }
    // JSON report with the SPEC keys.
    let json = d.path().join("t.json");
    let out = on_model("tensor", &p, &m)
        .args(["--method", "voigt", "--json", "-o"])
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for key in [
        "method",
        "units",
        "C",
        "n_particles",
        "n_bonds",
        "coordination",
        "volume",
        "cubic",
        "transverse",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["units"], "Pa");
    assert_eq!(v["C"].as_array().unwrap().len(), 6);
    for key in ["C11", "C12", "C44", "zener", "uncertainty"] {
        assert!(v["cubic"].get(key).is_some(), "missing cubic.{key}");
    }
    for key in ["C11", "C33", "C13", "C12", "C44"] {
        assert!(
            v["transverse"].get(key).is_some(),
            "missing transverse.{key}"
        );
    }
    // stdout JSON is the same report
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed, v);
}

#[test]
fn bad_packings_are_clear_errors_without_output() {
    let d = tmp();
    let m = write(d.path(), "model.toml", MODEL);
    let csv = d.path().join("bonds.csv");
    let cases = [
        (
            "malformed.txt",
            "# periodic 10 10 10\n1 1 1 0.5\n2 2 0.5\n",
            "malformed.txt:3",
        ),
        (
            "nan.txt",
            "# periodic 10 10 10\n1 1 1 0.5\n2 nan 2 0.5\n",
            "nan.txt:3",
        ),
        (
            "negative.txt",
            "# periodic 10 10 10\n1 1 1 0.5\n2 2 2 -0.5\n",
            "negative.txt:3",
        ),
        (
            "coincident.txt",
            "# periodic 10 10 10\n1 1 1 0.5\n1 1 1 0.5\n3 3 3 0.5\n",
            "coincident",
        ),
    ];
    for (name, text, needle) in cases {
        let p = write(d.path(), name, text);
        let err = fails(on_model("bonds", &p, &m).arg("-o").arg(&csv), &csv);
        assert!(err.contains(needle), "{name}: {err}");
    }
    // a missing file names the file
    let err = fails(
        bin()
            .args(["bonds", "/nonexistent/p.txt", "--model"])
            .arg(&m)
            .arg("-o")
            .arg(&csv),
        &csv,
    );
    assert!(err.contains("/nonexistent/p.txt"), "{err}");
}

#[test]
fn bad_models_are_clear_errors_without_output() {
    let d = tmp();
    let p = packing(d.path(), 300);
    let out_json = d.path().join("t.json");
    let cases = [
        (MODEL.replace("a_n = 4.31", "a_n = -1.0"), "a_n"),
        (MODEL.replace("shear = 3.55e12", "shear = 3.55e12\nrotation = [[1,0,0],[0,1,0.3],[0,0,1]]"), "orthogonal"),
        (MODEL.replace("shear = 3.55e12", "shear = 3.55e12\nextended = true"), "negative shear stiffness"),
        (MODEL.replace("a_s = 10.0", "a_s = 10.0 10"), "model.toml:9"),
        (
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\nC11 = 1e8\nC33 = 1e8\nC13 = 3e8\nC12 = 1e7\n".to_string(),
            "positive definite",
        ),
    ];
    for (text, needle) in cases {
        let m = write(d.path(), "model.toml", &text);
        let err = fails(
            on_model("tensor", &p, &m)
                .args(["--method", "voigt", "-o"])
                .arg(&out_json),
            &out_json,
        );
        assert!(err.contains(needle), "expected `{needle}` in: {err}");
        assert!(
            err.contains("model.toml"),
            "error does not name the file: {err}"
        );
    }
}

/// `anisobond ARGS… PACKING --model MODEL -o OUT` run to success: the JSON it wrote to
/// `out`, and its printed text (standard output, then standard error).
fn json_report(args: &[&str], p: &Path, m: &Path, out: &Path) -> (serde_json::Value, String) {
    let o = bin()
        .args(args)
        .arg(p)
        .arg("--model")
        .arg(m)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    (v, text)
}

/// `stress-test` (Šmilauer's servo-controlled element tests) against `tensor --method
/// relaxed` on the same packing and model: the orthotropic entries agree to a few per mille
/// of C11 (the small remainder is the relaxed tensor's non-orthotropic part, which the
/// engineering-constant route cannot see); a missing packing is a clear error, no output.
#[test]
fn stress_test_agrees_with_the_relaxed_tensor() {
    let d = tmp();
    let p = packing(d.path(), 300);
    let m = write(d.path(), "model.toml", MODEL);
    let run = |args: &[&str], out: &Path| {
        let (v, _) = json_report(args, &p, &m, out);
        let c: Vec<Vec<f64>> = serde_json::from_value(v["C"].clone()).unwrap();
        c
    };
    let servo = run(&["stress-test"], &d.path().join("servo.json"));
    // The report's engineering constants against the compliance of the relaxed tensor:
    // E_i = 1/S_ii, ν_ij = −S_ij/S_ii, G = 1/S_44.. (engineering shear).
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("servo.json")).unwrap())
            .unwrap();
    let e = &v["engineering"];
    let relaxed = run(
        &["tensor", "--method", "relaxed", "--json"],
        &d.path().join("relaxed.json"),
    );
    let c = nalgebra::Matrix6::from_fn(|i, j| relaxed[i][j]);
    let s = c.try_inverse().unwrap();
    let close = |got: &serde_json::Value, want: f64, what: &str| {
        let got = got.as_f64().unwrap_or_else(|| panic!("{what} missing"));
        assert!(
            (got - want).abs() <= 5e-3 * want.abs(),
            "{what}: {got} vs {want}"
        );
    };
    let axes = ["x", "y", "z"];
    for i in 0..3 {
        close(&e["young"][format!("E_{}", axes[i])], 1.0 / s[(i, i)], "E");
        for j in (0..3).filter(|&j| j != i) {
            close(
                &e["poisson"][format!("nu_{}{}", axes[i], axes[j])],
                -s[(i, j)] / s[(i, i)],
                "nu",
            );
        }
    }
    for (k, name) in ["G_yz", "G_xz", "G_xy"].iter().enumerate() {
        close(&e["shear"][*name], 1.0 / s[(3 + k, 3 + k)], name);
    }
    let c11 = relaxed[0][0];
    let mut worst = 0.0f64;
    for (a, b) in [
        (0, 0),
        (1, 1),
        (2, 2),
        (0, 1),
        (0, 2),
        (1, 2),
        (3, 3),
        (4, 4),
        (5, 5),
    ] {
        worst = worst.max((servo[a][b] - relaxed[a][b]).abs() / c11);
    }
    assert!(
        worst < 5e-3,
        "stress-controlled vs relaxed: worst {worst:.2e} of C11"
    );
    let missing = d.path().join("none.txt");
    let out = d.path().join("never.json");
    let err = fails(
        on_model("stress-test", &missing, &m).arg("-o").arg(&out),
        &out,
    );
    assert!(err.contains("none.txt"), "{err}");
    // A tolerance that can never be met is refused up front, not after the step limit.
    let err = fails(
        on_model("stress-test", &p, &m)
            .arg("--stress-tolerance=-1")
            .arg("-o")
            .arg(&out),
        &out,
    );
    assert!(err.contains("tolerance") && err.contains("-1"), "{err}");
}

/// `grips` (free block driven through grip particles, measurement spheres, Truszkowska 2018
/// Sec. 4) against `tensor --method relaxed` on the same periodic packing: the cubic
/// constants agree within 10 % (the grip layer of a 1,000-particle block stiffens it by a
/// few per cent; see BENCHMARKS.md for the size study), the heterogeneity metric is printed,
/// and a bad model is a clear error without output.
#[test]
fn grips_block_tensor_is_close_to_the_periodic_relaxed_one() {
    let d = tmp();
    let p = d.path().join("p1000.txt");
    let o = bin()
        .args(["pack", "--particles", "1000", "--seed", "3", "-o"])
        .arg(&p)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = write(d.path(), "model.toml", MODEL);
    let cubic = |args: &[&str], out: &Path| {
        let (v, text) = json_report(args, &p, &m, out);
        (
            ["C11", "C12", "C44"].map(|k| v["cubic"][k].as_f64().unwrap()),
            text,
        )
    };
    let (gripped, text) = cubic(&["grips"], &d.path().join("g.json"));
    assert!(text.contains("heterogeneity"), "{text}");
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("g.json")).unwrap()).unwrap();
    for part in ["normal", "shear"] {
        let h = g["heterogeneity"][part].as_f64().unwrap();
        // A disordered block: a few per cent of spread, never zero (an affine lattice gives 0,
        // tests/dem/grips_lattice.rs).
        assert!(h > 1e-3 && h < 0.5, "heterogeneity {part} {h}");
    }
    assert!(g["grips"]["grip_particles"].as_u64().unwrap() > 0);
    let (relaxed, _) = cubic(
        &["tensor", "--method", "relaxed", "--json"],
        &d.path().join("r.json"),
    );
    for k in 0..3 {
        let rel = (gripped[k] - relaxed[k]).abs() / relaxed[k];
        assert!(
            rel < 0.10,
            "cubic constant {k}: gripped {} vs relaxed {} ({rel:.3})",
            gripped[k],
            relaxed[k]
        );
    }
    let bad = write(
        d.path(),
        "bad.toml",
        "[bonding]\nrule = \"gap\"\nvalue = -1\n",
    );
    let out = d.path().join("never.json");
    let err = fails(on_model("grips", &p, &bad).arg("-o").arg(&out), &out);
    assert!(err.contains("bad.toml"), "{err}");
    // A grip shell that swallows the whole block is a clear error.
    let err = fails(
        on_model("grips", &p, &m)
            .arg("--grip-shell=100")
            .arg("-o")
            .arg(&out),
        &out,
    );
    assert!(err.contains("grip shell of 100"), "{err}");
}

/// An output path in a directory that does not exist is refused before any computation, by
/// every command that runs the integrator or a solver, naming the path and the directory.
#[test]
fn missing_output_directory_is_refused_up_front() {
    let d = tmp();
    let p = packing(d.path(), 300);
    let m = write(d.path(), "model.toml", MODEL);
    let missing = d.path().join("no-such-dir");
    let cases: [(&[&str], &str); 5] = [
        (&["run"], "-o"),
        (&["run"], "--history"),
        (&["stress-test"], "-o"),
        (&["grips"], "-o"),
        (&["tensor", "--method", "relaxed"], "-o"),
    ];
    for (cmd, flag) in cases {
        let target = missing.join("out.file");
        let err = fails(
            bin()
                .args(&cmd[..1])
                .arg(&p)
                .args(&cmd[1..])
                .arg("--model")
                .arg(&m)
                .arg(flag)
                .arg(&target),
            &missing,
        );
        assert!(
            err.contains("no-such-dir") && err.contains("does not exist"),
            "{cmd:?} {flag}: {err}"
        );
        // Refused before the element tests: no progress or step output on stderr.
        assert!(
            !err.contains("relaxed in"),
            "{cmd:?} {flag} ran first: {err}"
        );
    }
    // `pack` (minutes for the jammed route) checks up front; `bonds` goes through the atomic
    // writer's own check: the same message.
    let err = fails(
        bin()
            .args(["pack", "--route", "jammed", "--particles", "2000", "-o"])
            .arg(missing.join("p.txt")),
        &missing,
    );
    assert!(
        err.contains("no-such-dir") && err.contains("does not exist"),
        "pack: {err}"
    );
    let err = fails(
        on_model("bonds", &p, &m)
            .arg("-o")
            .arg(missing.join("b.csv")),
        &missing,
    );
    assert!(
        err.contains("no-such-dir") && err.contains("does not exist"),
        "bonds: {err}"
    );
}

/// Every file an anisobond command writes gets the permissions of an ordinary file created
/// by the same user in the same folder (std's `File::create`: 0666 less the umask), not the
/// private 0600 of the temporary file it is written through: packings, tables, scripts and
/// plots are meant to be shared and run by others (a YADE or LIGGGHTS user, a cluster job);
/// a `run.sh` also gets the run bit where it is readable.
#[cfg(unix)]
#[test]
fn outputs_get_the_permissions_of_an_ordinary_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tmp();
    let out = dir.path().join("demo");
    let status = bin().arg("demo").arg("-o").arg(&out).output().unwrap();
    assert!(status.status.success(), "{:?}", status);
    let reference = dir.path().join("reference.txt");
    std::fs::File::create(&reference).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let expected = mode(&reference);
    let mut files = Vec::new();
    let mut stack = vec![out.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                files.push(p);
            }
        }
    }
    assert!(files.len() >= 14, "demo wrote {} files", files.len());
    assert!(files
        .iter()
        .any(|p| p.extension().is_some_and(|e| e == "png")));
    for p in &files {
        // Scripts to run (`./run.sh`) get the run bit wherever they are readable.
        let expected = if p.file_name().is_some_and(|n| n == "run.sh") {
            expected | ((expected & 0o444) >> 2)
        } else {
            expected
        };
        assert_eq!(
            mode(p),
            expected,
            "{}: mode {:o}, an ordinary file here gets {:o}",
            p.display(),
            mode(p),
            expected
        );
    }
}
