//! YADE's own packing files read as written (issue 20): `SpherePack.save` after
//! `randomPeriPack` (`##PERIODIC::`, `x y z r clumpId`), `export.text` / `export.textExt`
//! of the same periodic scene (`#format x_y_z_r`, `x_y_z_r_matId`, `x_y_z_r_attrs`,
//! `id_x_y_z_r_matId`), a non-periodic `randomDensePack` saved, and a clump (refused).
//! The files are written by YADE 2023.02a in the test (`yade_files.py`), which also prints
//! what they hold as JSON; the library reader and `anisobond bonds` read every one.

use crate::common::yade::yade_available;
use crate::common::{cmd, fails, succeeds, tmp, write, CUBIC_MODEL};
use anisobond::export::yade::run_yade_script;
use anisobond::packing::read_packing;
use anisobond::packing::Packing;
use serde_json::Value;
use std::path::Path;

/// YADE writes numbers with 6 significant digits (`%g`, C++ streams).
const DIGITS: f64 = 1e-5;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= DIGITS * b.abs()
}

/// Run the script in `dir` and return its JSON.
fn yade_files(dir: &Path) -> Value {
    let script = dir.join("yade_files.py");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/yade/yade_files.py"),
        &script,
    )
    .unwrap();
    run_yade_script(&script, &[]).expect("yade run");
    let text = std::fs::read_to_string(dir.join("yade-files.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Same count and radii (in order) as YADE printed.
fn check_radii(p: &Packing, expected: &Value, name: &str) {
    let radii: Vec<f64> = expected["radii"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(p.len(), expected["n"].as_u64().unwrap() as usize, "{name}");
    assert_eq!(p.len(), radii.len(), "{name}");
    for (k, (a, b)) in p.radii.iter().zip(&radii).enumerate() {
        assert!(
            close(*a, *b),
            "{name}: sphere {k}: radius {a} vs YADE's {b}"
        );
    }
}

/// `anisobond bonds FILE` succeeds and bonds every sphere of the file it read.
fn bonds_of(dir: &Path, file: &Path) -> (usize, String) {
    let model = write(dir, "model.toml", CUBIC_MODEL);
    let out = dir.join("b.csv");
    let said = succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", file), ("m", &model), ("o", &out)],
    ));
    let table = std::fs::read_to_string(&out).unwrap();
    let rows = table.lines().filter(|l| !l.starts_with('#')).count() - 1;
    (rows, said)
}

#[test]
fn yade_written_packings_are_read_as_written() {
    if !yade_available("yade_files::yade_written_packings_are_read_as_written") {
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let info = yade_files(d);

    // SpherePack.save of randomPeriPack: the cell, the count and the radii.
    let peri = read_packing(&d.join("peri.txt")).expect("peri.txt");
    check_radii(&peri, &info["peri"], "peri.txt");
    let cell = peri.cell.expect("peri.txt is periodic").lengths;
    for k in 0..3 {
        let l = info["peri"]["cell"][k].as_f64().unwrap();
        assert!(close(cell[k], l), "cell {k}: {} vs YADE's {l}", cell[k]);
    }
    let (n_peri, said) = bonds_of(d, &d.join("peri.txt"));
    assert!(n_peri > peri.len(), "{said}");
    assert!(
        said.contains(&format!("between {} particles", peri.len())),
        "{said}"
    );

    // export.text and textExt of the same scene: same spheres in the same (body id) order.
    let text = read_packing(&d.join("text.txt")).expect("text.txt");
    check_radii(&text, &info["scene"], "text.txt");
    for name in ["matid.txt", "attrs.txt", "idmat.txt"] {
        let p = read_packing(&d.join(name)).expect(name);
        check_radii(&p, &info["scene"], name);
        assert_eq!(p.positions, text.positions, "{name}");
        assert_eq!(p.radii, text.radii, "{name}");
    }
    // Body ids: kept from `id_x_y_z_r_matId`, and carried to the bond table as id_i,id_j.
    let ids: Vec<u64> = info["scene"]["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    let idmat = read_packing(&d.join("idmat.txt")).unwrap();
    assert_eq!(idmat.ids.as_deref(), Some(&ids[..]));
    assert!(text.ids.is_none());
    bonds_of(d, &d.join("idmat.txt"));
    let header = std::fs::read_to_string(d.join("b.csv")).unwrap();
    assert!(header.starts_with("i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz,id_i,id_j\n"));
    // The scene's positions are those of the SpherePack, up to whole cell lengths (the text
    // files state no cell: read as written, not wrapped).
    let c = peri.cell.unwrap();
    for (a, b) in text.positions.iter().zip(&peri.positions) {
        let (d, _) = c.minimum_image(a - b);
        assert!(d.norm() <= DIGITS * cell.x, "{a} vs {b}");
    }

    // randomDensePack saved without a cell: a free packing, every sphere read.
    let dense = read_packing(&d.join("dense.txt")).expect("dense.txt");
    assert!(dense.cell.is_none());
    check_radii(&dense, &info["dense"], "dense.txt");
    let (n_dense, said) = bonds_of(d, &d.join("dense.txt"));
    assert!(n_dense > 0, "{said}");

    // A clump member is refused naming the file, the line and what was expected.
    let err = read_packing(&d.join("clump.txt")).unwrap_err().to_string();
    assert!(err.contains("clump.txt:2:"), "{err}");
    assert!(err.contains("belongs to clump 3"), "{err}");
    assert!(err.contains("expected clumpId -1"), "{err}");
    let model = write(d, "model.toml", CUBIC_MODEL);
    let out = d.join("clump.csv");
    let msg = fails(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &d.join("clump.txt")), ("m", &model), ("o", &out)],
    ));
    assert!(msg.contains("clump.txt:2:"), "{msg}");
    assert!(!out.exists());
}

