//! Builds the C++ side (`make -C cpp check`: static library with the cxx bridge, example,
//! C++ test) and runs the C++ test, which checks the bridge against docs/references.md numbers
//! and closed forms. Skipped with a reason only when g++/make are absent and CI is unset.

use crate::common::{missing, root, target_dir};
use std::process::Command;

#[test]
fn cpp_bridge_test_builds_and_passes() {
    if let Some(reason) = missing(&["g++", "make"]) {
        eprintln!("skipping: {reason}");
        return;
    }
    let (root, target) = (root(), target_dir());
    let out = Command::new("make")
        .args(["-C", "cpp", "check", "CXX=g++", "PROFILE=release"])
        .current_dir(&root)
        .env("CARGO_TARGET_DIR", &target)
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
