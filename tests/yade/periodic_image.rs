//! The periodic-image trap: `utils.createInteraction` picks the wrong image when
//! x_j − x_i < −L/2 in a component. On a generated packing where many bonds do, YADE's
//! raw `createInteraction` must get some wrong (so the test exercises the trap), and after
//! `anisobond_yade.build_scene` every bond's branch vector in YADE must equal the one
//! anisobond computes, x_j + image∘L − x_i, bond by bond.

use crate::common::yade::yade_available;
use anisobond::bonds::{self, build_bonds};
use anisobond::export::yade::{run_yade_script, write_yade_export, YadeRunOptions};
use anisobond::model::Model;
use anisobond::Vec3;

const SCRIPT: &str = r#"
import json, os, sys
HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, HERE)
import anisobond_yade as ab
from yade import O, utils

packing = ab.read_packing(os.path.join(HERE, "packing.txt"))
bonds = ab.read_bond_table(os.path.join(HERE, "bonds.csv"))
def v(x):
    return [float(x[0]), float(x[1]), float(x[2])]

# 1. Plain createInteraction (what a user would do): record the image YADE picks.
ab.build_scene(packing, bonds, verify=False)   # scene with bodies and engines
O.interactions.clear()
raw = []
for b in range(len(bonds)):
    I = utils.createInteraction(bonds.i[b], bonds.j[b])
    s = 1 if I.id1 == bonds.i[b] else -1
    raw.append([s * I.cellDist[k] for k in range(3)])

# 2. The module's scene: images fixed, geometry recomputed, verified.
sc = ab.build_scene(packing, bonds)
fixed = []
for b, I in enumerate(sc.interactions):
    s = 1.0 if I.id1 == bonds.i[b] else -1.0
    fixed.append({"i": I.id1 if s > 0 else I.id2, "j": I.id2 if s > 0 else I.id1,
                  "branch": [s * c for c in v(ab.branch_vector(I))],
                  "normal": [s * c for c in v(I.geom.normal)],
                  "penetration": float(I.geom.penetrationDepth)})
# 3. A few dynamic steps must keep every bond (nothing erased without a collider).
O.run(20, True)
ab._write_atomic(os.path.join(HERE, "images.json"), json.dumps(
    {"raw_images": raw, "fixed": fixed, "interactions_after_20_steps": len(O.interactions),
     "real_after_20_steps": sum(1 for I in O.interactions if I.isReal)}))
"#;

