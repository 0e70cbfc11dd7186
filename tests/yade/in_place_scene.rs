//! `anisobond_yade` in place on any YADE scene (issue 31, item 3): a non-periodic prism of
//! spheres between walls, a box floor and a facet lid, bonded by YADE's own functors
//! (`Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)` within
//! `interactionDetectionFactor` 1.1), written by YADE 2023.02a in the test
//! (`walled_scene.py`): `bond_table` and `write_packing` give files the `anisobond` command
//! accepts together, with YADE's own count of sphere–sphere bonds, YADE's springs and its
//! positions to the last bit; a periodic scene with spheres outside the cell likewise; a
//! scene with clumps is refused naming them. (`assign` needs the Python package inside YADE:
//! tests/python/test_yade_engines.py runs it on the same scene.)

use crate::common::yade::yade_available;
use crate::common::{cmd, fails, succeeds, tmp, write, CUBIC_MODEL};
use anisobond::bonds::read_bond_table_of;
use anisobond::export::yade::run_yade_script;
use anisobond::packing::read_packing;
use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;

/// Run `walled_scene.py MODE out.json` (with the module beside it) in `dir`; its JSON.
fn scene(dir: &Path, mode: &str) -> Value {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (from, to) in [
        ("tests/yade/walled_scene.py", "walled_scene.py"),
        ("yade-scripts/anisobond_yade.py", "anisobond_yade.py"),
    ] {
        std::fs::copy(root.join(from), dir.join(to)).unwrap();
    }
    run_yade_script(
        &dir.join("walled_scene.py"),
        &[mode.to_string(), "out.json".to_string()],
    )
    .expect("yade run");
    serde_json::from_str(&std::fs::read_to_string(dir.join("out.json")).unwrap()).unwrap()
}

fn u64s(v: &Value) -> Vec<u64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

/// The checks shared by the walled and the periodic scene: the packing's ids, positions and
/// radii are YADE's bit for bit; the bond table holds exactly YADE's cohesive sphere–sphere
/// pairs (mapped through the ids) with YADE's k_n; `anisobond tensor METHOD --bonds` accepts
/// the two files together. Returns the number of bonds.
fn check_tables(d: &Path, info: &Value, method: &str, extra: &[&str]) -> usize {
    let packing = read_packing(&d.join("packing.txt")).expect("packing.txt");
    let ids = u64s(&info["ids"]);
    assert_eq!(packing.len(), ids.len());
    assert_eq!(packing.ids.as_deref(), Some(&ids[..]), "body ids kept");
    // Positions as YADE holds them (outside a periodic cell too), bit for bit.
    let given = packing
        .given_positions
        .clone()
        .unwrap_or_else(|| packing.positions.clone());
    for (k, x) in info["x_bits"].as_array().unwrap().iter().enumerate() {
        for c in 0..3 {
            assert_eq!(
                given[k][c].to_bits(),
                x[c].as_u64().unwrap(),
                "sphere {k} (body {}), coordinate {c}: {} is not YADE's",
                ids[k],
                given[k][c]
            );
        }
        assert_eq!(
            packing.radii[k].to_bits(),
            info["r_bits"][k].as_u64().unwrap(),
            "radius {k}"
        );
    }

    // The bond table: checked row by row against the packing by the library's reader
    // (branch vector n·length within 1e-6 of the length), then against YADE's own bonds.
    let (bonds, springs) = read_bond_table_of(&d.join("bonds.csv"), &packing).expect("bonds.csv");
    let n_yade = info["yade_sphere_bonds"].as_u64().unwrap() as usize;
    assert_eq!(
        bonds.len(),
        n_yade,
        "one bond per cohesive sphere–sphere interaction"
    );
    assert_eq!(info["table_bonds"].as_u64(), Some(n_yade as u64));
    let mut pairs: Vec<[u64; 2]> = (0..bonds.len())
        .map(|b| [ids[bonds.i[b] as usize], ids[bonds.j[b] as usize]])
        .collect();
    pairs.sort();
    let yade_pairs: Vec<[u64; 2]> = info["yade_bond_pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [p[0].as_u64().unwrap(), p[1].as_u64().unwrap()])
        .collect();
    assert_eq!(pairs, yade_pairs, "the table's pairs are YADE's");
    let kn: HashMap<String, f64> = info["yade_kn"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_f64().unwrap()))
        .collect();
    for b in 0..bonds.len() {
        let key = format!("{}-{}", ids[bonds.i[b] as usize], ids[bonds.j[b] as usize]);
        assert_eq!(springs.kn[b], kn[&key], "bond {key}: kn");
    }
    // The table's id_i,id_j columns are the body ids of its i,j.
    let text = std::fs::read_to_string(d.join("bonds.csv")).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().ends_with(",ix,iy,iz,id_i,id_j"));
    for (b, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let id_i: u64 = f[14].parse().unwrap();
        let id_j: u64 = f[15].parse().unwrap();
        assert_eq!(
            [id_i, id_j],
            [ids[bonds.i[b] as usize], ids[bonds.j[b] as usize]]
        );
    }

    // The command accepts the two files together.
    let model = write(d, "model.toml", CUBIC_MODEL);
    let report = d.join("tensor.json");
    let said = succeeds(
        cmd(
            &format!("tensor {{p}} --model {{m}} --bonds {{b}} --method {method} -o {{o}}"),
            &[
                ("p", &d.join("packing.txt")),
                ("m", &model),
                ("b", &d.join("bonds.csv")),
                ("o", &report),
            ],
        )
        .args(extra),
    );
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(rep["n_bonds"].as_u64(), Some(n_yade as u64), "{said}");
    assert_eq!(
        rep["n_particles"].as_u64(),
        Some(ids.len() as u64),
        "{said}"
    );
    n_yade
}

