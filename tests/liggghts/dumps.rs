//! LIGGGHTS 3.8's own `dump custom` snapshots read as written (issue 31): the same deck writes
//! a dump (`id type x y z radius`, two snapshots) and a data file of the final state, in a
//! periodic and in a walled box. The dump is read as the data file is (same ids, positions,
//! radii; the periodic box as the cell, the walled box as a free cluster, from the dump's
//! own boundary flags), and bonded by the command. A `boundary p p f` bed's dump is read with
//! its box periodic along x and y only and bonded across those faces only.

use crate::common::liggghts::*;
use crate::common::{cmd, fails, missing, succeeds, tmp, write, CUBIC_MODEL};
use anisobond::packing::{read_packing, read_packing_as, CellChoice};

#[test]
fn liggghts_dump_custom_reads_as_its_data_file() {
    if let Some(r) = missing(&["liggghts"]) {
        assert!(std::env::var_os("CI").is_none(), "CI without liggghts: {r}");
        eprintln!("skipping: {r}");
        return;
    }
    let t = tmp();
    let d = t.path();
    for (boundary, periodic) in [("p", true), ("f", false)] {
        let (data, dump) = (
            format!("box-{boundary}.data"),
            format!("box-{boundary}.dump"),
        );
        let vars = [
            ("b", boundary),
            ("zh", "0.01"),
            ("dx", "0.0015"),
            ("name", data.as_str()),
            ("dump", dump.as_str()),
        ];
        run_stock_deck(d, "write_dump.in", &vars);
        let choice = if periodic {
            CellChoice::Periodic
        } else {
            CellChoice::Free
        };
        let from_data = read_packing_as(&d.join(&data), choice).unwrap().packing;
        let from_dump = read_packing(&d.join(&dump)).unwrap();
        assert_eq!(from_dump.cell.is_some(), periodic, "boundary {boundary}");
        assert_eq!(from_dump.ids, from_data.ids, "ids, boundary {boundary}");
        assert_eq!(from_dump.len(), from_data.len());
        let scale = 0.01;
        for k in 0..from_dump.len() {
            let dx = (from_dump.positions[k] - from_data.positions[k]).norm();
            assert!(
                dx <= 1e-14 * scale,
                "boundary {boundary}, atom {k}: {dx:e} m apart"
            );
            assert_eq!(from_dump.radii[k], from_data.radii[k]);
        }
        if periodic {
            assert_eq!(
                from_dump.cell.unwrap().lengths,
                from_data.cell.unwrap().lengths
            );
        }
        // Bonded by the command as it is, and the same bonds as the data file's.
        let m = write(d, "model.toml", CUBIC_MODEL);
        let (b1, b2) = (d.join("dump.csv"), d.join("data.csv"));
        let dump_path = d.join(&dump);
        let data_path = d.join(&data);
        succeeds(&mut cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &dump_path), ("m", &m), ("o", &b1)],
        ));
        let flag = if periodic { "--periodic" } else { "--free" };
        let mut c = cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &data_path), ("m", &m), ("o", &b2)],
        );
        c.arg(flag);
        succeeds(&mut c);
        let rows = |p: &std::path::Path| std::fs::read_to_string(p).unwrap().lines().count();
        assert_eq!(rows(&b1), rows(&b2), "bond rows, boundary {boundary}");
        // The dump states its boundary: a contradicting option is refused.
        let other = if periodic { "--free" } else { "--periodic" };
        let mut c = cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &dump_path), ("m", &m), ("o", &d.join("x.csv"))],
        );
        c.arg(other);
        let err = fails(&mut c);
        assert!(err.contains("BOX BOUNDS"), "{err}");
        // The real dump cut after every line: read (a whole first snapshot) or refused with
        // a line number, never a panic.
        let text = std::fs::read_to_string(&dump_path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for cut in 0..lines.len() {
            let part = lines[..cut].join("\n");
            let _ = anisobond::packing::parse_packing(&part, "cut.dump");
        }
    }
}

/// A settled bed's deck: `boundary p p f`, a 5 × 5 × 3 simple-cubic block of spheres
/// (diameter 1.9 mm, spacing 2 mm) filling a box of 10 × 10 × 6 mm: across the x and y faces
/// the rows continue; across the z faces (walls) the bottom and top layers would be
/// neighbours too if z were periodic. LIGGGHTS writes a `dump custom` and a data file.
pub(super) fn bed() -> String {
    format!(
        "units si\n\
         atom_style granular\n\
         atom_modify map array\n\
         boundary p p f\n\
         newton off\n\
         communicate single vel yes\n\
         region box block 0 0.01 0 0.01 0 0.006 units box\n\
         create_box 1 box\n\
         lattice sc 0.002\n\
         region fill block 0 0.0099 0 0.0099 0 0.0059 units box\n\
         create_atoms 1 region fill\n\
         displace_atoms all move 0.0005 0.0005 0.001 units box\n\
         {}",
        crate::common::liggghts::snapshot_tail("bed")
    )
}

