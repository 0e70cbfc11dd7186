//! A polycrystal's grain ids in the engines' own files, read by the engines themselves
//! (issue 34, docs/polycrystal.md "Grain ids in the engines"): LAMMPS reads `export lammps`'s
//! data.lmp and writes it back (`write_data`): every atom's molecule ID is its grain + 1;
//! LIGGGHTS runs the stock deck of `export liggghts` to its first `run 0` and dumps `mol`
//! from harmonic.data: grain + 1; YADE builds the scene of `export yade` with grains.txt and
//! reports each sphere's grain from its material, and the element test's stresses are the
//! same bits with and without the grains (the per-grain material copies change nothing). All
//! against `Assembly::grains` of the same files, computed here.
//!
//! Skipped with a printed reason when the program is absent and CI is unset; under CI=true a
//! missing program fails (tests/common).

use super::common::{self, bin, packing, succeeds, tmp, write};
use super::cubic_model;
use anisobond::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// 6 seeded Voronoi grains, random orientations.
const GRAINS: &str = "[grains]\ncount = 6\nseed = 1\n";

/// One engine at a time (each spawns processes on the two cores of CI).
fn one_engine_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// The packing (300 particles, no ids of its own: atom id = index + 1) and polycrystal model
/// in `dir`, and the grain of every particle by the library.
fn case(dir: &Path) -> (PathBuf, PathBuf, Vec<u32>) {
    let pk = packing(dir, 300);
    let model = write(dir, "poly.toml", &cubic_model("", GRAINS));
    let a = Assembly::from_files(&pk, &model).unwrap();
    let grain = a.grains().expect("a polycrystal").grain.clone();
    let distinct: std::collections::BTreeSet<u32> = grain.iter().copied().collect();
    assert_eq!(distinct.len(), 6, "six grains: {distinct:?}");
    (pk, model, grain)
}

/// `anisobond export ENGINE` of the case into `dir/ENGINE`.
fn export(engine: &str, pk: &Path, model: &Path, dir: &Path) -> PathBuf {
    let out = dir.join(engine);
    succeeds(
        bin()
            .args(["export", engine])
            .arg(pk)
            .arg("--model")
            .arg(model)
            .arg("-o")
            .arg(&out),
    );
    out
}

/// Atom id → molecule ID of an atom list: the lines of `text` after the line starting with
/// `section` up to the next blank line after the data, columns `id_col` and `mol_col`.
fn molecules(text: &str, section: &str, id_col: usize, mol_col: usize) -> BTreeMap<u64, u64> {
    let mut lines = text
        .lines()
        .skip_while(|l| !l.starts_with(section))
        .skip(1)
        .skip_while(|l| l.trim().is_empty());
    let mut out = BTreeMap::new();
    for l in lines.by_ref() {
        let w: Vec<&str> = l.split_whitespace().collect();
        if w.is_empty() {
            break;
        }
        let id = w[id_col].parse().unwrap();
        let mol = w[mol_col].parse().unwrap();
        assert!(out.insert(id, mol).is_none(), "atom {id} twice");
    }
    out
}

/// Every atom p + 1 carries molecule `grain[p] + 1`.
fn check_molecules(engine: &str, mol: &BTreeMap<u64, u64>, grain: &[u32]) {
    assert_eq!(mol.len(), grain.len(), "{engine}: atoms read back");
    for (p, g) in grain.iter().enumerate() {
        assert_eq!(
            mol.get(&(p as u64 + 1)),
            Some(&(u64::from(*g) + 1)),
            "{engine}: molecule of atom {}",
            p + 1
        );
    }
}

#[test]
fn lammps_reads_the_grains_as_molecule_ids() {
    let test = "lammps_reads_the_grains_as_molecule_ids";
    let Some(lmp) = common::lammps::lmp(test) else {
        return;
    };
    let dir = tmp();
    let (pk, model, grain) = case(dir.path());
    let out = export("lammps", &pk, &model, dir.path());
    // LAMMPS reads data.lmp as the deck does (atom_style bpm/sphere) and writes it back.
    write(
        &out,
        "in.grains",
        "units si\ndimension 3\nboundary p p p\natom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\n\
         read_data data.lmp\nwrite_data back.data noinit nocoeff\n",
    );
    let _alone = one_engine_at_a_time();
    let run = Command::new(&lmp)
        .args(["-in", "in.grains", "-log", "none"])
        .current_dir(&out)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success() && !log.contains("ERROR"), "{log}");
    let back = std::fs::read_to_string(out.join("back.data")).unwrap();
    // Atoms # bpm/sphere: id molecule-ID type diameter density x y z (image flags).
    check_molecules("LAMMPS", &molecules(&back, "Atoms", 0, 1), &grain);
}

#[test]
fn liggghts_dumps_the_grains_as_molecule_ids() {
    let test = "liggghts_dumps_the_grains_as_molecule_ids";
    if let Some(r) = common::missing(&["liggghts"]) {
        eprintln!("SKIPPED {test}: {r}");
        return;
    }
    let dir = tmp();
    let (pk, model, grain) = case(dir.path());
    let out = export("liggghts", &pk, &model, dir.path());
    // The stock deck as exported, up to its first `run 0`, with a dump of `mol` before it.
    let deck = std::fs::read_to_string(out.join("harmonic.in")).unwrap();
    let head = deck
        .split_inclusive('\n')
        .take_while(|l| l.trim() != "run 0")
        .collect::<String>();
    assert!(head.contains("read_data harmonic.data"), "{head}");
    write(
        &out,
        "grains.in",
        &format!(
            "{head}dump grains all custom 1 grains.dump id mol\n\
             dump_modify grains sort id\nrun 0\n"
        ),
    );
    let _alone = one_engine_at_a_time();
    let run = Command::new("liggghts")
        .args(["-in", "grains.in", "-log", "none"])
        .current_dir(&out)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success() && !log.contains("ERROR"), "{log}");
    let dump = std::fs::read_to_string(out.join("grains.dump")).unwrap();
    check_molecules(
        "LIGGGHTS",
        &molecules(&dump, "ITEM: ATOMS id mol", 0, 1),
        &grain,
    );
}

