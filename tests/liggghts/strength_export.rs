//! `export liggghts` of a model with `[strength]` gives the driver deck breakable bonds
//! (issue 32 item 5) and the pair style's `breaks FILE` says which bond broke when, the same
//! on one and two processes. A periodic simple-cubic lattice 3 × 3 × 4 of touching spheres
//! (R = 1 mm, spacing d = 2R, 108 bonds: 36 along each axis), isotropic springs, every bond
//! σ_t = 5 MPa (YADE's a_n = σ_t R² = 5 N), exported with `--no-shear` and a strain increment
//! 2.003 times the x bonds' breaking strain, run by the driver in the test.
//!
//! Compared against the closed form: in load case 11 the lattice stays affine (every sphere
//! alike), so the x bonds all reach a_n on the same step and σ11 peaks at the bonds per
//! section × a_n over the section, 9 a_n / (3d)², before they break; the record lists those
//! 36 x-neighbour pairs (found from the positions, independently of the export), all in
//! tension, on one step, sorted by ids; the file is byte-identical on -np 1 and -np 2. The
//! same model without `[strength]`: no adhesion columns, no `breaks`, σ11 passes the limit.

use crate::common::liggghts::*;
use crate::common::{bin, succeeds, write};
use anisobond::export::liggghts::run_liggghts;
use std::path::Path;

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];
const R: f64 = 1e-3;
const D: f64 = 2.0 * R;
const N: [usize; 3] = [3, 3, 4];
const KN: f64 = 2e6;
const TENSILE: f64 = 5e6;
const DEFORM: u64 = 2000;

fn model(strength: bool) -> String {
    let mut m = format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
         normal = {KN:e}\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n"
    );
    if strength {
        m.push_str(&format!(
            "[strength]\n[strength.bond]\ntensile = {TENSILE:e}\ncohesion = 1e8\nfriction = 0.5\n"
        ));
    }
    m
}

/// The lattice's centres, atom id k + 1 for row k.
fn sites() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for k in 0..N[2] {
        for j in 0..N[1] {
            for i in 0..N[0] {
                out.push([
                    (i as f64 + 0.5) * D,
                    (j as f64 + 0.5) * D,
                    (k as f64 + 0.5) * D,
                ]);
            }
        }
    }
    out
}

/// Export `model` into `dir/out` with the strain `strain` over [`DEFORM`] steps.
fn export(dir: &Path, model: &Path, strain: f64) -> std::path::PathBuf {
    let out = dir.join("out");
    let _ = std::fs::remove_dir_all(&out);
    succeeds(
        bin()
            .args(["export", "liggghts"])
            .arg(dir.join("lattice.txt"))
            .arg("--model")
            .arg(model)
            .args(["--no-shear", "--every", "1", "--relax-steps", "100"])
            .args(["--deform-steps", &DEFORM.to_string()])
            .args(["--strain", &format!("{strain:e}")])
            .arg("-o")
            .arg(&out),
    );
    out
}

/// Run the driver deck in `out` on `np` processes; the largest σ11 of load case 11 (Pa).
fn run(out: &Path, np: usize) -> f64 {
    let log = run_liggghts(&driver_launch((np > 1).then_some(np)), out, "anisobond.in")
        .expect("driver run");
    if np > 1 {
        assert!(log.contains("MPI processor grid"), "{log}");
    }
    let text = std::fs::read_to_string(out.join("stress_history.txt")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            (w[0], w[7])
        })
        .filter(|&(step, _)| step <= (DEFORM + 100) as f64)
        .map(|(_, s11)| s11)
        .fold(f64::MIN, f64::max)
}

