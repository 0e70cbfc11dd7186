//! `anisobond export vtk` on a polycrystal writes the grain ids ParaView colours grains by:
//! the point field `grain` of particles.vtu equals `Assembly::grains()` of the same files, and
//! the cell fields `grain_i`, `grain_j` of bonds.vtu are the grains of each bond's ends — read
//! back with an XML parser; a single crystal's files have no grain field.

use super::common::{bin, packing, succeeds, tmp, write};
use super::cubic_model;
use anisobond::prelude::*;
use quick_xml::events::Event;
use quick_xml::Reader;
use std::collections::HashMap;
use std::path::Path;

/// Every DataArray of a .vtu file: name → its values as text tokens.
fn data_arrays(path: &Path) -> HashMap<String, Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut reader = Reader::from_str(&text);
    let mut out = HashMap::new();
    let mut current: Option<String> = None;
    loop {
        match reader.read_event().expect("well-formed XML") {
            Event::Start(e) if e.name().as_ref() == b"DataArray" => {
                let name = e
                    .try_get_attribute("Name")
                    .unwrap()
                    .map(|a| a.unescape_value().unwrap().to_string())
                    .unwrap_or_default();
                current = Some(name);
                out.entry(current.clone().unwrap()).or_insert_with(Vec::new);
            }
            Event::Text(t) => {
                if let Some(name) = &current {
                    let values = t.unescape().unwrap();
                    let v = out.get_mut(name).unwrap();
                    v.extend(values.split_whitespace().map(str::to_string));
                }
            }
            Event::End(e) if e.name().as_ref() == b"DataArray" => current = None,
            Event::Eof => break,
            _ => {}
        }
    }
    out
}

/// The named field as grain ids.
fn ids(arrays: &HashMap<String, Vec<String>>, name: &str) -> Vec<u32> {
    arrays
        .get(name)
        .unwrap_or_else(|| panic!("no DataArray `{name}`: {:?}", arrays.keys()))
        .iter()
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn export_vtk_writes_the_grain_ids_of_a_polycrystal() {
    let dir = tmp();
    let pk = packing(dir.path(), 300);
    let poly = write(
        dir.path(),
        "poly.toml",
        &cubic_model("", "[grains]\ncount = 6\nseed = 1\n"),
    );
    let single = write(dir.path(), "single.toml", &cubic_model("", ""));
    // The grains and bonds of the same files, built here by the library.
    let a = Assembly::from_files(&pk, &poly).unwrap();
    let grain = &a.grains().expect("a polycrystal").grain;
    assert!(grain.iter().any(|&g| g != grain[0]), "more than one grain");
    for (strain, sub) in [("0", "unloaded"), ("1e-3,0,0,0,0,0", "strained")] {
        let out = dir.path().join(sub);
        succeeds(
            bin()
                .args(["export", "vtk"])
                .arg(&pk)
                .arg("--model")
                .arg(&poly)
                .args(["--strain", strain, "-o"])
                .arg(&out),
        );
        let particles = data_arrays(&out.join("particles.vtu"));
        assert_eq!(
            &ids(&particles, "grain"),
            grain,
            "{sub}: particles.vtu `grain`"
        );
        assert_eq!(particles["radius"].len(), a.packing.len());
        let bonds = data_arrays(&out.join("bonds.vtu"));
        for (name, ends) in [("grain_i", &a.bonds.i), ("grain_j", &a.bonds.j)] {
            let want: Vec<u32> = ends.iter().map(|&p| grain[p as usize]).collect();
            assert_eq!(ids(&bonds, name), want, "{sub}: bonds.vtu `{name}`");
        }
    }
    // A single crystal: no grain field (nothing to colour by).
    let out = dir.path().join("single");
    succeeds(
        bin()
            .args(["export", "vtk"])
            .arg(&pk)
            .arg("--model")
            .arg(&single)
            .args(["--strain", "0", "-o"])
            .arg(&out),
    );
    assert!(!data_arrays(&out.join("particles.vtu")).contains_key("grain"));
    assert!(!data_arrays(&out.join("bonds.vtu")).contains_key("grain_i"));
}

/// `anisobond specimen` on a free polycrystal block writes the same grain fields: `grain` of
/// particles.vtu and `grain_i`, `grain_j` of bonds.vtu equal the grains of
/// `Assembly::from_files` of the same files (Voronoi grains in the spheres' bounding box);
/// a single crystal's specimen files have none.
#[test]
fn specimen_writes_the_grain_ids_of_a_polycrystal() {
    let dir = tmp();
    let periodic = Assembly::from_files(
        &packing(dir.path(), 300),
        &write(dir.path(), "m.toml", &cubic_model("", "")),
    )
    .unwrap();
    // The same spheres without a cell: a free block.
    let free = Packing::new(
        periodic.packing.positions.clone(),
        periodic.packing.radii.clone(),
        None,
    )
    .unwrap();
    let pk = dir.path().join("free.txt");
    write_packing(&pk, &free).unwrap();
    let poly = write(
        dir.path(),
        "poly.toml",
        &cubic_model("", "[grains]\ncount = 5\nseed = 2\n"),
    );
    let a = Assembly::from_files(&pk, &poly).unwrap();
    assert!(a.packing.cell.is_none());
    let grain = &a.grains().expect("a polycrystal").grain;
    assert!(grain.iter().any(|&g| g != grain[0]), "more than one grain");
    let out = dir.path().join("specimen");
    succeeds(
        bin()
            .arg("specimen")
            .arg(&pk)
            .arg("--model")
            .arg(&poly)
            .args(["--free", "-o"])
            .arg(&out),
    );
    let particles = data_arrays(&out.join("particles.vtu"));
    assert_eq!(&ids(&particles, "grain"), grain, "particles.vtu `grain`");
    let bonds = data_arrays(&out.join("bonds.vtu"));
    for (name, ends) in [("grain_i", &a.bonds.i), ("grain_j", &a.bonds.j)] {
        let want: Vec<u32> = ends.iter().map(|&p| grain[p as usize]).collect();
        assert_eq!(ids(&bonds, name), want, "bonds.vtu `{name}`");
    }
    let single = write(dir.path(), "single.toml", &cubic_model("", ""));
    let out = dir.path().join("single");
    succeeds(
        bin()
            .arg("specimen")
            .arg(&pk)
            .arg("--model")
            .arg(&single)
            .args(["--free", "-o"])
            .arg(&out),
    );
    assert!(!data_arrays(&out.join("particles.vtu")).contains_key("grain"));
    assert!(!data_arrays(&out.join("bonds.vtu")).contains_key("grain_i"));
}
