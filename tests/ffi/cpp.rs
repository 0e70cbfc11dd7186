//! Builds the C++ side (`make -C cpp check`: static library with the cxx bridge, example,
//! C++ test) and runs the C++ test, which checks the bridge against docs/references.md numbers
//! and closed forms. Skipped with a reason only when g++/make are absent and CI is unset.

use crate::common::{self, missing, root, target_dir, tmp};
use anisobond::assembly::{Assembly, MethodKind, MethodOptions};
use std::process::Command;

#[test]
fn cpp_bridge_test_builds_and_passes() {
    if let Some(reason) = missing(&["g++", "make"]) {
        eprintln!("skipping: {reason}");
        return;
    }
    let (root, target) = (root(), target_dir());
    // A disordered packing and the demo's cubic model, for the methods only the registry
    // brought to the bridge (laf, prestressed): C++ writes its tensors to `methods.txt`.
    let dir = tmp();
    let packing = common::packing(dir.path(), 200);
    let model = common::write(dir.path(), "model.toml", common::CUBIC_MODEL);
    let methods = dir.path().join("methods.txt");
    let out = Command::new("make")
        .args(["-C", "cpp", "check", "CXX=g++", "PROFILE=release"])
        .current_dir(&root)
        .env("CARGO_TARGET_DIR", &target)
        .env("ANISOBOND_BRIDGE_PACKING", &packing)
        .env("ANISOBOND_BRIDGE_MODEL", &model)
        .env("ANISOBOND_BRIDGE_OUT", &methods)
        .output()
        .expect("run make");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "make -C cpp check failed:\n{stdout}\n{stderr}"
    );
    assert!(
        stdout.contains(" passed, 0 failed"),
        "the C++ test did not report a clean pass:\n{stdout}"
    );
    // The bridge's laf and prestressed tensors are the library's, computed here in Rust.
    let text = std::fs::read_to_string(&methods).expect("the C++ test wrote methods.txt");
    let asm = Assembly::from_files(&packing, &model).unwrap();
    let mut seen = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let kind: MethodKind = words.next().unwrap().parse().unwrap();
        let cpp: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
        let want = asm
            .tensor(&MethodOptions::default().method(kind))
            .unwrap()
            .report
            .tensor();
        let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            scale > 1e9,
            "{kind}: a tensor of a bonded packing, got {want}"
        );
        for (k, c) in cpp.iter().enumerate() {
            let w = want[(k / 6, k % 6)];
            assert!(
                (c - w).abs() <= 1e-12 * scale,
                "{kind} C[{}][{}]: C++ {c:e}, Rust {w:e}",
                k / 6,
                k % 6
            );
        }
        assert_eq!(cpp.len(), 36, "{kind}");
        seen.push(kind);
    }
    assert_eq!(seen, [MethodKind::Laf, MethodKind::Prestressed]);
    // The example links and runs against the same library.
    let model = target.join("cpp").join("example_model.toml");
    std::fs::write(
        &model,
        "[scheme]\nkind = \"isotropic\"\nnormal = 1.0e6\nshear = 5.0e5\n[geometry]\nconvention = \"spring\"\n",
    )
    .unwrap();
    let ex = Command::new(target.join("cpp").join("example"))
        .arg(&model)
        .output()
        .expect("example");
    let text = String::from_utf8_lossy(&ex.stdout);
    assert!(ex.status.success(), "example failed: {text}");
    assert!(
        text.contains("k_n = 1e+06 N/m, k_s = 500000 N/m"),
        "example output: {text}"
    );
}
