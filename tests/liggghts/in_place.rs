//! `pair_style anisobond model MODEL.toml` without a packing file (issue 20, "LIGGGHTS, in
//! place"): LIGGGHTS itself makes the packing (`in_place_packing.in`: a perturbed fcc
//! lattice, ids with gaps, periodic box, `write_data`); the exported element-test deck is
//! pointed at that data file and at the in-place pair style, which bonds the atoms of the
//! first run through the library and writes the table it used (`write_bonds`). Checked
//! against independent values: the table is `anisobond bonds` of the same data file (byte for
//! byte on an orthogonal box; to 1e-12 after the six-case deck's `change_box all triclinic`,
//! which moves LIGGGHTS' positions by rounding), the six damped element tests give the
//! relaxed tensor of that table (`anisobond tensor --bonds`, mid-gap lever arms) within 1e-4
//! (measured 2.1e-6 rotated cubic, 2.5e-6 cross-anisotropic), and under `mpirun -np 2` (three
//! normal cases, orthogonal box) the table is byte-identical to the one-process table.
//! Skipped with a reason only when LIGGGHTS/MPI/make are absent and CI is unset.

use crate::common::liggghts::*;
use crate::common::{bin, CUBIC_MODEL};
use anisobond::assembly::Assembly;
use anisobond::export::liggghts::{
    columns_from_cases, export_liggghts, read_stress_history, run_liggghts, DeckOptions,
};
use anisobond::model::Model;
use anisobond::packing::{read_packing_as, CellChoice};
use anisobond::tensor::Stiffness6;
use std::path::{Path, PathBuf};

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];

/// The cubic model rotated off the lattice axes (every tensor entry non-zero), with
/// parallel-bond moments (k_r, k_tw > 0).
fn rotated_cubic() -> String {
    format!("{CUBIC_MODEL}euler_zyz_deg = [10, 20, 30]\n[geometry]\nmoments = \"parallel-bond\"\n")
}

/// Cross-anisotropic: μ (the lattice scaling) comes from the bonds the pair style draws.
const CROSS_MODEL: &str = "[bonding]\nrule = \"factor\"\nvalue = 1.1\n\
    [scheme]\nkind = \"cross-anisotropic\"\nC11 = 130e6\nC33 = 55e6\nC13 = 28e6\nC12 = 40e6\n\
    strike_deg = 270\ndip_deg = 25\n[geometry]\nconvention = \"modulus\"\nmoments = \"parallel-bond\"\n";

/// LIGGGHTS (stock) writes the user's packing `user.data` into `dir`.
fn user_packing(dir: &Path) -> PathBuf {
    run_stock_deck(dir, "in_place_packing.in", &[("name", "user.data")]);
    dir.join("user.data")
}

/// The exported element-test deck of `data` (time step and case ends from the library's
/// bonds of the same file: deck parameters only), rewritten to read the user's data file
/// and bond it in place: `pair_style anisobond model model.toml write_bonds inplace_bonds.csv`.
/// The exported bond table and data file are removed, so the run cannot use them.
fn in_place_deck(dir: &Path, data: &Path, model: &str, opts: &DeckOptions) -> Vec<u64> {
    let m = Model::from_toml_str(model, "<test model>").unwrap();
    let p = read_packing_as(data, CellChoice::Periodic).unwrap().packing;
    let asm = Assembly::new(p, m).unwrap();
    let sum = export_liggghts(dir, &asm.packing, &asm.bonds, &asm.springs, opts).unwrap();
    std::fs::write(dir.join("model.toml"), model).unwrap();
    std::fs::copy(data, dir.join("user.data")).unwrap();
    let deck = std::fs::read_to_string(dir.join("anisobond.in")).unwrap();
    assert!(deck.contains("read_data packing.data") && deck.contains("table bonds.csv"));
    let deck = deck
        .replace("read_data packing.data", "read_data user.data")
        .replace(
            "table bonds.csv",
            "model model.toml write_bonds inplace_bonds.csv",
        );
    std::fs::write(dir.join("anisobond.in"), deck).unwrap();
    std::fs::remove_file(dir.join("bonds.csv")).unwrap();
    std::fs::remove_file(dir.join("packing.data")).unwrap();
    sum.case_end_steps
}

fn run_driver(dir: &Path, np: Option<usize>) {
    let t0 = std::time::Instant::now();
    run_liggghts(&driver_launch(np), dir, "anisobond.in").expect("driver run");
    eprintln!(
        "{}: driver run (np {}) took {:.1} s",
        dir.display(),
        np.unwrap_or(1),
        t0.elapsed().as_secs_f64()
    );
}

