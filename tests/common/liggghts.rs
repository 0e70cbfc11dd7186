//! Shared helpers of the LIGGGHTS tests: tool discovery (skip with a reason when LIGGGHTS
//! or MPI is absent, never under CI), building the driver, and bonded test packings.
#![allow(dead_code)]

use anisobond::bonds::{self, BondSet, BondStiffness};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::packing::{generate, GenerateOptions};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

#[allow(unused_imports)]
pub use super::{missing, root, target_dir};

/// Build the driver once per test binary (`make -C cpp driver`) and return its path.
pub fn driver() -> PathBuf {
    static BUILT: OnceLock<std::result::Result<PathBuf, String>> = OnceLock::new();
    BUILT
        .get_or_init(|| {
            // CXX=g++ as in the `ffi` group's `make -C cpp check`: the staticlib's build script
            // reruns when CXX changes, so a different CXX would rebuild it (about a minute).
            let out = Command::new("make")
                .args(["-C", "cpp", "driver", "CXX=g++", "PROFILE=release"])
                .current_dir(root())
                .env("CARGO_TARGET_DIR", target_dir())
                .output()
                .map_err(|e| format!("cannot run make: {e}"))?;
            if !out.status.success() {
                return Err(format!(
                    "make -C cpp driver failed:\n{}\n{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
            Ok(target_dir().join("cpp").join("anisobond-liggghts"))
        })
        .clone()
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The driver (built by [`driver`]) on `mpi_processes` (`None`: one process, no MPI),
/// without `-var` pairs.
pub fn driver_launch(mpi_processes: Option<usize>) -> anisobond::export::liggghts::Launch {
    anisobond::export::liggghts::Launch {
        program: driver(),
        mpi_processes,
        vars: vec![],
    }
}

pub struct Bonded {
    pub packing: Packing,
    pub bonds: BondSet,
    pub k: BondStiffness,
}

/// A seeded periodic packing of `n` spheres (R̄ = 1 mm, φ = 0.6), bonded by `model_toml`.
pub fn bonded(n: usize, seed: u64, model_toml: &str) -> Bonded {
    let opts = GenerateOptions {
        n_particles: n,
        seed,
        ..GenerateOptions::default()
    };
    let packing = generate(&opts, &|_| {}).expect("packing");
    let model = Model::from_toml_str(model_toml, "<test model>").expect("model");
    let bonds = bonds::build_bonds(&packing, model.bonding).expect("bonds");
    let scheme = model
        .build_scheme(Some((&packing, &bonds)))
        .expect("scheme");
    let k = bonds::assign_stiffness(&packing, &bonds, scheme.as_ref(), &model.geometry)
        .expect("springs");
    Bonded { packing, bonds, k }
}

/// Largest |a − b| over the entries, relative to the largest |b|.
pub fn rel_diff(a: &anisobond::tensor::Stiffness6, b: &anisobond::tensor::Stiffness6) -> f64 {
    (a - b).abs().max() / b.abs().max()
}

/// The largest difference of two stress histories (rows of six components), and the largest
/// |σ| of the first: the scale it is judged against.
pub fn history_difference(a: &[[f64; 6]], b: &[[f64; 6]]) -> (f64, f64) {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .zip(b)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0f64, f64::max);
    (worst, scale)
}

pub fn fresh_dir(name: &str) -> PathBuf {
    let d = target_dir().join("liggghts-tests").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("test dir");
    d
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}

/// Run the stock `liggghts` on the repository's deck `tests/liggghts/DECK` in `dir` with
/// `-var NAME VALUE` pairs; asserts it succeeded without an ERROR line and returns its log.
pub fn run_stock_deck(dir: &Path, deck: &str, vars: &[(&str, &str)]) -> String {
    let mut c = Command::new("liggghts");
    for (name, value) in vars {
        c.args(["-var", name, value]);
    }
    let out = c
        .arg("-in")
        .arg(crate::common::root().join("tests/liggghts").join(deck))
        .current_dir(dir)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success() && !log.contains("ERROR"), "{log}");
    log
}

/// The end of a deck that writes a LIGGGHTS snapshot of its spheres as they are: diameter
/// 1.9 mm, density 2500 kg/m³, a Hertz granular pair style, one step, then `NAME.dump`
/// (`dump custom`: id type x y z radius, full precision) and `NAME.data` (`write_data`).
pub fn snapshot_tail(name: &str) -> String {
    format!(
        "set group all diameter 0.0019 density 2500\n\
         pair_style gran model hertz tangential history\n\
         pair_coeff * *\n\
         fix m1 all property/global youngsModulus peratomtype 1e7\n\
         fix m2 all property/global poissonsRatio peratomtype 0.3\n\
         fix m3 all property/global coefficientRestitution peratomtypepair 1 0.5\n\
         fix m4 all property/global coefficientFriction peratomtypepair 1 0.5\n\
         fix integr all nve/sphere\n\
         timestep 1e-6\n\
         dump d all custom 1 {name}.dump id type x y z radius\n\
         dump_modify d format \"%d %d %.17g %.17g %.17g %.17g\"\n\
         run 1\n\
         write_data {name}.data\n"
    )
}

/// Write `deck` as `dir/NAME.in` and run the stock `liggghts` on it in `dir`; asserts it
/// succeeded without an ERROR line. Returns the snapshot's `(NAME.dump, NAME.data)` (a deck
/// ending in [`snapshot_tail`]).
pub fn write_snapshot(dir: &Path, name: &str, deck: &str) -> (PathBuf, PathBuf) {
    std::fs::write(dir.join(format!("{name}.in")), deck).unwrap();
    let out = Command::new("liggghts")
        .arg("-in")
        .arg(format!("{name}.in"))
        .current_dir(dir)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && !log.contains("ERROR"), "{log}");
    (
        dir.join(format!("{name}.dump")),
        dir.join(format!("{name}.data")),
    )
}