/// The YADE script: the export's module builds the scene twice, without and with the
/// grains of grains.txt, runs the 11 path for 50 steps each time and writes the grains it
/// reads back from the spheres and both stress histories (repr: every bit).
const YADE_GRAINS: &str = r#"import json, os, sys
sys.dont_write_bytecode = True
d = sys.argv[1]
sys.path.insert(0, d)
import anisobond_yade as ab
pk = ab.read_packing(os.path.join(d, "packing.txt"))
bonds = ab.read_bond_table(os.path.join(d, "bonds.csv"), len(pk))
grains = ab.read_grains(os.path.join(d, "grains.txt"), len(pk))
out = {}
for name, g in (("plain", None), ("grains", grains)):
    r = ab.element_tests(pk, bonds, steps=50, damping=0.4, paths=(0,), grains=g)
    out[name] = [repr(x) for row in r.histories[0] for x in row[3]]
    out[name + "_scene"] = ab.scene_grains()
    from yade import O
    out[name + "_materials"] = len(O.materials)
    out[name + "_colours"] = len(set(tuple(b.shape.color) for b in O.bodies))
with open(os.path.join(d, "grains.json"), "w") as f:
    json.dump(out, f)
"#;

#[test]
fn yade_spheres_carry_the_grains_without_changing_the_run() {
    let test = "yade_spheres_carry_the_grains_without_changing_the_run";
    if !common::yade::yade_available(test) {
        return;
    }
    let dir = tmp();
    let (pk, model, grain) = case(dir.path());
    let out = export("yade", &pk, &model, dir.path());
    // grains.txt is the grain-file format the model's `[grains] file` reads.
    let read = anisobond::grains::read_grain_file(&out.join("grains.txt"), grain.len()).unwrap();
    assert_eq!(read, grain);
    let run_py = std::fs::read_to_string(out.join("run.py")).unwrap();
    assert!(run_py.contains("\"--grains\", os.path.join(HERE, \"grains.txt\")"));
    let script = write(dir.path(), "grains.py", YADE_GRAINS);
    let _alone = one_engine_at_a_time();
    anisobond::export::yade::run_yade_script(&script, &[out.display().to_string()]).unwrap();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("grains.json")).unwrap()).unwrap();
    let scene: Vec<u32> = r["grains_scene"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g.as_u64().expect("every sphere has a grain") as u32)
        .collect();
    assert_eq!(scene, grain, "YADE's spheres' grains");
    assert!(r["plain_scene"]
        .as_array()
        .unwrap()
        .iter()
        .all(|g| g.is_null()));
    // One material copy and one colour per grain (the original material stays).
    assert_eq!(r["plain_materials"], 1);
    assert_eq!(r["grains_materials"], 7);
    assert_eq!(r["grains_colours"], 6);
    // The same stresses, bit for bit, after 50 damped steps of the 11 path.
    let plain = r["plain"].as_array().unwrap();
    assert_eq!(plain.len(), 6 * 51, "{plain:?}");
    assert!(plain
        .iter()
        .any(|s| s.as_str().unwrap().parse::<f64>().unwrap() != 0.0));
    assert_eq!(r["grains"], r["plain"]);
}

#[test]
fn a_grain_count_other_than_the_particles_is_refused_with_nothing_written() {
    use anisobond::export::{lammps, liggghts, yade};
    let dir = tmp();
    let (pk, model, grain) = case(dir.path());
    let a = Assembly::from_files(&pk, &model).unwrap();
    let short = &grain[1..];
    let (p, b, k) = (&a.packing, &a.bonds, &a.springs);
    let out = dir.path().join("lammps");
    std::fs::create_dir(&out).unwrap();
    let o = lammps::LammpsOptions {
        grains: Some(short.to_vec()),
        ..Default::default()
    };
    let e = lammps::export_lammps(&out, p, b, k, &o).unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(
        e.to_string().contains("299 grain ids for 300 particles"),
        "{e}"
    );
    assert!(common::entries(&out).is_empty(), "LAMMPS files left behind");
    let out = dir.path().join("yade");
    let yo = yade::YadeRunOptions::default();
    let e = yade::write_yade_export_grains(&out, p, b, k, None, &yo, Some(short)).unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(
        e.to_string().contains("299 grain ids for 300 particles"),
        "{e}"
    );
    assert!(!out.exists(), "YADE files left behind");
    let out = dir.path().join("liggghts");
    let lo = liggghts::DeckOptions::default();
    let e = liggghts::LiggghtsInputs {
        grains: Some(short),
        ..liggghts::LiggghtsInputs::new(p, b, k, &lo)
    }
    .export(&out)
    .unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(
        e.to_string().contains("299 grain ids for 300 particles"),
        "{e}"
    );
    assert!(!out.exists(), "LIGGGHTS files left behind");
}