#[test]
fn exported_deck_breaks_the_bonds_at_the_closed_form_load_on_one_and_two_processes() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("strength_export");
    let s = sites();
    let l = [N[0] as f64 * D, N[1] as f64 * D, N[2] as f64 * D];
    let mut text = format!("# periodic {:?} {:?} {:?}\n", l[0], l[1], l[2]);
    for p in &s {
        text.push_str(&format!("{:?} {:?} {:?} {R:?}\n", p[0], p[1], p[2]));
    }
    write(&dir, "lattice.txt", &text);
    let strong = write(&dir, "strong.toml", &model(true));
    let plain = write(&dir, "plain.toml", &model(false));
    let a_n = TENSILE * R * R;
    let closed = 9.0 * a_n / (3.0 * D * 3.0 * D);
    // Not a whole number of steps to the break: the x bonds then all pass a_n on one step.
    let strain = 2.003 * a_n / (KN * D);

    let out = export(&dir, &strong, strain);
    let table = std::fs::read_to_string(out.join("bonds.csv")).unwrap();
    assert!(
        table
            .lines()
            .next()
            .unwrap()
            .ends_with("normal_adhesion,shear_adhesion,tan_friction"),
        "{}",
        table.lines().next().unwrap()
    );
    let deck = std::fs::read_to_string(out.join("anisobond.in")).unwrap();
    assert!(deck.contains("breaks breaks.txt"), "{deck}");

    // The x-neighbour pairs (ids), periodic in x, from the positions.
    let mut x_pairs = Vec::new();
    for a in 0..s.len() {
        for b in a + 1..s.len() {
            let mut dx = (s[b][0] - s[a][0]).abs();
            dx = dx.min(l[0] - dx);
            if (dx - D).abs() < 1e-9 && s[a][1] == s[b][1] && s[a][2] == s[b][2] {
                x_pairs.push((a + 1, b + 1));
            }
        }
    }
    assert_eq!(x_pairs.len(), 36);

    let mut records = Vec::new();
    for np in [1, 2] {
        let peak = run(&out, np);
        let err = (peak - closed) / closed;
        let rec = std::fs::read_to_string(out.join("breaks.txt")).unwrap();
        let rows: Vec<(u64, usize, usize, String)> = rec
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                (
                    w[0].parse().unwrap(),
                    w[1].parse().unwrap(),
                    w[2].parse().unwrap(),
                    w[3].to_string(),
                )
            })
            .collect();
        println!(
            "np {np}: σ11 peak {peak:.9e} Pa vs 9 a_n / (3d)² = {closed:.9e} Pa: relative \
             {err:.2e}; {} breaks recorded, first at step {:?}",
            rows.len(),
            rows.first().map(|r| r.0)
        );
        assert!(
            err <= 1e-9 && err > -2e-3,
            "np {np}: peak {peak} vs {closed}"
        );
        // Load case 11: the 36 x bonds, all in tension, on one step, sorted by ids.
        let first: Vec<_> = rows.iter().take(36).collect();
        assert!(
            first.iter().all(|r| r.0 == first[0].0 && r.3 == "tension"),
            "{rec}"
        );
        let pairs: Vec<(usize, usize)> = first.iter().map(|r| (r.1, r.2)).collect();
        let mut sorted = pairs.clone();
        sorted.sort_unstable();
        assert_eq!(pairs, sorted, "{rec}");
        assert_eq!(sorted, x_pairs, "{rec}");
        assert!(first[0].0 <= DEFORM, "{rec}");
        records.push(rec);
    }
    assert_eq!(
        records[0], records[1],
        "the break records differ on -np 1 and -np 2"
    );

    // Without [strength]: unbreakable, σ11 goes on to twice the limit.
    let out = export(&dir, &plain, strain);
    let table = std::fs::read_to_string(out.join("bonds.csv")).unwrap();
    assert!(!table.contains("normal_adhesion"));
    assert!(!std::fs::read_to_string(out.join("anisobond.in"))
        .unwrap()
        .contains("breaks"));
    let peak = run(&out, 1);
    println!("plain model: σ11 reaches {peak:.6e} Pa");
    assert!(peak > 1.9 * closed, "{peak} vs {closed}");
    assert!(!out.join("breaks.txt").exists());
}