/// YADE's export.text of a periodic scene states no cell (issue 20, item 2): read without
/// options it is a free cluster and every command says so, naming `--cell`; with `--cell`
/// from YADE's own cell it is the same bond network as the SpherePack.save file that states
/// the cell; a contradicting option on a file that states its cell is refused.
#[test]
fn export_text_states_no_cell_and_the_user_gives_it() {
    if !yade_available("yade_files::export_text_states_no_cell_and_the_user_gives_it") {
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let info = yade_files(d);
    let model = write(d, "model.toml", CUBIC_MODEL);
    let l: Vec<String> = (0..3)
        .map(|k| info["peri"]["cell"][k].as_f64().unwrap().to_string())
        .collect();
    let cell = l.join(",");
    let bonds = |file: &str, extra: &[&str]| {
        let out = d.join("b.csv");
        let o = cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &d.join(file)), ("m", &model), ("o", &out)],
        )
        .args(extra)
        .output()
        .unwrap();
        assert!(o.status.success(), "{}", crate::common::stderr(&o));
        let rows = std::fs::read_to_string(&out).unwrap().lines().count() - 1;
        (rows, crate::common::stderr(&o))
    };
    let (stated, note) = bonds("peri.txt", &[]);
    assert!(
        note.is_empty(),
        "a file that states its cell gets no note: {note}"
    );
    let (assumed, note) = bonds("text.txt", &[]);
    assert!(
        note.contains("text.txt: the file states no periodic cell"),
        "{note}"
    );
    assert!(note.contains("give --cell Lx,Ly,Lz"), "{note}");
    assert!(
        note.contains("volume is the bounding box of the spheres"),
        "{note}"
    );
    let (given, note) = bonds("text.txt", &["--cell", &cell]);
    assert!(note.is_empty(), "{note}");
    eprintln!(
        "export.text of randomPeriPack ({} spheres): {assumed} bonds read as a free cluster, \
         {given} with --cell {cell}, {stated} from SpherePack.save",
        info["peri"]["n"]
    );
    assert_eq!(given, stated);
    assert!(assumed < stated);
    let (_, note) = bonds("text.txt", &["--free"]);
    assert!(
        note.contains("a free cluster: volume is the bounding box"),
        "{note}"
    );

    // The tensor of the free reading prints the same note; --periodic cannot give lengths.
    let msg = fails(&mut cmd(
        "tensor {p} --model {m} --method voigt --periodic",
        &[("p", &d.join("text.txt")), ("m", &model)],
    ));
    assert!(msg.contains("text.txt"), "{msg}");
    assert!(msg.contains("expected --cell Lx,Ly,Lz"), "{msg}");
    // A file that states its cell refuses an option that contradicts it.
    let msg = fails(&mut cmd(
        "tensor {p} --model {m} --method voigt --free",
        &[("p", &d.join("peri.txt")), ("m", &model)],
    ));
    assert!(msg.contains("peri.txt"), "{msg}");
    assert!(msg.contains("the file states a periodic cell"), "{msg}");
}

