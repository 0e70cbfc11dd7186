//! `validate yade` for real: YADE 2023.02a and anisobond on a 300-particle periodic bonded
//! packing (gap 0.17 R̄, Truszkowska 2018 MRV cubic model). The validation must pass; the
//! comparisons must be able to fail (a 0.1 % mass mismatch is caught by the undamped
//! history, an impossibly tight tolerance makes the command exit non-zero naming the
//! check); and the stress both codes report right after the strain step must be the
//! affine one, C_Voigt·ε (an independent closed form: Σ k l⊗n⊗n⊗l / V).
//!
//! Skipped with a printed reason only when `yade` is not on PATH; with the environment
//! variable CI set, a missing `yade` fails.

use crate::common::yade::yade_available;
use anisobond::bonds::{self, build_bonds, BondSet, BondStiffness};
use anisobond::dem::{build_law, DemOptions, LawKind, MassOptions, Simulation};
use anisobond::homogenize::voigt_tensor;
use anisobond::model::Model;
use anisobond::packing::{write_packing, Packing};
use anisobond::tensor::relative_difference;
use anisobond::validate::yade::{
    compare_histories, outputs, run_path_like_yade, validate_yade, write_validation_files,
    YadeValidationOptions,
};
use std::process::Command;

fn bonded_packing(n: usize, seed: u64) -> (Packing, BondSet, BondStiffness, Model) {
    let packing = crate::common::bonded::generated(n, seed);
    let model = Model::truszkowska_mrv(); // gap 0.17 R̄, cubic Zener > 1
    let b = build_bonds(&packing, model.bonding).expect("bonds");
    let scheme = model.build_scheme(Some((&packing, &b))).expect("scheme");
    let k = bonds::assign_stiffness(&packing, &b, scheme.as_ref(), &model.geometry).unwrap();
    (packing, b, k, model)
}

#[test]
fn yade_and_anisobond_agree_on_300_particles() {
    let test = "yade_and_anisobond_agree_on_300_particles";
    if !yade_available(test) {
        return;
    }
    let (packing, b, k, model) = bonded_packing(300, 11);
    let dir = tempfile::tempdir().unwrap();
    // One undamped path (the shear 12) keeps the test short; the CLI default adds 11.
    let opts = YadeValidationOptions {
        undamped_paths: vec![5],
        ..Default::default()
    };
    let v = validate_yade(
        dir.path(),
        &packing,
        &b,
        &k,
        Some(&model),
        &opts,
        &|m: &str| eprintln!("{test}: {m}"),
    )
    .expect("validation ran");
    for c in &v.checks {
        eprintln!(
            "{test}: {:<70} {:.3e} (tolerance {:.0e})",
            c.description,
            c.value,
            c.tolerance.unwrap_or(f64::NAN)
        );
    }
    eprintln!(
        "{test}: {} particles, {} bonds, dt {:.4e} s; times (s): {:?}",
        v.n_particles, v.n_bonds, v.time_step, v.timings
    );
    assert!(v.passed(), "checks failed: {:?}", v.failures());
    assert_eq!(v.checks.len(), 4);
    assert_eq!(v.undamped[0].steps, opts.undamped_steps + 1);

    // The damped comparison discriminates: relaxation moves C well beyond the tolerance.
    let affine = voigt_tensor(&b, &k, packing.volume());
    let relaxation = relative_difference(&affine, &v.tensors.relaxed);
    assert!(
        relaxation > 0.02,
        "relaxed ≈ affine ({relaxation:.3e}): the tensor checks would not discriminate"
    );

    // Independent closed form: the stress of step 2 (the first force evaluation that sees
    // the strain, YADE's one-step-late velGrad) is the affine C_Voigt·ε in both codes, to
    // the geometric non-linearity of a 1e-5 strain.
    for rows in [&v.undamped_runs.engine, &v.undamped_runs.integrator] {
        let s1 = rows.iter().find(|r| r.step == 1).unwrap();
        let s2 = rows.iter().find(|r| r.step == 2).unwrap();
        assert_eq!(s1.stress.amax(), 0.0, "stress after step 1 must be zero");
        let want = affine * s2.strain;
        let err = (s2.stress - want).amax() / want.amax();
        assert!(
            (s2.strain[5] - opts.strain).abs() < 1e-10 * opts.strain && err < 1e-4,
            "step-2 stress {} vs affine {want} ({err:.3e})",
            s2.stress
        );
    }

    // The undamped comparison can fail: 0.1 % more mass in anisobond is visible.
    let law = build_law(LawKind::Yade, &packing, &b, &k).unwrap();
    let heavier = Simulation::new(
        &packing,
        &b,
        law,
        &DemOptions {
            time_step: Some(v.time_step),
            mass: MassOptions {
                density: opts.density * 1.001,
                scaling: 1.0,
            },
            ..Default::default()
        },
    )
    .unwrap();
    let steps = 100;
    let rows = run_path_like_yade(&heavier, 5, opts.strain, steps, 0.0).unwrap();
    let yade: Vec<_> = v
        .undamped_runs
        .engine
        .iter()
        .filter(|r| r.step <= steps)
        .cloned()
        .collect();
    let off = compare_histories(5, &yade, &rows).unwrap();
    eprintln!(
        "{test}: density +0.1 % → undamped difference {:.3e}",
        off.relative
    );
    assert!(
        off.relative > 100.0 * opts.tolerances.history,
        "a 0.1 % mass mismatch gives only {:.3e}",
        off.relative
    );

    // Files: both histories side by side, the summary.
    let written = write_validation_files(dir.path(), &v).unwrap();
    assert_eq!(written.len(), 5);
    // The history plots are real pictures: 1000×700 with many colours.
    for png in [outputs::UNDAMPED_PNG, outputs::DAMPED_PNG] {
        let img = image::open(dir.path().join(png))
            .expect("decodable PNG")
            .to_rgb8();
        assert_eq!(img.dimensions(), (1000, 700));
        let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert!(colours.len() > 20, "{png} looks blank");
    }
    let csv = std::fs::read_to_string(dir.path().join(outputs::UNDAMPED_CSV)).unwrap();
    let data: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert!(data[0].starts_with("path,step,time_s,e_path,yade_s11_Pa"));
    assert!(data[0].contains("anisobond_s12_Pa"));
    assert_eq!(data.len(), 1 + opts.undamped_steps + 1);
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join(outputs::SUMMARY_JSON)).unwrap(),
    )
    .unwrap();
    assert_eq!(json["passed"], true);
    assert_eq!(json["units"], "Pa");
    assert_eq!(json["C_yade"].as_array().unwrap().len(), 6);
}

