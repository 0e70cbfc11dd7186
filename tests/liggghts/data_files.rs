//! LIGGGHTS 3.8's own `write_data` files read as written (issue 20): a periodic box and a
//! walled `boundary f f f` box, made by `write_data.in` in the test (a simple-cubic lattice,
//! `delete_atoms` leaving non-contiguous ids, a `Velocities` section, image flags ≠ 0 after
//! `displace_atoms` across the periodic faces). A data file does not state its boundary:
//! without options the command assumes periodic and says so; `--free` bonds the walled box
//! without bonds across its walls. Bond counts are checked against a brute-force count.

use crate::common::liggghts::*;
use crate::common::{cmd, fails, tmp, write, CUBIC_MODEL};
use anisobond::packing::Packing;
use anisobond::packing::{read_packing_as, CellChoice, CellOrigin};
use std::path::Path;
use std::process::Command;

/// Run `write_data.in` with LIGGGHTS in `dir`; returns the atom count LIGGGHTS printed.
fn write_data(dir: &Path, boundary: &str, zhi: &str, dx: &str, name: &str) -> usize {
    let vars = [("b", boundary), ("zh", zhi), ("dx", dx), ("name", name)];
    let log = run_stock_deck(dir, "write_data.in", &vars);
    let total = log
        .lines()
        .find_map(|l| l.split("new total = ").nth(1))
        .unwrap_or_else(|| panic!("no `new total` in the log:\n{log}"));
    total.trim().parse().unwrap()
}

/// Brute-force bonds of the gap rule 0.17 R̄ (CUBIC_MODEL), across faces when `periodic`.
fn brute_force(p: &Packing, lengths: anisobond::Vec3, periodic: bool) -> usize {
    let mean = p.radii.iter().sum::<f64>() / p.len() as f64;
    let mut n = 0;
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let mut d = p.positions[j] - p.positions[i];
            if periodic {
                for k in 0..3 {
                    d[k] -= (d[k] / lengths[k]).round() * lengths[k];
                }
            }
            if d.norm() - p.radii[i] - p.radii[j] <= 0.17 * mean {
                n += 1;
            }
        }
    }
    n
}

/// The bond table ends with `id_i,id_j`, and they are `ids[i]`, `ids[j]` on every row.
fn check_id_columns(csv: &Path, ids: &[u64]) {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().ends_with(",ix,iy,iz,id_i,id_j"));
    for row in lines {
        let w: Vec<u64> = row
            .split(',')
            .enumerate()
            .filter(|(k, _)| [0, 1, 14, 15].contains(k))
            .map(|(_, v)| v.parse().unwrap())
            .collect();
        assert_eq!(
            (ids[w[0] as usize], ids[w[1] as usize]),
            (w[2], w[3]),
            "{row}"
        );
    }
}

fn bond_rows(csv: &Path) -> usize {
    std::fs::read_to_string(csv).unwrap().lines().count() - 1
}

