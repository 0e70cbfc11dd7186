//! No silent wrong answer (issue 17): every result the command writes is right or refused.
//! A refusal exits non-zero, says which input or option is wrong, writes no output and
//! leaves every pre-existing file (inputs above all) as it was; a command's set of outputs
//! appears whole or not at all.

mod common;
use common::*;
use std::path::Path;

/// The folder holds exactly `names` (so no staging file or folder was left behind).
fn holds_exactly(dir: &Path, names: &[&str]) {
    let mut want: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(entries(dir), want, "contents of {}", dir.display());
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let original_p = std::fs::read(&p).unwrap();
    let original_m = std::fs::read(&m).unwrap();
    // The same file by another name too: ./dir/../packing.txt.
    std::fs::create_dir(d.join("sub")).unwrap();
    let other_name = d.join("sub").join("..").join("packing.txt");
    let cases: Vec<Vec<std::ffi::OsString>> = vec![
        vec![
            "bonds".into(),
            p.clone().into(),
            "--model".into(),
            m.clone().into(),
            "-o".into(),
            p.clone().into(),
        ],
        vec![
            "bonds".into(),
            p.clone().into(),
            "--model".into(),
            m.clone().into(),
            "-o".into(),
            m.clone().into(),
        ],
        vec![
            "bonds".into(),
            p.clone().into(),
            "--model".into(),
            m.clone().into(),
            "-o".into(),
            other_name.into(),
        ],
        vec![
            "tensor".into(),
            p.clone().into(),
            "--model".into(),
            m.clone().into(),
            "--method".into(),
            "voigt".into(),
            "-o".into(),
            p.clone().into(),
        ],
        vec![
            "run".into(),
            p.clone().into(),
            "--model".into(),
            m.clone().into(),
            "--history".into(),
            p.clone().into(),
        ],
        vec![
            "calibrate".into(),
            "--model".into(),
            m.clone().into(),
            "--target".into(),
            "C12/C11=0.3,C44/C11=0.43".into(),
            "-o".into(),
            m.clone().into(),
        ],
    ];
    for args in cases {
        let err = fails(bin().args(&args));
        assert!(
            err.contains("also an input") && err.contains("refusing to overwrite"),
            "{args:?}: {err}"
        );
        assert_eq!(
            std::fs::read(&p).unwrap(),
            original_p,
            "{args:?} changed the packing"
        );
        assert_eq!(
            std::fs::read(&m).unwrap(),
            original_m,
            "{args:?} changed the model"
        );
    }
    holds_exactly(d, &["model.toml", "packing.txt", "sub"]);
}

#[test]
fn a_multi_file_output_appears_whole_or_not_at_all() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    // export yade: DIR/run.py is a folder, so the last file cannot be placed: nothing is.
    let ex = d.join("ex");
    std::fs::create_dir_all(ex.join("run.py")).unwrap();
    let err = fails(
        bin()
            .args(["export", "yade"])
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .arg("-o")
            .arg(&ex),
    );
    assert!(
        err.contains("run.py") && err.contains("is a folder"),
        "{err}"
    );
    holds_exactly(&ex, &["run.py"]);
    // Without the obstacle the same command writes the whole set into the existing folder.
    std::fs::remove_dir(ex.join("run.py")).unwrap();
    succeeds(
        bin()
            .args(["export", "yade"])
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .arg("-o")
            .arg(&ex),
    );
    holds_exactly(
        &ex,
        &[
            "anisobond_yade.py",
            "bonds.csv",
            "model.toml",
            "packing.txt",
            "run.py",
        ],
    );
    // domain --samples 0 fails and creates no folder.
    let dom = d.join("dom");
    let err = fails(bin().args(["domain", "--samples", "0", "-o"]).arg(&dom));
    assert!(err.contains("at least 1"), "{err}");
    assert!(!dom.exists());
    // run: -o names a folder, so the history file already there must stay as it was.
    let h = write(d, "h.csv", "keep\n");
    std::fs::create_dir(d.join("D")).unwrap();
    let err = fails(
        bin()
            .arg("run")
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .arg("-o")
            .arg(d.join("D"))
            .arg("--history")
            .arg(&h),
    );
    assert!(err.contains("D: is a folder"), "{err}");
    assert_eq!(std::fs::read_to_string(&h).unwrap(), "keep\n");
    holds_exactly(d, &["D", "ex", "h.csv", "model.toml", "packing.txt"]);
}