/// `anisobond convert` (issue 20): YADE's export.text with the cell given by `--cell`, written
/// for `SpherePack.load` and `ymport.text`, and loaded back by YADE itself: same count, cell
/// and radii.
#[test]
fn convert_outputs_load_back_in_yade() {
    if !yade_available("yade_files::convert_outputs_load_back_in_yade") {
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let info = yade_files(d);
    let cell: Vec<f64> = (0..3)
        .map(|k| info["peri"]["cell"][k].as_f64().unwrap())
        .collect();
    let cell_arg = format!("{},{},{}", cell[0], cell[1], cell[2]);
    let said = succeeds(
        cmd(
            "convert {i} -o {o} --to spherepack",
            &[("i", &d.join("text.txt")), ("o", &d.join("sp.txt"))],
        )
        .args(["--cell", &cell_arg]),
    );
    assert!(said.contains("periodic cell"), "{said}");
    succeeds(&mut cmd(
        "convert {i} -o {o} --to text",
        &[("i", &d.join("peri.txt")), ("o", &d.join("ym.txt"))],
    ));
    let script = d.join("load_back.py");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/yade/load_back.py"),
        &script,
    )
    .unwrap();
    run_yade_script(&script, &["sp.txt".into(), "ym.txt".into()]).expect("yade run");
    let back: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("load-back.json")).unwrap()).unwrap();
    for k in 0..3 {
        assert_eq!(back["spherepack"]["cell"][k].as_f64().unwrap(), cell[k]);
    }
    check_radii_json(&back["spherepack"], &info["scene"], "SpherePack.load");
    check_radii_json(&back["ymport"], &info["peri"], "ymport.text");
    // YADE body ids (from 0) to LIGGGHTS atom ids (from 1): shifted by one, with a note.
    let o = cmd(
        "convert {i} -o {o} --to liggghts",
        &[("i", &d.join("idmat.txt")), ("o", &d.join("id.data"))],
    )
    .args(["--cell", &cell_arg])
    .output()
    .unwrap();
    assert!(o.status.success());
    assert!(crate::common::stderr(&o).contains("atom id = id + 1"));
    let ids: Vec<u64> = info["scene"]["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() + 1)
        .collect();
    let back = read_packing(&d.join("id.data")).unwrap();
    assert_eq!(back.ids, Some(ids));
    // The converted SpherePack file reads back in anisobond as the SpherePack.save file (to
    // its 6 digits).
    let a = read_packing(&d.join("sp.txt")).unwrap();
    let b = read_packing(&d.join("peri.txt")).unwrap();
    for k in 0..3 {
        assert!(close(
            a.cell.unwrap().lengths[k],
            b.cell.unwrap().lengths[k]
        ));
    }
    assert_eq!(a.radii, b.radii);
}

/// Same count and radii (YADE's 6 digits) in two JSON summaries.
fn check_radii_json(got: &Value, expected: &Value, name: &str) {
    assert_eq!(got["n"], expected["n"], "{name}");
    let g = got["radii"].as_array().unwrap();
    let e = expected["radii"].as_array().unwrap();
    for (a, b) in g.iter().zip(e) {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!(close(a, b), "{name}: radius {a} vs {b}");
    }
}
