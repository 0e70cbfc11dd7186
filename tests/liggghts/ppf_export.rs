//! Issue 31, mixed periodicity exported: LIGGGHTS' own `dump custom` of a `boundary p p f`
//! bed (written here by LIGGGHTS, [`super::dumps::bed`]: a 5 × 5 × 3 simple-cubic block,
//! periodic along x and y, walls along z) is read, bonded by the model's rule, springs
//! assigned, and exported to LIGGGHTS (stock harmonic deck and the driver deck), LAMMPS
//! (route a) and YADE; each deck runs unedited in its engine. The engines' own bond counts
//! equal anisobond's, no atom is lost, and the stiffness each measures along the periodic
//! axes matches the closed form of the simple-cubic slab computed here from the dump's box
//! and the bond table (C11 = Σ k_n l² n_x⁴ / V over the bonds, the box volume V as read:
//! under a stretch along x only the x rows stretch, and every particle's two x bonds pull
//! equally, so the affine state is the equilibrium), and the engines agree with each other
//! on the in-plane shear C66, where the particles do relax.

use super::dumps::bed;
use crate::common::lammps::lmp_with;
use crate::common::{cmd, succeeds, tmp, write, CUBIC_MODEL};
use std::path::Path;
use std::process::Command;

/// Run `program args…` in `dir`; its standard output, after asserting that it succeeded
/// and printed no ERROR.
fn run(dir: &Path, program: &Path, args: &[&str], env: &[(&str, &Path)]) -> String {
    let mut c = Command::new(program);
    c.args(args).current_dir(dir);
    for (k, v) in env {
        c.env(k, v);
    }
    let out = c.output().unwrap();
    let log = String::from_utf8_lossy(&out.stdout).to_string();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !log.contains("ERROR"),
        "{} {args:?} in {}:\n{log}\n{err}",
        program.display(),
        dir.display()
    );
    log
}

/// The rows of a CSV file as maps from column name to value.
fn csv(path: &Path) -> Vec<std::collections::HashMap<String, f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let h: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            h.iter()
                .cloned()
                .zip(l.split(',').map(|v| v.parse().unwrap()))
                .collect()
        })
        .collect()
}

/// The box volume (m³) of a dump's last `ITEM: BOX BOUNDS`, read here.
fn dump_box_volume(dump: &Path) -> f64 {
    let text = std::fs::read_to_string(dump).unwrap();
    let at = text.rfind("ITEM: BOX BOUNDS").unwrap();
    text[at..]
        .lines()
        .skip(1)
        .take(3)
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
            w[1] - w[0]
        })
        .product()
}

/// C_aa of the slab from the bond table: Σ (k_n n_a⁴ + k_s n_a²(1 − n_a²)) l² / V (Pa).
fn closed_form(table: &Path, axis: &str, volume: f64) -> f64 {
    csv(table)
        .iter()
        .map(|r| {
            let n2 = r[axis] * r[axis];
            (r["kn"] * n2 * n2 + r["ks"] * n2 * (1.0 - n2)) * r["length"] * r["length"]
        })
        .sum::<f64>()
        / volume
}

