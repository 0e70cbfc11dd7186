//! A polycrystal model written back reads identically (TOML and JSON); its grain ids travel
//! to the bond table and to ParaView's particles.

use super::common::bonded::generated;
use super::{cubic_model, model};
use anisobond::prelude::*;
use std::path::Path;

#[test]
fn a_written_polycrystal_model_reads_back_identically() {
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("ids.txt"), "0\n").unwrap();
    std::fs::write(dir.path().join("e.txt"), "1 2 3\n").unwrap();
    for grains in [
        "[grains]\ncount = 7\n",
        "[grains]\nmean_size = 2.5\nseed = 12\nboundary = \"series\"\nboundary_factor = 0.75\n",
        "[grains]\ncount = 3\norientation = \"fibre\"\naxis = [1, 1, 0]\n\
         direction = [1, 1, 1]\nspread_deg = 7.5\n",
        "[grains]\nfile = \"ids.txt\"\norientation = \"euler-file\"\neuler_file = \"e.txt\"\n",
    ] {
        let path = dir.path().join("model.toml");
        std::fs::write(&path, cubic_model("", grains)).unwrap();
        let m = Model::from_path(&path).unwrap();
        assert!(m.grains.is_some());
        for name in ["written.toml", "written.json"] {
            // Written elsewhere: resolved paths still name the same files.
            let sub = dir.path().join("elsewhere");
            std::fs::create_dir_all(&sub).unwrap();
            let out = sub.join(name);
            std::fs::write(&out, m.to_string_for(Path::new(name))).unwrap();
            assert_eq!(Model::from_path(&out).unwrap(), m, "{name}: {grains}");
        }
    }
    // A relative file resolves against the model file's folder.
    let m = Model::from_path(&dir.path().join("model.toml")).unwrap();
    match m.grains.unwrap().map {
        anisobond::grains::GrainMap::File(f) => {
            assert!(f.is_absolute(), "{f:?}");
            assert_eq!(std::fs::read_to_string(f).unwrap(), "0\n");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn grain_ids_go_to_the_bond_table_and_the_particles_vtu() {
    let a = Assembly::new(
        generated(300, 71),
        model(&cubic_model("", "[grains]\ncount = 6\n")),
    )
    .unwrap();
    let grain = &a.grains().unwrap().grain;
    let dir = super::common::tmp();
    let table = dir.path().join("bonds.csv");
    a.write_bonds(&table).unwrap();
    let text = std::fs::read_to_string(&table).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (ci, cj, gi, gj) = (col("i"), col("j"), col("grain_i"), col("grain_j"));
    let mut rows = 0;
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let i: usize = f[ci].parse().unwrap();
        let j: usize = f[cj].parse().unwrap();
        assert_eq!(f[gi].parse::<u32>().unwrap(), grain[i]);
        assert_eq!(f[gj].parse::<u32>().unwrap(), grain[j]);
        rows += 1;
    }
    assert_eq!(rows, a.bonds.len());
    // The table reads back as bonds and springs (the grain columns are extra columns).
    let (b, k) = anisobond::bonds::read_bond_table(&table).unwrap();
    assert_eq!(b.len(), a.bonds.len());
    assert_eq!(k.kn, a.springs.kn);

    a.write_vtk(dir.path(), None).unwrap();
    let vtu = std::fs::read_to_string(dir.path().join("particles.vtu")).unwrap();
    let start = vtu.find("Name=\"grain\"").expect("a grain field");
    let values = &vtu[start..];
    let values = &values[values.find('>').unwrap() + 1..values.find("</DataArray>").unwrap()];
    let read: Vec<u32> = values
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(&read, grain);
    let vtu = std::fs::read_to_string(dir.path().join("bonds.vtu")).unwrap();
    for (name, ends) in [("grain_i", &a.bonds.i), ("grain_j", &a.bonds.j)] {
        let start = vtu
            .find(&format!("Name=\"{name}\""))
            .expect("a grain field");
        let values = &vtu[start..];
        let values = &values[values.find('>').unwrap() + 1..values.find("</DataArray>").unwrap()];
        let read: Vec<u32> = values
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        let expected: Vec<u32> = ends.iter().map(|&p| grain[p as usize]).collect();
        assert_eq!(read, expected, "{name}");
    }
}
