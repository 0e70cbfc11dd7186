//! `export lammps --types K`: the springs quantised into at most K bond types. The reported
//! tensor error is recomputed here from the files LAMMPS reads (data.lmp's bond types and
//! bond_coeffs.lmp's springs, put into a bond table for `tensor --bonds`); one type is exact
//! for a model whose bonds all have the same springs, and K ≥ the distinct spring sets is
//! exact; K = 0 or not a number is refused naming `--types`; the relaxed clustering weights
//! satisfy the energy identity Σ k·w = V trace C against the `tensor` command; the quantised
//! deck run by `lmp` gives the relaxed tensor of the quantised network within 1e-4.

use super::export::{
    export_cmd, lammps_tensor, max_relative, one_lammps_at_a_time, relaxed, CROSS, ROTATED_CUBIC,
};
use crate::common::lammps::lmp;
use crate::common::{bin, packing, stderr, succeeds, tmp, write};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// `export lammps PACKING --model MODEL --types K -o DIR`; returns bond-types.json.
fn export_types(pk: &Path, model: &Path, k: &str, dir: &Path) -> serde_json::Value {
    let out = succeeds(&mut export_cmd(pk, model, &["--types", k], dir));
    eprintln!("{}", out.lines().last().unwrap_or(""));
    serde_json::from_str(&std::fs::read_to_string(dir.join("bond-types.json")).unwrap()).unwrap()
}

/// The bond table of `pk` and `model` (`anisobond bonds`).
fn exact_table(dir: &Path, pk: &Path, model: &Path) -> PathBuf {
    let table = dir.join("exact.csv");
    succeeds(
        bin()
            .arg("bonds")
            .arg(pk)
            .arg("--model")
            .arg(model)
            .arg("-o")
            .arg(&table),
    );
    table
}

/// The springs of each bond as LAMMPS gets them, read from the export: bond b's type from
/// data.lmp's `Bonds`, the type's `k_r k_s k_t k_b` from bond_coeffs.lmp, in anisobond's
/// order `[k_n, k_s, k_r, k_tw]`; with each bond's (i, j), 0-based. Also the number of types.
fn springs_from_export(dir: &Path) -> (Vec<(usize, usize, [f64; 4])>, usize) {
    let coeffs = std::fs::read_to_string(dir.join("bond_coeffs.lmp")).unwrap();
    let mut by_type = std::collections::HashMap::new();
    for line in coeffs.lines().filter(|l| l.starts_with("bond_coeff")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let v = |i: usize| f[i].parse::<f64>().unwrap();
        // bond_coeff T k_r k_s k_t k_b …: anisobond k_n = k_r, k_s, k_tw = k_t, k_r = k_b.
        by_type.insert(f[1].parse::<usize>().unwrap(), [v(2), v(3), v(5), v(4)]);
    }
    let data = std::fs::read_to_string(dir.join("data.lmp")).unwrap();
    let types: usize = data
        .lines()
        .find(|l| l.ends_with(" bond types"))
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(by_type.len(), types, "one bond_coeff line per bond type");
    let section = data.split("\nBonds\n").nth(1).unwrap();
    let bonds = section
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<usize> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            (f[2] - 1, f[3] - 1, by_type[&f[1]])
        })
        .collect();
    (bonds, types)
}

/// The exact bond table with every bond's springs replaced by the export's; returns the
/// table's path and, per spring, the largest relative error (computed here: |q − k|/k, and
/// for k = 0 relative to the largest k of that spring).
fn quantised_table(dir: &Path, exact: &Path, export: &Path) -> (PathBuf, [f64; 4], usize) {
    let (springs, types) = springs_from_export(export);
    let text = std::fs::read_to_string(exact).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert!(header.starts_with("i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw"));
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), springs.len(), "one data.lmp bond per table row");
    let mut max = [0.0f64; 4];
    for r in &rows {
        for (c, m) in max.iter_mut().enumerate() {
            *m = m.max(r[7 + c].parse::<f64>().unwrap());
        }
    }
    let mut err = [0.0f64; 4];
    let mut out = format!("{header}\n");
    for (r, (i, j, q)) in rows.iter().zip(&springs) {
        assert_eq!(
            (
                r[0].parse::<usize>().unwrap(),
                r[1].parse::<usize>().unwrap()
            ),
            (*i, *j)
        );
        let mut r = r.clone();
        for c in 0..4 {
            let k: f64 = r[7 + c].parse().unwrap();
            let scale = if k > 0.0 { k } else { max[c] };
            if scale > 0.0 {
                err[c] = err[c].max((q[c] - k).abs() / scale);
            }
            r[7 + c] = format!("{:?}", q[c]);
        }
        out.push_str(&r.join(","));
        out.push('\n');
    }
    let path = dir.join("quantised.csv");
    std::fs::write(&path, out).unwrap();
    (path, err, types)
}