#[test]
fn walled_scene_bond_table_and_packing_are_read_by_anisobond() {
    if !yade_available("in_place_scene::walled_scene_bond_table_and_packing_are_read_by_anisobond")
    {
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let info = scene(d, "tables");
    assert_eq!(info["periodic"], Value::Bool(false));
    // The scene is what the test means: walls, a box and facets among the bodies (some of
    // them before the spheres, so body ids are not sphere indices), in contact with spheres,
    // and cohesive contacts with the box and facets that are not bonds.
    let kinds: Vec<&str> = info["non_sphere"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_str().unwrap())
        .collect();
    for k in ["Wall", "Box", "Facet"] {
        assert!(kinds.contains(&k), "{kinds:?}");
    }
    let ids = u64s(&info["ids"]);
    assert!(ids[0] > 0, "spheres come after the walls");
    let other: u64 = info["yade_other_cohesive"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert!(
        other > 0,
        "no cohesive wall contact: {}",
        info["yade_other_cohesive"]
    );
    assert!(info["non_sphere_contacts"].as_u64().unwrap() > other);
    // bond_table skipped (and counted) exactly YADE's cohesive non-sphere contacts and named
    // the non-sphere bodies, which write_packing left out.
    assert_eq!(info["table_skipped"].as_u64(), Some(other));
    let mut non_sphere: Vec<u64> = info["non_sphere"]
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.parse().unwrap())
        .collect();
    non_sphere.sort();
    assert_eq!(u64s(&info["table_non_sphere_bodies"]), non_sphere);
    assert_eq!(u64s(&info["written_ids"]), ids);
    let head = std::fs::read_to_string(d.join("packing.txt")).unwrap();
    assert!(head.contains("\n# free\n"), "{head:.300}");
    // YADE's bonds start in tension across gaps: bond_table says so.
    assert_eq!(info["warnings"], serde_json::json!(["PrestressWarning"]));

    let n = check_tables(d, &info, "voigt", &["--free"]);
    eprintln!(
        "walled prism: {} spheres, {n} bonds (YADE's cohesive sphere–sphere interactions), \
         {other} cohesive contacts with the box/facets and {} contacts with non-spheres in \
         all skipped; positions bit-identical to YADE's",
        ids.len(),
        info["non_sphere_contacts"]
    );

    // YADE's own export.text of the same spheres keeps 6 digits: the full-precision table
    // is rightly refused against it, naming the table's line.
    let model = d.join("model.toml");
    let msg = fails(&mut cmd(
        "tensor {p} --free --model {m} --bonds {b} --method voigt",
        &[
            ("p", &d.join("text6.txt")),
            ("m", &model),
            ("b", &d.join("bonds.csv")),
        ],
    ));
    assert!(msg.contains("bonds.csv:"), "{msg}");
    assert!(msg.contains("not of this packing"), "{msg}");
}

#[test]
fn periodic_scene_with_spheres_outside_the_cell() {
    if !yade_available("in_place_scene::periodic_scene_with_spheres_outside_the_cell") {
        return;
    }
    let dir = tmp();
    let d = dir.path();
    let info = scene(d, "periodic");
    assert_eq!(info["periodic"], Value::Bool(true));
    assert!(
        info["outside"].as_u64().unwrap() > 10,
        "{}",
        info["outside"]
    );
    let packing = read_packing(&d.join("packing.txt")).unwrap();
    let cell = packing.cell.expect("the cell is written").lengths;
    for k in 0..3 {
        assert_eq!(
            cell[k].to_bits(),
            info["cell_bits"][k].as_u64().unwrap(),
            "cell {k}"
        );
    }
    assert!(packing.given_positions.is_some(), "positions kept as given");
    // anisobond_yade.read_packing (what build_scene reads) takes the same file back.
    let back = &info["read_back"];
    assert_eq!(back["ids"], info["ids"]);
    assert_eq!(back["r_bits"], info["r_bits"]);
    assert_eq!(back["cell_bits"], info["cell_bits"]);
    let n = check_tables(d, &info, "relaxed", &[]);
    eprintln!(
        "periodic scene: {} spheres ({} outside the cell), {n} bonds",
        info["ids"].as_array().unwrap().len(),
        info["outside"]
    );
}

#[test]
fn a_scene_with_clumps_is_refused_by_name() {
    if !yade_available("in_place_scene::a_scene_with_clumps_is_refused_by_name") {
        return;
    }
    let dir = tmp();
    let info = scene(dir.path(), "clump");
    let clumps = u64s(&info["clumps"]);
    let members = u64s(&info["members"]);
    assert_eq!(clumps.len(), 1);
    let named = format!(
        "clump {} (members {})",
        clumps[0],
        members
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    );
    for entry in ["bond_table", "write_packing", "assign", "scene_bonds"] {
        let msg = info["refused"][entry]
            .as_str()
            .unwrap_or_else(|| panic!("{entry} accepted a scene with a clump"));
        assert!(msg.contains(&named), "{entry}: {msg}");
        assert!(msg.contains("one rigid body"), "{entry}: {msg}");
    }
    assert_eq!(info["files"], serde_json::json!([]), "nothing written");
}