/// `anisobond tensor DATA --model MODEL --bonds TABLE --method relaxed --periodic`.
fn relaxed_of_table(dir: &Path, table: &str) -> Stiffness6 {
    let out = dir.join("relaxed.json");
    let o = bin()
        .arg("tensor")
        .arg(dir.join("user.data"))
        .arg("--model")
        .arg(dir.join("model.toml"))
        .arg("--bonds")
        .arg(dir.join(table))
        .args(["--method", "relaxed", "--periodic", "--json", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let c: Vec<Vec<f64>> = serde_json::from_value(v["C"].clone()).unwrap();
    Stiffness6::from_fn(|i, j| c[i][j])
}

/// `anisobond bonds DATA --model MODEL --periodic`: the CLI's bonding of the same packing.
fn cli_bonds(dir: &Path) -> String {
    let out = dir.join("cli_bonds.csv");
    let o = bin()
        .arg("bonds")
        .arg(dir.join("user.data"))
        .arg("--model")
        .arg(dir.join("model.toml"))
        .args(["--periodic", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(out).unwrap()
}

/// The two SPEC tables (with `id_i,id_j`) have the same rows (particles, images, ids) and
/// every number agrees within `tol` relative (0: byte-identical text).
fn same_bonds(got: &str, want: &str, tol: f64) {
    if tol == 0.0 {
        assert!(got == want, "the bond tables differ");
        return;
    }
    let (g, w): (Vec<&str>, Vec<&str>) = (got.lines().collect(), want.lines().collect());
    assert_eq!(g.len(), w.len(), "bond tables of different lengths");
    assert_eq!(g[0], w[0]);
    let mut worst = 0.0f64;
    for (a, b) in g[1..].iter().zip(&w[1..]) {
        let (a, b): (Vec<&str>, Vec<&str>) = (a.split(',').collect(), b.split(',').collect());
        for k in [0, 1, 11, 12, 13, 14, 15] {
            assert_eq!(a[k], b[k], "row {a:?} vs {b:?}");
        }
        for k in 2..11 {
            let (x, y): (f64, f64) = (a[k].parse().unwrap(), b[k].parse().unwrap());
            // Normals (columns 2–4) absolutely, the rest relative to themselves.
            let scale = if k < 5 { 1.0 } else { y.abs() };
            worst = worst.max((x - y).abs() / scale);
        }
    }
    eprintln!(
        "bond tables: same {} rows, numbers within {worst:.1e}",
        g.len() - 1
    );
    assert!(
        worst <= tol,
        "bond table numbers differ by {worst:.1e} > {tol:e}"
    );
}

/// Largest |column − relaxed column| over the first `n` columns, relative to max |C|.
fn column_diff(cols: &[[f64; 6]], c: &Stiffness6) -> f64 {
    let mut d = 0.0f64;
    for (a, col) in cols.iter().enumerate() {
        for r in 0..6 {
            d = d.max((col[r] - c[(r, a)]).abs());
        }
    }
    d / c.abs().max()
}

/// Opts of the damped element tests: long holds so the damped relaxation reaches 1e-4.
fn opts(shear: bool) -> DeckOptions {
    DeckOptions {
        relax_steps: std::env::var("RELAX")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(10_000),
        shear,
        ..DeckOptions::default()
    }
}

/// One model: the six cases on one process, then (`mpi`) the three normal cases on two.
fn in_place_case(name: &str, model: &str, mpi: bool) {
    let base = fresh_dir(name);
    let data = user_packing(&base);
    let text = std::fs::read_to_string(&data).unwrap();
    assert!(
        text.contains("\n256 1 ") && !text.contains("\n5 1 "),
        "the user's ids must have gaps"
    );

    let dir = base.join("np1");
    std::fs::create_dir_all(&dir).unwrap();
    let ends = in_place_deck(&dir, &data, model, &opts(true));
    run_driver(&dir, None);
    let table = std::fs::read_to_string(dir.join("inplace_bonds.csv")).expect("write_bonds");
    assert!(table.lines().next().unwrap().ends_with(",id_i,id_j"));
    // `change_box all triclinic` (the six-case deck) round-trips LIGGGHTS' positions
    // through its lamda coordinates: the same bonds, numbers equal to rounding.
    same_bonds(&table, &cli_bonds(&dir), 1e-12);
    let h = read_stress_history(&dir.join("stress_history.txt")).unwrap();
    let cols = columns_from_cases(&h, &ends).unwrap();
    let relaxed = relaxed_of_table(&dir, "inplace_bonds.csv");
    let d = column_diff(&cols, &relaxed);
    eprintln!(
        "{name}: {} bonds; six element tests vs relaxed of the written table: {d:.3e}\nrelaxed:\n{relaxed:.4e}",
        table.lines().count() - 1
    );
    assert!(
        d < 1e-4,
        "{name}: in-place tensor vs relaxed {d:.3e} > 1e-4"
    );

    if mpi {
        // The three normal cases on an orthogonal box (LIGGGHTS 3.8 makes no ghosts for a
        // triclinic box under MPI), on one and on two processes.
        let mut tables = Vec::new();
        for np in [1usize, 2] {
            let dir = base.join(format!("normal_np{np}"));
            std::fs::create_dir_all(&dir).unwrap();
            let ends = in_place_deck(&dir, &data, model, &opts(false));
            run_driver(&dir, Some(np));
            let table = std::fs::read_to_string(dir.join("inplace_bonds.csv")).unwrap();
            let h = read_stress_history(&dir.join("stress_history.txt")).unwrap();
            let cols = columns_from_cases(&h, &ends).unwrap();
            assert_eq!(cols.len(), 3);
            let d = column_diff(&cols, &relaxed_of_table(&dir, "inplace_bonds.csv"));
            eprintln!("{name}: -np {np}, three normal cases vs relaxed: {d:.3e}");
            assert!(
                d < 1e-4,
                "{name}: -np {np} normal columns vs relaxed {d:.3e}"
            );
            tables.push(table);
        }
        // Without the triclinic round trip the positions are the data file's: the table is
        // the CLI's to the byte, on one process and on two.
        same_bonds(&tables[0], &cli_bonds(&base.join("normal_np1")), 0.0);
        same_bonds(&tables[1], &tables[0], 0.0);
    }
}

#[test]
fn in_place_rotated_cubic_matches_relaxed_tensor_serial_and_mpi() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    in_place_case("in_place_cubic", &rotated_cubic(), true);
}

#[test]
fn in_place_cross_anisotropic_mu_from_its_own_bonds_matches_relaxed_tensor() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    in_place_case("in_place_cross", CROSS_MODEL, false);
}

/// The in-place form refuses what it cannot bond as the CLI would, with the reason: a box
/// periodic along some directions only, `write_bonds` with a given bond table, and bonding
/// again in a run continued from a restart file.
#[test]
fn in_place_refuses_mixed_periodicity_write_bonds_with_a_table_and_restarts() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("in_place_refusals");
    std::fs::write(dir.join("model.toml"), rotated_cubic()).unwrap();
    std::fs::write(
        dir.join("bonds.csv"),
        "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz\n0,1,1,0,0,0.0021,0.001,1,1,1,1,0,0,0\n",
    )
    .unwrap();
    let deck = |boundary: &str, style: &str| {
        format!(
            "units si\natom_style granular\natom_modify map array\nboundary {boundary}\n\
             newton on\ncommunicate single vel yes\n\
             region box block 0 0.01 0 0.01 0 0.01 units box\ncreate_box 1 box\n\
             lattice sc 0.002\ncreate_atoms 1 box\nset group all diameter 0.0019 density 2500\n\
             pair_style anisobond {style}\npair_coeff * *\ntimestep 1e-8\nrun 0\n"
        )
    };
    for (name, boundary, style, want) in [
        (
            "mixed.in",
            "p p f",
            "model model.toml",
            "periodic along x and y only",
        ),
        (
            "table.in",
            "p p p",
            "table bonds.csv write_bonds out.csv",
            "write_bonds is for the in-place form",
        ),
    ] {
        std::fs::write(dir.join(name), deck(boundary, style)).unwrap();
        let launch = driver_launch(None);
        let e = run_liggghts(&launch, &dir, name).unwrap_err().to_string();
        assert!(e.contains(want), "{name}: expected `{want}` in: {e}");
        assert!(!dir.join("out.csv").exists());
    }
    // A run continued from a restart file holding the bond state: bonding again where the
    // atoms are then would be another network; refused before write_bonds writes anything.
    let first = deck("p p p", "model model.toml write_bonds first.csv").replace(
        "run 0\n",
        "fix integ all nve/sphere\nvelocity all set 1e-3 -2e-3 5e-4\nrun 20\nwrite_restart r.restart\n",
    );
    std::fs::write(dir.join("first.in"), first).unwrap();
    std::fs::write(
        dir.join("again.in"),
        "atom_modify map array\nread_restart r.restart\nnewton on\ncommunicate single vel yes\n\
         pair_style anisobond model model.toml write_bonds again.csv\npair_coeff * *\nrun 0\n",
    )
    .unwrap();
    let launch = driver_launch(None);
    run_liggghts(&launch, &dir, "first.in").unwrap();
    assert!(dir.join("first.csv").exists() && dir.join("r.restart").exists());
    let e = run_liggghts(&launch, &dir, "again.in")
        .unwrap_err()
        .to_string();
    assert!(e.contains("continued from a restart file"), "{e}");
    assert!(!dir.join("again.csv").exists());
}
