//! No silent wrong answer (issue 17): every result the command writes is right or refused.
//! A refusal exits non-zero, says which input or option is wrong, writes no output and
//! leaves every pre-existing file (inputs above all) as it was; a command's set of outputs
//! appears whole or not at all.

use crate::common::*;
use std::path::Path;

/// `cmd(line, vars)` must fail without writing `out`; returns standard error.
fn refused(line: &str, vars: &[(&str, &Path)], out: &Path) -> String {
    let err = fails(&mut cmd(line, vars));
    assert!(!out.exists(), "`{line}` wrote {}", out.display());
    err
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let original = (std::fs::read(&p).unwrap(), std::fs::read(&m).unwrap());
    // The same file by another name too: sub/../packing.txt.
    std::fs::create_dir(d.join("sub")).unwrap();
    let other = d.join("sub").join("..").join("packing.txt");
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("other", other.as_path()),
    ];
    for line in [
        "bonds {p} --model {m} -o {p}",
        "bonds {p} --model {m} -o {m}",
        "bonds {p} --model {m} -o {other}",
        "tensor {p} --model {m} --method voigt -o {p}",
        "run {p} --model {m} --history {p}",
        "calibrate --model {m} --target C12/C11=0.3,C44/C11=0.43 -o {m}",
    ] {
        let err = fails(&mut cmd(line, &vars));
        assert!(
            err.contains("also an input") && err.contains("refusing to overwrite"),
            "{line}: {err}"
        );
        let now = (std::fs::read(&p).unwrap(), std::fs::read(&m).unwrap());
        assert!(now == original, "`{line}` changed an input");
    }
    holds_exactly(d, &["model.toml", "packing.txt", "sub"]);
}

#[test]
fn a_multi_file_output_appears_whole_or_not_at_all() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let (ex, dom, h, dir) = (d.join("ex"), d.join("dom"), d.join("h.csv"), d.join("D"));
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("ex", ex.as_path()),
        ("dom", dom.as_path()),
        ("h", h.as_path()),
        ("D", dir.as_path()),
    ];
    // export yade: DIR/run.py is a folder, so the last file cannot be placed: nothing is.
    std::fs::create_dir_all(ex.join("run.py")).unwrap();
    let err = fails(&mut cmd("export yade {p} --model {m} -o {ex}", &vars));
    assert!(
        err.contains("run.py") && err.contains("is a folder"),
        "{err}"
    );
    holds_exactly(&ex, &["run.py"]);
    // Without the obstacle the same command writes the whole set into the existing folder.
    std::fs::remove_dir(ex.join("run.py")).unwrap();
    succeeds(&mut cmd("export yade {p} --model {m} -o {ex}", &vars));
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
    let err = refused("domain --samples 0 -o {dom}", &vars, &dom);
    assert!(err.contains("at least 1"), "{err}");
    // run: -o names a folder, so the history file already there must stay as it was.
    std::fs::write(&h, "keep\n").unwrap();
    std::fs::create_dir(&dir).unwrap();
    let err = fails(&mut cmd("run {p} --model {m} -o {D} --history {h}", &vars));
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
    let out = d.join("r.json");
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("out", out.as_path()),
    ];
    for bad in ["1", "0.5", "0", "-1e-6", "NaN", "1e-15"] {
        let line =
            format!("tensor {{p}} --model {{m}} --method relaxed --cg-tolerance={bad} -o {{out}}");
        let err = refused(&line, &vars, &out);
        assert!(
            err.contains("--cg-tolerance") && err.contains("[1e-12, 1e-2]"),
            "{bad}: {err}"
        );
    }
    // A relaxed report says which residual it reached, and that residual meets the request.
    for tol in [1e-4, 1e-9] {
        let line =
            format!("tensor {{p}} --model {{m}} --method relaxed --json --cg-tolerance {tol}");
        let v: serde_json::Value = serde_json::from_str(&succeeds(&mut cmd(&line, &vars))).unwrap();
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
    let (out, pk) = (d.join("C.json"), d.join("big.txt"));
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("huge", huge.as_path()),
        ("out", out.as_path()),
        ("pk", pk.as_path()),
    ];
    for method in ["mean-field", "voigt", "relaxed"] {
        let err = refused(
            &format!("tensor {{p}} --model {{huge}} --method {method} -o {{out}}"),
            &vars,
            &out,
        );
        assert!(err.contains("huge.toml"), "{method}: {err}");
    }
    let err = refused(
        "tensor --model {huge} --method mean-field -o {out}",
        &vars,
        &out,
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
        let err = refused(
            &format!("tensor --model {{m}} --method mean-field {opt} {v} -o {{out}}"),
            &vars,
            &out,
        );
        assert!(err.contains(opt), "{opt} {v}: {err}");
    }
    let err = refused("pack --quiet --mean-radius 1e300 -o {pk}", &vars, &pk);
    assert!(err.contains("mean radius 1e300"), "{err}");
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
    let p = packing(d, 120);
    let zero_springs = CUBIC_MODEL
        .replace("normal = 1.0e13", "normal = 0")
        .replace("shear = 3.55e12", "shear = 0");
    let zero = write(d, "zero.toml", &zero_springs);
    let out = d.join("C.json");
    let vars = [
        ("two", two.as_path()),
        ("chain", chain.as_path()),
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("zero", zero.as_path()),
        ("out", out.as_path()),
    ];
    let cases = [
        ("two", "m", "voigt relaxed laf"),
        ("chain", "m", "voigt relaxed laf"),
        ("p", "zero", "voigt relaxed"),
    ];
    for (packing, model, methods) in cases {
        for method in methods.split(' ') {
            let line =
                format!("tensor {{{packing}}} --model {{{model}}} --method {method} -o {{out}}");
            let err = refused(&line, &vars, &out);
            assert!(
                err.contains("carries no load") || err.contains("is a mechanism"),
                "{line}: {err}"
            );
        }
    }
    // The same packing with the real model is a result: positive definite, finite.
    let json = succeeds(&mut cmd(
        "tensor {p} --model {m} --method relaxed --json",
        &vars,
    ));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["cubic"]["zener"].as_f64().unwrap().is_finite());
}