#[test]
fn validate_yade_cli_exits_non_zero_out_of_tolerance() {
    let test = "validate_yade_cli_exits_non_zero_out_of_tolerance";
    if !yade_available(test) {
        return;
    }
    let (packing, _, _, model) = bonded_packing(300, 12);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("packing.txt");
    write_packing(&p, &packing).unwrap();
    let m = dir.path().join("model.toml");
    std::fs::write(&m, model.to_toml_string()).unwrap();
    let out_dir = dir.path().join("out");
    // Short runs; an undamped tolerance no two codes summing in different orders can meet
    // (measured differences are ~1e-10), every other tolerance loose.
    let out = Command::new(env!("CARGO_BIN_EXE_anisobond"))
        .args(["validate", "yade"])
        .arg(&p)
        .arg("--model")
        .arg(&m)
        .arg("-o")
        .arg(&out_dir)
        .args([
            "--undamped-steps",
            "50",
            "--undamped-paths",
            "11",
            "--damped-steps",
            "20",
            "--history-tolerance",
            "1e-15",
            "--tensor-tolerance",
            "1",
            "--relaxed-tolerance",
            "1",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{test}: stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(!out.status.success(), "exit status {}", out.status);
    assert!(
        stderr.contains("validate yade FAILED (1 of 4 checks")
            && stderr.contains("undamped stress history, path 11"),
        "the message must name the failing check: {stderr}"
    );
    assert!(stdout.contains("FAILED") && stdout.contains("max |Δσ| (Pa)"));
    // The files are written even when the validation fails.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out_dir.join(outputs::SUMMARY_JSON)).unwrap(),
    )
    .unwrap();
    assert_eq!(json["passed"], false);
    assert!(out_dir.join(outputs::DAMPED_CSV).is_file());
    assert!(out_dir.join(outputs::YADE_DIR).join("run.py").is_file());
}