#[test]
fn every_bond_has_the_table_branch_vector_in_yade() {
    if !yade_available("every_bond_has_the_table_branch_vector_in_yade") {
        return;
    }
    let packing = crate::common::bonded::generated(200, 11);
    let model = Model::truszkowska_mrv();
    let bond_set = build_bonds(&packing, model.bonding).unwrap();
    let scheme = model.build_scheme(Some((&packing, &bond_set))).unwrap();
    let springs =
        bonds::assign_stiffness(&packing, &bond_set, scheme.as_ref(), &model.geometry).unwrap();
    let cell = packing.cell.unwrap();
    // Independent branch vectors and the bonds that trigger the trap.
    let mut trap = 0;
    let mut expected = Vec::new();
    for b in 0..bond_set.len() {
        let (i, j) = (bond_set.i[b] as usize, bond_set.j[b] as usize);
        let raw = packing.positions[j] - packing.positions[i];
        if (0..3).any(|k| raw[k] < -0.5 * cell.lengths[k]) {
            trap += 1;
        }
        expected.push(raw + cell.shift(bond_set.image[b]));
    }
    assert!(
        trap > 20,
        "only {trap} bonds with x_j − x_i < −L/2: the trap is not exercised"
    );

    let dir = tempfile::tempdir().unwrap();
    write_yade_export(
        dir.path(),
        &packing,
        &bond_set,
        &springs,
        Some(&model),
        &YadeRunOptions::default(),
    )
    .unwrap();
    let script = dir.path().join("images.py");
    std::fs::write(&script, SCRIPT).unwrap();
    run_yade_script(&script, &[]).expect("yade run");
    let res: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("images.json")).unwrap())
            .unwrap();

    // The raw createInteraction image is wrong for some bonds (the trap is real).
    let raw = res["raw_images"].as_array().unwrap();
    let wrong = raw
        .iter()
        .enumerate()
        .filter(|(b, img)| (0..3).any(|k| img[k].as_i64().unwrap() != bond_set.image[*b][k] as i64))
        .count();
    eprintln!(
        "{} bonds, {trap} with x_j − x_i < −L/2; plain createInteraction gets {wrong} images wrong",
        bond_set.len()
    );
    assert!(
        wrong > 0,
        "createInteraction got every image right: trap not exercised"
    );

    let fixed = res["fixed"].as_array().unwrap();
    assert_eq!(fixed.len(), bond_set.len());
    let v = |j: &serde_json::Value| {
        Vec3::new(
            j[0].as_f64().unwrap(),
            j[1].as_f64().unwrap(),
            j[2].as_f64().unwrap(),
        )
    };
    let mut worst: f64 = 0.0;
    for (b, f) in fixed.iter().enumerate() {
        assert_eq!(f["i"].as_u64(), Some(bond_set.i[b] as u64));
        assert_eq!(f["j"].as_u64(), Some(bond_set.j[b] as u64));
        let l = v(&f["branch"]);
        let err = (l - expected[b]).norm() / expected[b].norm();
        worst = worst.max(err);
        assert!(err < 1e-12, "bond {b}: YADE branch {l} vs {}", expected[b]);
        let n_err = (v(&f["normal"]) - expected[b].normalize()).norm();
        assert!(n_err < 1e-12, "bond {b}: normal");
        let ri = packing.radii[bond_set.i[b] as usize];
        let rj = packing.radii[bond_set.j[b] as usize];
        let pd = ri + rj - expected[b].norm();
        assert!((f["penetration"].as_f64().unwrap() - pd).abs() < 1e-12 * expected[b].norm());
    }
    eprintln!("worst relative branch-vector difference after the fix: {worst:.2e}");
    assert_eq!(
        res["real_after_20_steps"].as_u64(),
        Some(bond_set.len() as u64)
    );
    assert_eq!(
        res["interactions_after_20_steps"].as_u64(),
        Some(bond_set.len() as u64)
    );
}

/// A bond table whose image disagrees with its length·n (here: one bond's ix changed)
/// makes the YADE run fail loudly, naming the bond, instead of running a wrong model.
#[test]
fn a_bond_table_inconsistent_with_the_packing_fails_loudly() {
    if !yade_available("a_bond_table_inconsistent_with_the_packing_fails_loudly") {
        return;
    }
    let packing = crate::common::bonded::generated(100, 3);
    let model = Model::truszkowska_mrv();
    let bond_set = build_bonds(&packing, model.bonding).unwrap();
    let scheme = model.build_scheme(Some((&packing, &bond_set))).unwrap();
    let springs =
        bonds::assign_stiffness(&packing, &bond_set, scheme.as_ref(), &model.geometry).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let export = write_yade_export(
        dir.path(),
        &packing,
        &bond_set,
        &springs,
        None,
        &YadeRunOptions {
            steps: 5,
            ..Default::default()
        },
    )
    .unwrap();
    let table = std::fs::read_to_string(dir.path().join("bonds.csv")).unwrap();
    let mut lines: Vec<String> = table.lines().map(str::to_string).collect();
    let mut f: Vec<String> = lines[3].split(',').map(str::to_string).collect();
    let ix: i32 = f[11].parse().unwrap();
    f[11] = (ix + 1).to_string();
    lines[3] = f.join(",");
    std::fs::write(dir.path().join("bonds.csv"), lines.join("\n") + "\n").unwrap();
    let err = run_yade_script(&export.run_script, &[])
        .expect_err("YADE accepted a wrong image")
        .to_string();
    assert!(err.contains("BondMismatch"), "{err}");
    assert!(err.contains("1 of") && err.contains("bond 2 "), "{err}");
    assert!(!export.tensor.exists() && !export.history.exists());
}