/// The bonds of a bond table by atom ids (smaller first), with their images.
fn bonds_by_id(path: &std::path::Path) -> std::collections::BTreeSet<(u64, u64, [i32; 3])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let h: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| h.iter().position(|c| *c == n).unwrap();
    let (ci, cj, cx) = (col("id_i"), col("id_j"), col("ix"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let (a, b): (u64, u64) = (f[ci].parse().unwrap(), f[cj].parse().unwrap());
            let m = [0, 1, 2].map(|k| f[cx + k].parse::<i32>().unwrap());
            if a < b {
                (a, b, m)
            } else {
                (b, a, m.map(|v| -v))
            }
        })
        .collect()
}

/// LIGGGHTS' own `dump custom` of a `boundary p p f` bed (issue 31): read with its box
/// periodic along x and y only (from BOX BOUNDS `pp pp ff`), bonded across the x and y faces
/// and never across z — the pairs of a brute-force search over the x, y minimum image made
/// here from the dump's own lines; the data file of the same state read with `--boundary
/// "p p f"` gives the same bonds, and read as `p p p` it gains the bonds across z. The
/// tensors that need a periodic equilibrium refuse the mixed box by name (its exports:
/// ppf_export.rs).
#[test]
fn liggghts_dump_of_a_p_p_f_bed_bonds_across_the_periodic_faces_only() {
    if let Some(r) = missing(&["liggghts"]) {
        assert!(std::env::var_os("CI").is_none(), "CI without liggghts: {r}");
        eprintln!("skipping: {r}");
        return;
    }
    let t = tmp();
    let d = t.path();
    let (dump, data) = crate::common::liggghts::write_snapshot(d, "bed", &bed());
    let text = std::fs::read_to_string(&dump).unwrap();
    assert!(text.contains("ITEM: BOX BOUNDS pp pp ff"), "{text}");
    // The last snapshot's atoms, read here: id → (x, y, z, r).
    let last = &text[text.rfind("ITEM: ATOMS").unwrap()..];
    let atoms: Vec<(u64, [f64; 4])> = last
        .lines()
        .skip(1)
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
            (w[0] as u64, [w[2], w[3], w[4], w[5]])
        })
        .collect();
    assert_eq!(atoms.len(), 75);
    // Brute force: gap ≤ 0.17 R̄ (the model's rule), minimum image along x and y (L = 0.01).
    let r_mean = atoms.iter().map(|a| a.1[3]).sum::<f64>() / atoms.len() as f64;
    let mut expected = std::collections::BTreeSet::new();
    for (p, a) in atoms.iter().enumerate() {
        for b in &atoms[p + 1..] {
            let mut dist2 = 0.0;
            let mut m = [0i32; 3];
            for (k, mk) in m.iter_mut().enumerate() {
                let mut dk = b.1[k] - a.1[k];
                if k < 2 {
                    let s = -(dk / 0.01).round();
                    dk += s * 0.01;
                    *mk = s as i32;
                }
                dist2 += dk * dk;
            }
            if dist2.sqrt() - a.1[3] - b.1[3] <= 0.17 * r_mean {
                let (lo, hi, m) = if a.0 < b.0 {
                    (a.0, b.0, m)
                } else {
                    (b.0, a.0, m.map(|v| -v))
                };
                expected.insert((lo, hi, m));
            }
        }
    }
    // 5 × 5 × 3 spheres: 75 bonds along x, 75 along y, 50 along z within each column.
    assert_eq!(expected.len(), 200);
    assert!(expected.iter().any(|b| b.2[0] != 0) && expected.iter().all(|b| b.2[2] == 0));
    let p = read_packing(&dump).unwrap();
    assert_eq!(p.cell.unwrap().periodic, [true, true, false]);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let (b_dump, b_data, b_ppp) = (d.join("dump.csv"), d.join("data.csv"), d.join("ppp.csv"));
    succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &m), ("o", &b_dump)],
    ));
    assert_eq!(bonds_by_id(&b_dump), expected);
    let mut c = cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &data), ("m", &m), ("o", &b_data)],
    );
    c.args(["--boundary", "p p f"]);
    succeeds(&mut c);
    assert_eq!(bonds_by_id(&b_data), expected);
    succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &data), ("m", &m), ("o", &b_ppp)],
    ));
    let ppp = bonds_by_id(&b_ppp);
    assert_eq!(ppp.len(), 225, "p p p: the layers bonded across z too");
    assert!(ppp.iter().any(|b| b.2[2] != 0));
    // A contradicting option, and a tensor a mixed box cannot give, refused by name.
    let mut c = cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &m), ("o", &d.join("x.csv"))],
    );
    c.arg("--periodic");
    assert!(fails(&mut c).contains("the boundary p p f"));
    for line in [
        "tensor {p} --model {m} --method relaxed -o {o}",
        "tensor {p} --model {m} --method laf -o {o}",
    ] {
        let e = fails(&mut cmd(
            line,
            &[("p", &dump), ("m", &m), ("o", &d.join("out"))],
        ));
        assert!(
            e.contains("periodic along some axes only (boundary p p f)"),
            "{line}: {e}"
        );
        assert!(!d.join("out").exists());
    }
}
