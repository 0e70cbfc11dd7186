//! Issue 31, a user's LAMMPS `atom_style bpm/sphere` data file of a `boundary p p f` slab,
//! written in the test by LAMMPS itself (a 4 × 4 × 4 simple-cubic block, `create_bonds many`
//! with two bond types: no bond across the free z faces), read with `--boundary "p p f"` and
//! its Bonds section as the bond network, springs assigned, and exported by `export lammps`:
//! route (a) run on its own data.lmp, the plugin deck run on the user's file as it is. The
//! decks' boundary is `p p m`; LAMMPS' own bond count equals the file's, no atom is lost,
//! and C11, C22 match the closed form of the simple-cubic slab computed here from the bond
//! table and the box (Σ k_n l² n_x⁴ / V: under a stretch along x only the x rows stretch, and
//! every particle's two x bonds pull equally, so the affine state is the equilibrium).

use super::export::{export_cmd, one_lammps_at_a_time};
use super::plugin::{export_plugin, lammps};
use crate::common::lammps::lmp;
use crate::common::{succeeds, tmp, write, CUBIC_MODEL};
use std::path::Path;
use std::process::Command;

/// Spheres of diameter 1.9 mm on a 2 mm simple-cubic lattice (origin half a cell in) in a box
/// of 8 mm, periodic along x and y; bonds of type 1 in the lower half, type 2 otherwise.
const MAKE: &str = "units si\n\
dimension 3\n\
boundary p p f\n\
newton on off\n\
atom_style bpm/sphere\n\
special_bonds lj 0 1 1 coul 0 1 1\n\
comm_modify vel yes\n\
lattice sc 0.002 origin 0.5 0.5 0.5\n\
region box block 0 4 0 4 0 4\n\
create_box 1 box bond/types 2 extra/bond/per/atom 10 extra/special/per/atom 30\n\
create_atoms 1 box\n\
set type 1 diameter 0.0019\n\
set type 1 density 2600\n\
pair_style zero 0.0025\n\
pair_coeff * *\n\
bond_style bpm/rotational break no smooth no\n\
bond_coeff * 1 1 1 1 1 1 1 1 0 0 0 0\n\
region lower block INF INF INF INF INF 2 units lattice\n\
group lower region lower\n\
group upper subtract all lower\n\
create_bonds many lower lower 1 0.0019 0.0021\n\
create_bonds many upper all 2 0.0019 0.0021\n\
write_data user.data\n";

/// C_aa (Pa) of a bond table's simple-cubic slab: Σ (k_n n_a⁴ + k_s n_a²(1 − n_a²)) l² / V.
fn closed_form(table: &Path, axis: &str, volume: f64) -> f64 {
    let text = std::fs::read_to_string(table).unwrap();
    let mut lines = text.lines();
    let h: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| h.iter().position(|c| *c == n).unwrap();
    let (cn, ckn, cks, cl) = (col(axis), col("kn"), col("ks"), col("length"));
    lines
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            let n2 = f[cn] * f[cn];
            (f[ckn] * n2 * n2 + f[cks] * n2 * (1.0 - n2)) * f[cl] * f[cl]
        })
        .sum::<f64>()
        / volume
}

/// Run `run.sh 1 [DATA]` in `out` with `lmp`; LAMMPS' log and its tensor report.
fn run(out: &Path, lmp: &Path, data: Option<&Path>) -> (String, serde_json::Value) {
    let _one = one_lammps_at_a_time();
    let mut c = Command::new(out.join("run.sh"));
    c.arg("1").args(data).env("LMP", lmp);
    let r = c.output().unwrap();
    assert!(
        r.status.success(),
        "{}:\n{}\n{}",
        out.display(),
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
    let log = std::fs::read_to_string(out.join("log.lammps")).unwrap();
    let json = std::fs::read_to_string(out.join("lammps-tensor.json")).unwrap();
    (log, serde_json::from_str(&json).unwrap())
}

#[test]
fn a_p_p_f_bpm_sphere_data_file_exports_and_runs_on_the_users_file() {
    let Some(lmp) = lmp("a_p_p_f_bpm_sphere_data_file") else {
        return;
    };
    let t = tmp();
    let d = t.path();
    write(d, "in.make", MAKE);
    let made = Command::new(&lmp)
        .args(["-in", "in.make", "-log", "none"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stdout)
    );
    let data = d.join("user.data");
    let original = std::fs::read(&data).unwrap();
    // 64 atoms: 64 x, 64 y and 48 z bonds (none across the free z faces).
    assert!(String::from_utf8_lossy(&original).contains("176 bonds"));
    let model = write(d, "model.toml", CUBIC_MODEL);
    let boundary = ["--boundary", "p p f"];
    let v_box = 0.008f64.powi(3);

    // Route (a): its own data.lmp, one bond type per bond.
    let a = d.join("route-a");
    succeeds(&mut export_cmd(&data, &model, &boundary, &a));
    let (log, json) = run(&a, &lmp, None);
    assert!(
        log.contains("boundary p p m") && log.contains("  64 atoms"),
        "{log}"
    );
    assert!(log.contains("  176 bonds"), "{log}");
    assert_eq!(json["boundary"], "p p f");
    let c = |j: &serde_json::Value, r: usize, k: usize| j["C"][r][k].as_f64();
    assert!(c(&json, 0, 2).is_none() && c(&json, 0, 3).is_none() && c(&json, 0, 4).is_none());

    // The plugin deck on the user's file, unedited.
    let Some(l) = lammps("a_p_p_f_bpm_sphere_data_file (plugin)") else {
        return;
    };
    let plug = d.join("plugin");
    succeeds(export_plugin(&data, &model, &l.so, &plug).args(boundary));
    let table = plug.join("bonds.csv");
    let (c11, c22) = (
        closed_form(&table, "nx", v_box),
        closed_form(&table, "ny", v_box),
    );
    let (route_a, route_a_c66) = (
        [c(&json, 0, 0).unwrap(), c(&json, 1, 1).unwrap()],
        c(&json, 5, 5).unwrap(),
    );
    let (log, json) = run(&plug, &lmp, Some(&data));
    assert_eq!(
        std::fs::read(&data).unwrap(),
        original,
        "the user's file changed"
    );
    assert!(log.contains(&format!("read_data {} nocoeff", data.display())));
    assert!(
        log.contains("  176 bonds") && log.contains("  64 atoms"),
        "{log}"
    );
    let plugin = [c(&json, 0, 0).unwrap(), c(&json, 1, 1).unwrap()];
    eprintln!("closed form C11 = {c11:e}; route (a) {route_a:?}, plugin {plugin:?} Pa");
    for v in [route_a, plugin] {
        assert!((v[0] - c11).abs() < 1e-4 * c11, "{v:?} vs {c11}");
        assert!((v[1] - c22).abs() < 1e-4 * c22, "{v:?} vs {c22}");
    }
    // The in-plane shear, where the particles relax: the two bond styles agree.
    let shear = [c(&json, 5, 5).unwrap(), route_a_c66];
    eprintln!("C66: plugin, route (a) = {shear:?} Pa");
    assert!((shear[0] - shear[1]).abs() < 1e-3 * shear[1], "{shear:?}");
}