#[test]
fn liggghts_write_data_periodic_and_walled_boxes() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let n_peri = write_data(d, "p", "0.01", "0.0065", "peri.data");
    let n_wall = write_data(d, "f", "0.02", "0.0005", "wall.data");
    let model = write(d, "model.toml", CUBIC_MODEL);
    let peri_text = std::fs::read_to_string(d.join("peri.data")).unwrap();
    assert!(peri_text.contains("Velocities"));
    assert!(
        peri_text.lines().any(|l| l.ends_with(" 1 0 0")),
        "image flags"
    );

    // Periodic box: every atom, the box as the cell (assumed, with a note).
    let r = read_packing_as(&d.join("peri.data"), CellChoice::AsStated).unwrap();
    assert_eq!(r.origin, CellOrigin::Assumed);
    assert_eq!(r.packing.len(), n_peri);
    let cell = r.packing.cell.unwrap().lengths;
    assert_eq!(cell, anisobond::Vec3::repeat(0.01));
    assert!(r.packing.radii.iter().all(|&x| x == 0.95e-3));
    let out = d.join("peri.csv");
    let o = cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &d.join("peri.data")), ("m", &model), ("o", &out)],
    )
    .output()
    .unwrap();
    let note = crate::common::stderr(&o);
    assert!(o.status.success(), "{note}");
    assert!(
        note.contains("peri.data: a LIGGGHTS data file does not say"),
        "{note}"
    );
    assert!(note.contains("give --free for a walled box"), "{note}");
    assert_eq!(bond_rows(&out), brute_force(&r.packing, cell, true));
    // Atom ids kept (sorted): 1…125 without the ids the deck deleted, and the bond table's
    // id_i,id_j are those of its rows i,j.
    let deleted = |id: u64| [3, 7, 11].contains(&id) || (20..=40).contains(&id);
    let expected: Vec<u64> = (1..=125).filter(|&id| !deleted(id)).collect();
    assert_eq!(r.packing.ids.as_deref(), Some(&expected[..]));
    check_id_columns(&out, &expected);
    let o = cmd(
        "bonds {p} --model {m} -o {o} --periodic",
        &[("p", &d.join("peri.data")), ("m", &model), ("o", &out)],
    )
    .output()
    .unwrap();
    assert!(crate::common::stderr(&o).is_empty());

    // Walled box: --free bonds no pair across the walls; the assumed periodic reading would.
    let free = read_packing_as(&d.join("wall.data"), CellChoice::Free).unwrap();
    assert_eq!(free.packing.len(), n_wall);
    let box_l = anisobond::Vec3::new(0.01, 0.01, 0.02);
    let (walled, across) = (
        brute_force(&free.packing, box_l, false),
        brute_force(&free.packing, box_l, true),
    );
    let out = d.join("wall.csv");
    let o = cmd(
        "bonds {p} --model {m} -o {o} --free",
        &[("p", &d.join("wall.data")), ("m", &model), ("o", &out)],
    )
    .output()
    .unwrap();
    let note = crate::common::stderr(&o);
    assert!(o.status.success(), "{note}");
    assert!(
        note.contains("--free: the LIGGGHTS box is walled"),
        "{note}"
    );
    assert!(note.contains("bounding box of the spheres"), "{note}");
    eprintln!(
        "LIGGGHTS walled box, {n_wall} atoms: {walled} bonds with --free, {across} if taken \
         as periodic; periodic box {n_peri} atoms"
    );
    assert_eq!(bond_rows(&out), walled);
    let expected: Vec<u64> = (1..=150).filter(|&id| !deleted(id)).collect();
    check_id_columns(&out, &expected);
    assert!(across > walled);
    // --cell has no meaning for a data file (its box is the cell): refused, nothing written.
    let out2 = d.join("none.csv");
    let msg = fails(&mut cmd(
        "bonds {p} --model {m} -o {o} --cell 1,1,1",
        &[("p", &d.join("wall.data")), ("m", &model), ("o", &out2)],
    ));
    assert!(
        msg.contains("wall.data") && msg.contains("--periodic"),
        "{msg}"
    );
    assert!(!out2.exists());
}

/// `anisobond convert --to liggghts` (issue 20): LIGGGHTS's own periodic data file (ids with
/// gaps) converted, loaded back by LIGGGHTS `read_data` and written again by `write_data`:
/// the same ids, radii, cell and positions.
#[test]
fn convert_to_liggghts_loads_back_in_read_data() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = tmp();
    let d = dir.path();
    write_data(d, "p", "0.01", "0.0065", "peri.data");
    let said = crate::common::succeeds(
        cmd(
            "convert {i} -o {o} --to liggghts --periodic",
            &[("i", &d.join("peri.data")), ("o", &d.join("conv.data"))],
        )
        .arg("--density")
        .arg("2500"),
    );
    assert!(
        said.contains("101 spheres, periodic cell") && said.contains("ids kept"),
        "{said}"
    );
    std::fs::write(
        d.join("back.in"),
        "units si\natom_style granular\natom_modify map array\nboundary p p p\n\
         read_data conv.data\nwrite_data back.data\n",
    )
    .unwrap();
    let out = Command::new("liggghts")
        .args(["-in", "back.in"])
        .current_dir(d)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success() && !log.contains("ERROR"), "{log}");
    let a = read_packing_as(&d.join("peri.data"), CellChoice::Periodic)
        .unwrap()
        .packing;
    let b = read_packing_as(&d.join("back.data"), CellChoice::Periodic)
        .unwrap()
        .packing;
    assert_eq!(a.ids, b.ids);
    assert_eq!(a.radii, b.radii);
    assert_eq!(a.cell, b.cell);
    for (x, y) in a.positions.iter().zip(&b.positions) {
        assert!((x - y).norm() <= 1e-15, "{x} vs {y}");
    }
    // Ids from YADE start at 0: refused for LIGGGHTS by the writer (the command shifts them).
    let p = anisobond::packing::Packing::new(vec![anisobond::Vec3::zeros()], vec![1.0], None)
        .unwrap()
        .with_ids(vec![0])
        .unwrap();
    let e = anisobond::packing::write_liggghts_data_with_ids(&d.join("x.data"), &p, 1.0);
    assert!(e.unwrap_err().to_string().contains("atom ids must be ≥ 1"));
}