#[test]
fn the_relaxed_tolerance_is_checked_and_its_residual_reported() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 150);
    let m = write(d, "model.toml", CUBIC_MODEL);
    for bad in ["1", "0.5", "0", "-1e-6", "NaN", "1e-15"] {
        let out = d.join("r.json");
        let err = fails(
            bin()
                .arg("tensor")
                .arg(&p)
                .arg("--model")
                .arg(&m)
                .args([
                    "--method",
                    "relaxed",
                    &format!("--cg-tolerance={bad}"),
                    "-o",
                ])
                .arg(&out),
        );
        assert!(
            err.contains("--cg-tolerance") && err.contains("[1e-12, 1e-2]"),
            "{bad}: {err}"
        );
        assert!(!out.exists());
    }
    // A relaxed report says which residual it reached, and that residual meets the request.
    for tol in [1e-4, 1e-9] {
        let json = succeeds(bin().arg("tensor").arg(&p).arg("--model").arg(&m).args([
            "--method",
            "relaxed",
            "--json",
            "--cg-tolerance",
            &tol.to_string(),
        ]));
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let r = v["relative_residual"]
            .as_f64()
            .expect("relative_residual in the report");
        assert!(r > 0.0 && r <= tol, "residual {r} for tolerance {tol}");
    }
}

#[test]
fn overflowing_inputs_are_refused_by_name_with_no_output() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let huge = write(
        d,
        "huge.toml",
        &CUBIC_MODEL.replace("normal = 1.0e13", "normal = 1e308"),
    );
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = d.join("C.json");
    for method in ["mean-field", "voigt", "relaxed"] {
        let err = fails(
            bin()
                .arg("tensor")
                .arg(&p)
                .arg("--model")
                .arg(&huge)
                .args(["--method", method, "-o"])
                .arg(&out),
        );
        assert!(err.contains("huge.toml"), "{method}: {err}");
        assert!(!out.exists());
    }
    let err = fails(
        bin()
            .arg("tensor")
            .arg("--model")
            .arg(&huge)
            .args(["--method", "mean-field"]),
    );
    assert!(
        err.contains("huge.toml") && err.contains("overflows"),
        "{err}"
    );
    for (opt, v) in [
        ("--coordination", "1e308"),
        ("--radius", "1e300"),
        ("--radius", "1e-300"),
    ] {
        let err = fails(
            bin()
                .arg("tensor")
                .arg("--model")
                .arg(&m)
                .args(["--method", "mean-field", opt, v, "-o"])
                .arg(&out),
        );
        assert!(err.contains(opt), "{opt} {v}: {err}");
        assert!(!out.exists());
    }
    let pk = d.join("big.txt");
    let err = fails(
        bin()
            .args(["pack", "--quiet", "--mean-radius", "1e300", "-o"])
            .arg(&pk),
    );
    assert!(err.contains("mean radius 1e300"), "{err}");
    assert!(!pk.exists());
}

#[test]
fn networks_that_carry_no_load_are_refused() {
    let t = tmp();
    let d = t.path();
    let m = write(d, "model.toml", CUBIC_MODEL);
    // Two bonded spheres and a three-sphere chain: a mechanism under most strains. (The mean
    // field is left out: it integrates over a uniform orientation distribution at the
    // packing's bond density by definition, whatever the network's connectivity.)
    let two = write(
        d,
        "two.txt",
        "# periodic 0.01 0.01 0.01\n0 0 0 0.001\n0.002 0 0 0.001\n",
    );
    let chain = write(
        d,
        "chain.txt",
        "# periodic 0.01 0.01 0.01\n0 0 0 0.001\n0.002 0 0 0.001\n0.004 0 0 0.001\n",
    );
    let out = d.join("C.json");
    for p in [&two, &chain] {
        for method in ["voigt", "relaxed", "laf"] {
            let err = fails(
                bin()
                    .arg("tensor")
                    .arg(p)
                    .arg("--model")
                    .arg(&m)
                    .args(["--method", method, "-o"])
                    .arg(&out),
            );
            assert!(
                err.contains("carries no load") || err.contains("is a mechanism"),
                "{} {method}: {err}",
                p.display()
            );
            assert!(!out.exists());
        }
    }
    // Zero springs on a well-connected packing: the tensor is zero, not a result.
    let p = packing(d, 120);
    let zero = write(
        d,
        "zero.toml",
        &CUBIC_MODEL
            .replace("normal = 1.0e13", "normal = 0")
            .replace("shear = 3.55e12", "shear = 0"),
    );
    for method in ["voigt", "relaxed"] {
        let err = fails(
            bin()
                .arg("tensor")
                .arg(&p)
                .arg("--model")
                .arg(&zero)
                .args(["--method", method]),
        );
        assert!(
            err.contains("carries no load") || err.contains("is a mechanism"),
            "{method}: {err}"
        );
    }
    // The same packing with the real model is a result: positive definite, finite.
    let json = succeeds(
        bin()
            .arg("tensor")
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .args(["--method", "relaxed", "--json"]),
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["cubic"]["zener"].as_f64().unwrap().is_finite());
}