fn bonds_arg(table: &Path) -> [&OsStr; 2] {
    [OsStr::new("--bonds"), table.as_os_str()]
}

#[test]
fn reported_error_is_the_relaxed_difference_of_the_quantised_bond_table() {
    let dir = tmp();
    let pk = packing(dir.path(), 1000);
    for (name, text, k) in [("cubic", ROTATED_CUBIC, "16"), ("cross", CROSS, "8")] {
        let sub = dir.path().join(name);
        std::fs::create_dir(&sub).unwrap();
        let model = write(&sub, "model.toml", text);
        let export = sub.join("export");
        let report = export_types(&pk, &model, k, &export);
        let exact = exact_table(&sub, &pk, &model);
        let (table, spring_err, types) = quantised_table(&sub, &exact, &export);
        assert_eq!(report["exact"], false);
        assert_eq!(report["types"].as_u64().unwrap() as usize, types);
        assert!(types <= k.parse().unwrap() && types > 1);
        let c = relaxed(&sub, "exact.json", &pk, &model, &bonds_arg(&exact));
        let c_q = relaxed(&sub, "quantised.json", &pk, &model, &bonds_arg(&table));
        let here = max_relative(&c_q, &c);
        let reported = report["tensor_error"].as_f64().unwrap();
        eprintln!("{name}, {types} types: tensor error reported {reported:.6e}, here {here:.6e}");
        assert!(
            here > 1e-4,
            "{name}: the quantisation changes the tensor ({here:e})"
        );
        // Both solved by CG to 1e-10 (tensor error ~ its square).
        assert!(
            (reported - here).abs() < 1e-8,
            "{name}: {reported:e} vs {here:e}"
        );
        let e = &report["spring_max_relative_error"];
        for (c, key) in ["kn", "ks", "kr", "ktw"].iter().enumerate() {
            let r = e[key].as_f64().unwrap();
            assert!(
                (r - spring_err[c]).abs() <= 1e-12 * spring_err[c].max(1.0),
                "{name} {key}: {r:e} vs {:e}",
                spring_err[c]
            );
        }
        // The files say the same as the report.
        for f in ["params.lmp", "in.elastic"] {
            let t = std::fs::read_to_string(export.join(f)).unwrap();
            assert!(t.contains(&format!("max|ΔC|/max|C| = {reported}")), "{f}");
        }
    }
}

#[test]
fn one_type_is_exact_when_every_bond_has_the_same_springs() {
    // Isotropic scheme, springs in N/m: every bond's springs the same.
    let iso = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\n\
               normal = 2.0e5\nshear = 6.0e4\n[geometry]\nconvention = \"spring\"\n";
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", iso);
    let export = dir.path().join("export");
    let report = export_types(&pk, &model, "1", &export);
    assert_eq!(report["exact"], true);
    assert_eq!(report["types"], 1);
    assert_eq!(report["distinct_springs"], 1);
    assert_eq!(report["tensor_error"], 0.0);
    let (springs, types) = springs_from_export(&export);
    assert_eq!(types, 1);
    assert!(springs
        .iter()
        .all(|(_, _, q)| *q == [2.0e5, 6.0e4, 0.0, 0.0]));
    // Its relaxed tensor is the exact one.
    let exact = exact_table(dir.path(), &pk, &model);
    let (table, err, _) = quantised_table(dir.path(), &exact, &export);
    assert_eq!(err, [0.0; 4]);
    let c = relaxed(dir.path(), "exact.json", &pk, &model, &bonds_arg(&exact));
    let c_q = relaxed(dir.path(), "q.json", &pk, &model, &bonds_arg(&table));
    assert_eq!(max_relative(&c_q, &c), 0.0);
}