/// Issue 29, B3: the bond table of LIGGGHTS's own walled box (`boundary f f f`, bonded with
/// `--free`) given to `tensor --method relaxed` without `--free` reads the box as the
/// periodic cell; no bond crosses its faces, so the "relaxed tensor" is orders of magnitude
/// below the Voigt tensor of the same bonds. Refused (no report written), naming `--free`;
/// with `--free` the same table gives a tensor. The Voigt tensor of the table is the scale.
#[test]
fn walled_box_table_read_as_periodic_is_refused() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = tmp();
    let d = dir.path();
    write_data(d, "f", "0.02", "0.0005", "wall.data");
    let model = write(d, "model.toml", CUBIC_MODEL);
    let (data, table) = (d.join("wall.data"), d.join("wall.csv"));
    crate::common::succeeds(&mut cmd(
        "bonds {p} --model {m} -o {t} --free",
        &[("p", &data), ("m", &model), ("t", &table)],
    ));
    let voigt = d.join("voigt.json");
    crate::common::succeeds(&mut cmd(
        "tensor {p} --model {m} --bonds {t} --method voigt -o {o}",
        &[("p", &data), ("m", &model), ("t", &table), ("o", &voigt)],
    ));
    let out = d.join("relaxed.json");
    let msg = fails(&mut cmd(
        "tensor {p} --model {m} --bonds {t} --method relaxed -o {o}",
        &[("p", &data), ("m", &model), ("t", &table), ("o", &out)],
    ));
    eprintln!("{msg}");
    assert!(
        msg.contains("below 1e-6 of the Voigt tensor") && msg.contains("--free"),
        "{msg}"
    );
    assert!(msg.contains("0 of"), "no bond crosses the faces: {msg}");
    assert!(!out.exists());
    // The refusal's scale: the Voigt tensor is GPa-sized.
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&voigt).unwrap()).unwrap();
    assert!(v["C"][0][0].as_f64().unwrap() > 1e8, "{v}");
}

/// Issue 29, A12: atom id 0 and atom type 0 in a data file LIGGGHTS wrote (one atom line
/// edited) are refused naming the line, as LIGGGHTS's own `read_data` refuses them; a type
/// above the header's `N atom types` likewise.
#[test]
fn atom_id_and_type_zero_are_refused_as_liggghts_refuses_them() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = tmp();
    let d = dir.path();
    write_data(d, "p", "0.01", "0.0065", "peri.data");
    let text = std::fs::read_to_string(d.join("peri.data")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let atoms = lines.iter().position(|l| l.starts_with("Atoms")).unwrap();
    // The first atom line (after the blank line that follows `Atoms`).
    let first = atoms + 2;
    let words: Vec<&str> = lines[first].split_whitespace().collect();
    assert!(words.len() >= 7, "{}", lines[first]);
    for (name, column, value, needle) in [
        ("id0.data", 0, "0", "atom id (column 1) must be ≥ 1"),
        ("type0.data", 1, "0", "atom type (column 2) must be ≥ 1"),
        (
            "type2.data",
            1,
            "2",
            "exceeds the 1 atom types of the header",
        ),
    ] {
        let mut w = words.clone();
        w[column] = value;
        let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        edited[first] = w.join(" ");
        let path = d.join(name);
        std::fs::write(&path, edited.join("\n") + "\n").unwrap();
        let e = read_packing_as(&path, CellChoice::Periodic)
            .unwrap_err()
            .to_string();
        let at = format!("{}:{}: ", path.display(), first + 1);
        assert!(e.contains(&at) && e.contains(needle), "{name}: {e}");
        // LIGGGHTS's own read_data refuses the same file.
        std::fs::write(
            d.join("read.in"),
            format!(
                "units si\natom_style granular\natom_modify map array\nboundary p p p\n\
                 read_data {name}\n"
            ),
        )
        .unwrap();
        let out = Command::new("liggghts")
            .args(["-in", "read.in"])
            .current_dir(d)
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            log.contains("ERROR") || !out.status.success(),
            "LIGGGHTS read {name}:\n{log}"
        );
    }
}