#[test]
fn sizes_beyond_the_machine_are_refused_before_allocating() {
    let t = tmp();
    let d = t.path();
    let (out, dom) = (d.join("p.txt"), d.join("dom"));
    let vars = [("out", out.as_path()), ("dom", dom.as_path())];
    let start = std::time::Instant::now();
    let err = refused("pack --quiet --particles 4294967295 -o {out}", &vars, &out);
    assert!(
        err.contains("GiB of memory") && err.contains("available"),
        "{err}"
    );
    let err = refused("pack --quiet --particles 10000000000 -o {out}", &vars, &out);
    assert!(
        err.contains("between 2 and 4294967295") && err.contains("10000000000"),
        "{err}"
    );
    let err = refused("domain --samples 4000000000 -o {dom}", &vars, &dom);
    assert!(err.contains("GiB of memory"), "{err}");
    // A refusal, not an attempt: far below the time any allocation of that size would take.
    assert!(start.elapsed().as_secs() < 30);
}

#[test]
fn validate_liggghts_refuses_an_unsupported_rank_count_before_running() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = d.join("v");
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("out", out.as_path()),
    ];
    let err = refused(
        "validate liggghts {p} --model {m} --np 3 -o {out}",
        &vars,
        &out,
    );
    assert!(err.contains("--np") && err.contains("1..=2"), "{err}");
}

#[test]
fn options_that_make_a_meaningless_result_are_refused() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let (out, cal) = (d.join("out"), d.join("cal.toml"));
    let vars = [
        ("p", p.as_path()),
        ("m", m.as_path()),
        ("out", out.as_path()),
        ("cal", cal.as_path()),
    ];
    // Explicit time steps above the critical one: the exported run would blow up.
    for (target, opt) in [("yade", "--dt"), ("liggghts", "--timestep")] {
        let err = refused(
            &format!("export {target} {{p}} --model {{m}} {opt} 1e-3 -o {{out}}"),
            &vars,
            &out,
        );
        assert!(
            err.contains(opt) && err.contains("critical time step"),
            "{target}: {err}"
        );
    }
    // A strain far outside the small-strain state VTK shows (1e308 wrote NaN and inf).
    let err = refused(
        "export vtk {p} --model {m} --strain 1e308,0,0,0,0,0 -o {out}",
        &vars,
        &out,
    );
    assert!(err.contains("--strain") && err.contains("0.1"), "{err}");
    // An infinite calibration tolerance accepted the starting point as "calibrated".
    for tol in ["inf", "0", "1"] {
        let line = format!("calibrate --model {{m}} --target C12/C11=0.3,C44/C11=0.43 --tolerance {tol} --on relaxed {{p}} -o {{cal}}");
        let err = refused(&line, &vars, &cal);
        assert!(err.contains("--tolerance"), "{tol}: {err}");
    }
    // A solid fraction of 1e-300 gave a subnormal "tensor".
    let err = refused(
        "tensor --model {m} --method mean-field --solid-fraction 1e-300 -o {out}",
        &vars,
        &out,
    );
    assert!(err.contains("--solid-fraction"), "{err}");
}

#[test]
fn an_elongated_cell_is_refused_not_aborted() {
    // Found by tests/io/fuzz_readers.rs: the two-level preconditioner sized a dense grid of
    // aggregates by the cell (1e15 m along x: an 8.8 TB allocation, SIGABRT). A 4×4×4 lattice
    // that does not span the cell along x is a mechanism under e11, so it is refused.
    let t = tmp();
    let d = t.path();
    let mut text = String::from("# periodic 1e15 8e-3 8e-3\n");
    for (i, j, k) in (0..64).map(|n| (n / 16, (n / 4) % 4, n % 4)) {
        text += &format!(
            "{} {} {} 1e-3\n",
            i as f64 * 2e-3,
            j as f64 * 2e-3,
            k as f64 * 2e-3
        );
    }
    let p = write(d, "long.txt", &text);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let out = cmd(
        "tensor {p} --model {m} --method relaxed",
        &[("p", &p), ("m", &m)],
    )
    .output()
    .unwrap();
    let err = stderr(&out);
    // A degenerate result (README "Errors and limits": exit 4), not an abort.
    assert_eq!(out.status.code(), Some(4), "{err}");
    assert!(err.contains("is a mechanism"), "{err}");
}