#[test]
fn types_at_least_the_distinct_spring_sets_keep_every_bond_exact() {
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    let export = dir.path().join("export");
    let out = succeeds(&mut export_cmd(
        &pk,
        &model,
        &["--types", "4000000000"],
        &export,
    ));
    assert!(
        out.contains("every bond's springs exact, no tensor error"),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("bond-types.json")).unwrap())
            .unwrap();
    assert_eq!(report["exact"], true);
    assert_eq!(report["tensor_error"], 0.0);
    let exact = exact_table(dir.path(), &pk, &model);
    let (_, err, types) = quantised_table(dir.path(), &exact, &export);
    assert_eq!(err, [0.0; 4], "every bond keeps its springs bit for bit");
    assert_eq!(report["types"].as_u64().unwrap() as usize, types);
    assert_eq!(report["distinct_springs"].as_u64().unwrap() as usize, types);
}

#[test]
fn types_zero_or_not_a_number_is_refused_naming_the_option() {
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    for bad in ["0", "-3", "two", "1.5", ""] {
        let export = dir.path().join("export");
        let out = export_cmd(&pk, &model, &["--types", bad], &export)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "--types {bad:?}");
        let err = stderr(&out);
        assert!(err.contains("--types"), "--types {bad:?}: {err}");
        assert!(!export.exists(), "--types {bad:?} wrote the export");
    }
}

#[test]
fn quantised_deck_gives_the_relaxed_tensor_of_the_quantised_network() {
    let Some(lmp) = lmp("quantised_deck") else {
        return;
    };
    let _alone = one_lammps_at_a_time();
    let dir = tmp();
    let pk = packing(dir.path(), 1000);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    let c_lammps = lammps_tensor(&lmp, dir.path(), &pk, &model, 1, &["--types", "16"]);
    let export = dir.path().join("lammps-np1");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("bond-types.json")).unwrap())
            .unwrap();
    let exact = exact_table(dir.path(), &pk, &model);
    let (table, _, types) = quantised_table(dir.path(), &exact, &export);
    let c_q = relaxed(dir.path(), "q.json", &pk, &model, &bonds_arg(&table));
    let c = relaxed(dir.path(), "exact.json", &pk, &model, &bonds_arg(&exact));
    let d = max_relative(&c_lammps, &c_q);
    let reported = report["tensor_error"].as_f64().unwrap();
    let from_exact = max_relative(&c_lammps, &c);
    eprintln!(
        "{types} types: max |C_lammps − C_quantised| / max |C_quantised| = {d:.2e}; against the \
         exact springs {from_exact:.2e} (reported quantisation error {reported:.2e})"
    );
    assert!(d < 1e-4, "{d:e}");
    // LAMMPS ran the quantised network, not the exact one.
    assert!(reported > 1e-3 && (from_exact - reported).abs() < 2e-4);
}

#[test]
fn relaxed_weights_sum_to_the_trace_of_the_relaxed_tensor() {
    // At equilibrium the energy under unit strain a is ½ V C_aa = ½ Σ_b Σ_c k_b,c δ_b,c,a²,
    // so Σ_b Σ_c k_b,c w_b,c = V · trace(C): here against the `tensor` command's C.
    use anisobond::homogenize::LeverArm;
    use anisobond::homogenize::RelaxedOptions;
    let dir = tmp();
    let pk = packing(dir.path(), 1000);
    for (name, text) in [("cubic", ROTATED_CUBIC), ("cross", CROSS)] {
        let sub = dir.path().join(name);
        std::fs::create_dir(&sub).unwrap();
        let model = write(&sub, "model.toml", text);
        let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
        let opts = RelaxedOptions {
            lever_arm: LeverArm::HalfLength,
            tolerance: 1e-10,
            ..Default::default()
        };
        let (w, _) =
            anisobond::bonds::sensitivity_weights(&asm.packing, &asm.bonds, &asm.springs, &opts)
                .unwrap();
        let k = &asm.springs;
        let energy: f64 = (0..w.len())
            .map(|b| w[b][0] * k.kn[b] + w[b][1] * k.ks[b] + w[b][2] * k.kr[b] + w[b][3] * k.ktw[b])
            .sum();
        let c = relaxed(&sub, "relaxed.json", &pk, &model, &[]);
        let trace: f64 = (0..6).map(|a| c[a][a]).sum();
        let here = energy / asm.packing.volume();
        eprintln!("{name}: Σ k·w / V = {here:.9e} Pa, trace C = {trace:.9e} Pa");
        assert!(
            (here - trace).abs() < 1e-8 * trace,
            "{name}: {here:e} vs {trace:e}"
        );
        // The rotational springs take part (cubic: parallel-bond moments).
        if name == "cubic" {
            assert!(w.iter().any(|x| x[2] > 0.0 && x[3] > 0.0));
        }
    }
}