/// The last `stress_history.txt` row of each load case (the case ends), as maps.
fn case_ends(dir: &Path, ends: &[u64]) -> Vec<[f64; 13]> {
    let text = std::fs::read_to_string(dir.join("stress_history.txt")).unwrap();
    let rows: Vec<[f64; 13]> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
            std::array::from_fn(|k| w[k])
        })
        .collect();
    ends.iter()
        .map(|&e| {
            *rows
                .iter()
                .find(|r| r[0] as u64 == e)
                .expect("case end row")
        })
        .collect()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn a_p_p_f_dump_is_exported_to_liggghts_lammps_and_yade_and_runs_in_each() {
    let Some(lmp) = lmp_with(&["liggghts", "yade"]) else {
        return;
    };
    let t = tmp();
    let d = t.path();
    let (dump, _) = crate::common::liggghts::write_snapshot(d, "bed", &bed());
    let model = write(d, "model.toml", CUBIC_MODEL);
    let v_box = dump_box_volume(&dump);
    assert!(rel(v_box, 0.01 * 0.01 * 0.006) < 1e-12, "{v_box}");

    // LIGGGHTS: both decks of one export.
    let lig = d.join("lig");
    succeeds(&mut cmd(
        "export liggghts {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &model), ("o", &lig)],
    ));
    let table = lig.join("bonds.csv");
    let rows = csv(&table);
    assert_eq!(rows.len(), 200, "5 × 5 × 3: 75 x, 75 y and 50 z bonds");
    assert!(rows.iter().any(|r| r["ix"] != 0.0) && rows.iter().any(|r| r["iy"] != 0.0));
    assert!(
        rows.iter().all(|r| r["iz"] == 0.0),
        "no bond across the free z faces"
    );
    let c11 = closed_form(&table, "nx", v_box);
    let c22 = closed_form(&table, "ny", v_box);
    assert!(c11 > 0.0 && rel(c11, c22) < 1e-12);
    let deck = std::fs::read_to_string(lig.join("harmonic.in")).unwrap();
    assert!(deck.contains("boundary p p m"), "{deck}");
    let log = run(&lig, Path::new("liggghts"), &["-in", "harmonic.in"], &[]);
    assert!(
        log.contains("75 atoms") && log.contains("200 bonds"),
        "{log}"
    );
    // The stock deck runs the normal cases of the periodic axes: 11 and 22.
    let period = 500 + 10_000;
    let ends = case_ends(&lig, &[period, 2 * period]);
    let harmonic = [ends[0][7] / ends[0][1], ends[1][8] / ends[1][2]];
    eprintln!("LIGGGHTS harmonic C11, C22 = {harmonic:?} Pa, closed form {c11:e}");
    // Case 22 runs on the box stretched by case 11: its volume is 1 + ε larger (1e-6).
    assert!(rel(harmonic[0], c11) < 1e-5 && rel(harmonic[1], c22) < 1e-5);
    // The driver deck (full law): cases 11, 22, 12.
    let driver = crate::common::liggghts::driver();
    run(&lig, &driver, &["-in", "anisobond.in"], &[]);
    let ends = case_ends(&lig, &[period, 2 * period, 3 * period]);
    let driver_c11 = ends[0][7] / ends[0][1];
    let driver_c66 = ends[2][12] / ends[2][6];
    eprintln!("LIGGGHTS driver C11 = {driver_c11:e}, C66 = {driver_c66:e} Pa");
    assert!(rel(driver_c11, c11) < 1e-4, "{driver_c11} vs {c11}");

    // LAMMPS, route (a): its own data.lmp (the user's atom ids).
    let out = d.join("lmp");
    succeeds(&mut cmd(
        "export lammps {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &model), ("o", &out)],
    ));
    run(&out, Path::new("sh"), &["run.sh", "1"], &[("LMP", &lmp)]);
    let log = std::fs::read_to_string(out.join("log.lammps")).unwrap();
    assert!(
        log.contains("boundary p p m") && log.contains("  75 atoms"),
        "{log}"
    );
    assert!(log.contains("  200 bonds"), "LAMMPS' own bond count: {log}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("lammps-tensor.json")).unwrap())
            .unwrap();
    assert_eq!(json["boundary"], "p p f");
    let c = |r: usize, k: usize| json["C"][r][k].as_f64();
    for k in [2, 3, 4] {
        assert!(
            c(0, k).is_none(),
            "case {} strains a free axis: null",
            k + 1
        );
    }
    let (lammps_c11, lammps_c66) = (c(0, 0).unwrap(), c(5, 5).unwrap());
    eprintln!("LAMMPS C11 = {lammps_c11:e}, C66 = {lammps_c66:e} Pa");
    assert!(rel(lammps_c11, c11) < 1e-4, "{lammps_c11} vs {c11}");
    assert!(rel(c(1, 1).unwrap(), c22) < 1e-4);

    // YADE: the free axis extended; run.py's stresses per the box as read.
    let out = d.join("yade");
    succeeds(&mut cmd(
        "export yade {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &model), ("o", &out)],
    ));
    let log = run(&out, Path::new("yade"), &["-n", "-x", "run.py"], &[]);
    assert!(log.contains("75 particles, 200 bonds"), "{log}");
    let cell: Vec<f64> = std::fs::read_to_string(out.join("packing.txt"))
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("# periodic "))
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(&cell[..2], &[0.01, 0.01]);
    assert!(
        cell[2] > 0.006 + 2.0 * 0.0019,
        "the free axis extended: {cell:?}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("yade-tensor.json")).unwrap())
            .unwrap();
    // run.py reports stresses per the box as read (--stress-volume), not per YADE's cell.
    let volume = json["volume"].as_f64().unwrap();
    assert!(rel(volume, v_box) < 1e-12, "{volume} vs {v_box}");
    let col = |p: &str, k: usize| json["yade"]["columns"][p][k].as_f64().unwrap();
    assert_eq!(json["yade"]["paths"], serde_json::json!(["11", "22", "12"]));
    let (yade_c11, yade_c66) = (col("11", 0), col("12", 5));
    eprintln!("YADE C11 = {yade_c11:e}, C66 = {yade_c66:e} Pa (box volume)");
    assert!(rel(yade_c11, c11) < 1e-3, "{yade_c11} vs {c11}");

    // In-plane shear: three engines, three laws written apart, one slab.
    for (name, v) in [("YADE", yade_c66), ("LIGGGHTS driver", driver_c66)] {
        assert!(
            rel(v, lammps_c66) < 2e-3,
            "{name} C66 {v} vs LAMMPS {lammps_c66}"
        );
    }
}