#[test]
fn sizes_beyond_the_machine_are_refused_before_allocating() {
    let t = tmp();
    let d = t.path();
    let out = d.join("p.txt");
    let start = std::time::Instant::now();
    let err = fails(
        bin()
            .args(["pack", "--quiet", "--particles", "4294967295", "-o"])
            .arg(&out),
    );
    assert!(
        err.contains("GiB of memory") && err.contains("available"),
        "{err}"
    );
    let err = fails(
        bin()
            .args(["pack", "--quiet", "--particles", "10000000000", "-o"])
            .arg(&out),
    );
    assert!(
        err.contains("between 2 and 4294967295") && err.contains("10000000000"),
        "{err}"
    );
    let dom = d.join("dom");
    let err = fails(
        bin()
            .args(["domain", "--samples", "4000000000", "-o"])
            .arg(&dom),
    );
    assert!(err.contains("GiB of memory"), "{err}");
    // A refusal, not an attempt: far below the time any allocation of that size would take.
    assert!(start.elapsed().as_secs() < 30);
    assert!(!out.exists() && !dom.exists());
}

#[test]
fn validate_liggghts_refuses_an_unsupported_rank_count_before_running() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = d.join("v");
    let err = fails(
        bin()
            .args(["validate", "liggghts"])
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .args(["--np", "3", "-o"])
            .arg(&out),
    );
    assert!(err.contains("--np") && err.contains("1..=2"), "{err}");
    assert!(!out.exists());
}

#[test]
fn options_that_make_a_meaningless_result_are_refused() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = d.join("out");
    // Explicit time steps above the critical one: the exported run would blow up.
    for (target, opt) in [("yade", "--dt"), ("liggghts", "--timestep")] {
        let err = fails(
            bin()
                .args(["export", target])
                .arg(&p)
                .arg("--model")
                .arg(&m)
                .args([opt, "1e-3", "-o"])
                .arg(&out),
        );
        assert!(
            err.contains(opt) && err.contains("critical time step"),
            "{target}: {err}"
        );
        assert!(!out.exists());
    }
    // A strain far outside the small-strain state VTK shows (1e308 wrote NaN and inf).
    let err = fails(
        bin()
            .args(["export", "vtk"])
            .arg(&p)
            .arg("--model")
            .arg(&m)
            .args(["--strain", "1e308,0,0,0,0,0", "-o"])
            .arg(&out),
    );
    assert!(err.contains("--strain") && err.contains("0.1"), "{err}");
    assert!(!out.exists());
    // An infinite calibration tolerance accepted the starting point as "calibrated".
    let cal = d.join("cal.toml");
    for tol in ["inf", "0", "1"] {
        let err = fails(
            bin()
                .args(["calibrate", "--model"])
                .arg(&m)
                .args([
                    "--target",
                    "C12/C11=0.3,C44/C11=0.43",
                    "--tolerance",
                    tol,
                    "--on",
                    "relaxed",
                ])
                .arg(&p)
                .arg("-o")
                .arg(&cal),
        );
        assert!(err.contains("--tolerance"), "{tol}: {err}");
        assert!(!cal.exists());
    }
    // A solid fraction of 1e-300 gave a subnormal "tensor".
    let err = fails(bin().arg("tensor").arg("--model").arg(&m).args([
        "--method",
        "mean-field",
        "--solid-fraction",
        "1e-300",
    ]));
    assert!(err.contains("--solid-fraction"), "{err}");
}

#[test]
fn an_elongated_cell_is_refused_not_aborted() {
    // Found by tests/fuzz_readers.rs: the two-level preconditioner sized a dense grid of
    // aggregates by the cell (1e15 m along x: an 8.8 TB allocation, SIGABRT). A 4×4×4 lattice
    // that does not span the cell along x is a mechanism under e11, so it is refused.
    let t = tmp();
    let d = t.path();
    let mut text = String::from("# periodic 1e15 8e-3 8e-3\n");
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                text += &format!(
                    "{} {} {} 1e-3\n",
                    i as f64 * 2e-3,
                    j as f64 * 2e-3,
                    k as f64 * 2e-3
                );
            }
        }
    }
    let p = write(d, "long.txt", &text);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = bin()
        .arg("tensor")
        .arg(&p)
        .arg("--model")
        .arg(&m)
        .args(["--method", "relaxed"])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("is a mechanism"), "{err}");
}
