//! YADE breaks bonds with anisobond's strengths (issue 32, item 5): a bonded simple-cubic bar
//! (3 × 3 × 8 touching spheres, R = 1 mm, in a large periodic cell so no bond crosses it) with
//! a `[strength]` table — bonds σ_t = 5 MPa, c = 10 MPa, μ = 0.5, and a plane of weakness
//! z = 17 mm between layers 3 and 4 with σ_t = 2 MPa, c_w = 4 MPa, μ_w = 0.6 — exported by
//! `anisobond export yade`, built by the exported module and pulled by YADE 2023.02a in the
//! test (`strength_tension.py`: bottom layer held, top layer moved at constant speed,
//! Cundall damping 0.4).
//!
//! Compared against: the adhesion columns worked by hand (YADE's a_n = σ_t·r², a_s = c·r²,
//! r = min radius); the peak force against the closed form bonds per section × a_n of the
//! joint, 9 × 2 MPa × R² = 18 N; the bonds YADE broke against those anisobond's own criterion
//! (`yade_cohfrict` on `assign_strength`'s strengths) breaks at the measured peak; the same
//! bar without `[strength]`: the plain bond table (the same rows less the three columns) and
//! a run past twice the joint's limit with no bond lost.

use crate::common::yade::yade_available;
use crate::common::{bin, succeeds, tmp, write};
use anisobond::bonds::read_bond_table_of;
use anisobond::export::yade::run_yade_script;
use anisobond::model::Model;
use anisobond::packing::read_packing;
use anisobond::strength::assign_strength;
use anisobond::strength::criteria::{yade_cohfrict, LocalLoads, YadeAdhesion};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The SPEC bond table's header (docs/formats.md).
const HEADER: &str = "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz";
const R: f64 = 1e-3;
const D: f64 = 2.0 * R;
/// Plane of weakness z = offset, between layers k = 3 (z = 16 mm) and k = 4 (18 mm).
const PLANE_Z: f64 = 0.017;
const BOND: (f64, f64, f64) = (5.0e6, 1.0e7, 0.5);
const JOINT: (f64, f64, f64) = (2.0e6, 4.0e6, 0.6);
/// Bonds across a section of the 3 × 3 bar.
const PER_SECTION: f64 = 9.0;

const MODEL: &str = r#"
[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "isotropic"
normal = 1.0e12
shear = 0.5e12
"#;

fn strength_table() -> String {
    format!(
        "[strength]\n[strength.bond]\ntensile = {:e}\ncohesion = {:e}\nfriction = {}\n\
         [[strength.planes]]\nnormal = [0.0, 0.0, 1.0]\nspacing = 10.0\noffset = {PLANE_Z}\n\
         tensile = {:e}\ncohesion = {:e}\nfriction = {}\n",
        BOND.0, BOND.1, BOND.2, JOINT.0, JOINT.1, JOINT.2
    )
}

/// The bar: layers k = 0..8 along z at 10 mm + k·D, in a 0.1 m periodic cell.
fn packing_text() -> String {
    let mut s = "# periodic 0.1 0.1 0.1\n".to_string();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..8 {
                let p = |n: i32| 0.01 + n as f64 * D;
                s.push_str(&format!("{:?} {:?} {:?} {R:?}\n", p(i), p(j), p(k)));
            }
        }
    }
    s
}

/// `anisobond export yade` of the bar with `model` into `dir/name`.
fn export(dir: &Path, name: &str, model: &str) -> PathBuf {
    let packing = write(dir, "packing.txt", &packing_text());
    let model = write(dir, &format!("{name}.toml"), model);
    let out = dir.join(name);
    succeeds(
        bin()
            .args(["export", "yade"])
            .arg(&packing)
            .arg("--model")
            .arg(&model)
            .arg("-o")
            .arg(&out),
    );
    out
}

/// The CSV as rows of fields (header first).
fn csv(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// Pull the exported bar in YADE: `reach` N per column in ~40,000 steps, at most `cap` steps.
fn pull(dir: &Path, reach: f64, cap: u32) -> Value {
    let script = dir.join("strength_tension.py");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/yade/strength_tension.py"),
        &script,
    )
    .unwrap();
    let out = dir.join("out.json");
    run_yade_script(
        &script,
        &[
            dir.display().to_string(),
            out.display().to_string(),
            reach.to_string(),
            cap.to_string(),
        ],
    )
    .expect("yade run");
    serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap()
}

fn pairs(v: &Value) -> BTreeSet<(u32, u32)> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_u64().unwrap() as u32, p[1].as_u64().unwrap() as u32))
        .collect()
}

#[test]
fn bar_in_direct_tension_breaks_at_the_joints_adhesion() {
    if !yade_available("strength_tension::bar_in_direct_tension_breaks_at_the_joints_adhesion") {
        return;
    }
    let t = tmp();
    let model_text = format!("{MODEL}{}", strength_table());
    let dir = export(t.path(), "strong", &model_text);

    // The adhesion columns, by hand: joint bonds (axial, crossing z = 17 mm) take the joint's
    // strengths, all others the bond's; a_n = σ_t·R², a_s = c·R² (equal radii).
    let rows = csv(&dir.join("bonds.csv"));
    assert_eq!(
        rows[0].join(","),
        format!("{HEADER},normal_adhesion,shear_adhesion,tan_friction")
    );
    let col = |name: &str| rows[0].iter().position(|c| c == name).unwrap();
    let (ci, cj, cz) = (col("i"), col("j"), col("nz"));
    let packing = read_packing(&dir.join("packing.txt")).unwrap();
    let mut joints = BTreeSet::new();
    for r in &rows[1..] {
        let (i, j): (usize, usize) = (r[ci].parse().unwrap(), r[cj].parse().unwrap());
        let (zi, zj) = (packing.positions[i].z, packing.positions[j].z);
        let crosses = (zi - PLANE_Z) * (zj - PLANE_Z) < 0.0;
        if crosses {
            assert!(r[cz].parse::<f64>().unwrap().abs() == 1.0);
            joints.insert((i as u32, j as u32));
        }
        let (st, c, mu) = if crosses { JOINT } else { BOND };
        let got: Vec<f64> = r[r.len() - 3..]
            .iter()
            .map(|w| w.parse().unwrap())
            .collect();
        let want = [st * R * R, c * R * R, mu];
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g - w).abs() <= 1e-12 * w,
                "bond {i}-{j}: {got:?} vs {want:?}"
            );
        }
    }
    assert_eq!(joints.len(), 9);

    let run = pull(&dir, 2.0 * JOINT.0 * R * R, 120_000);
    let peak = run["peak"].as_f64().unwrap();
    let closed = PER_SECTION * JOINT.0 * R * R;
    let err = (peak - closed).abs() / closed;
    println!(
        "YADE peak {peak:.9} N vs bonds per section × a_n = {closed} N: relative error {err:.2e} \
         (dt {:.3e} s, {} steps to the peak, parted at step {})",
        run["dt"].as_f64().unwrap(),
        run["peak_step"],
        run["parted_at"]
    );
    assert!(err <= 1e-3, "peak {peak} N vs {closed} N");
    assert!(run["parted_at"].as_u64().is_some(), "the bar did not part");
    assert!(run["final_force"].as_f64().unwrap().abs() <= 1e-3 * closed);
    assert!(run["fragile"].as_array().unwrap().iter().all(|f| f == true));

    // anisobond's criterion on its own strengths at the measured peak (each axial bond
    // carries peak/9, lateral bonds nothing): just above it exactly the joint bonds break,
    // just below it none.
    let (bonds, _) = read_bond_table_of(&dir.join("bonds.csv"), &packing).unwrap();
    let spec = Model::strength_from_str_for(&model_text, Path::new("model.toml"))
        .unwrap()
        .unwrap();
    let strengths = assign_strength(&packing, &bonds, &spec).unwrap();
    let predicted = |factor: f64| -> BTreeSet<(u32, u32)> {
        (0..bonds.len())
            .filter(|&b| {
                let axial = bonds.normal[b].z.abs() > 0.5;
                let loads = LocalLoads {
                    normal: if axial {
                        -factor * peak / PER_SECTION
                    } else {
                        0.0
                    },
                    ..LocalLoads::default()
                };
                let (ri, rj) = (
                    packing.radii[bonds.i[b] as usize],
                    packing.radii[bonds.j[b] as usize],
                );
                yade_cohfrict(&YadeAdhesion::of(&strengths.get(b), ri, rj, false), &loads).broken
            })
            .map(|b| (bonds.i[b], bonds.j[b]))
            .collect()
    };
    let broken = pairs(&run["broken"]);
    println!("YADE broke {} bonds: {broken:?}", broken.len());
    assert_eq!(broken, predicted(1.0 + 1e-3));
    assert_eq!(broken, joints);
    assert!(predicted(1.0 - 1e-3).is_empty());

    // Without [strength]: the plain table (the same rows without the three columns) and
    // bonds that never break, pulled to twice the joint's limit.
    let plain = export(t.path(), "plain", MODEL);
    let plain_rows = csv(&plain.join("bonds.csv"));
    assert_eq!(plain_rows[0].join(","), HEADER);
    assert_eq!(plain_rows.len(), rows.len());
    for (p, r) in plain_rows.iter().zip(&rows).skip(1) {
        assert_eq!(p[..], r[..r.len() - 3]);
    }
    let run = pull(&plain, 2.0 * JOINT.0 * R * R, 30_000);
    let reached = run["peak"].as_f64().unwrap();
    println!("without [strength]: {reached:.6} N reached, nothing broken");
    assert!(reached > 1.4 * closed, "{reached} N");
    assert!(pairs(&run["broken"]).is_empty());
    assert!(run["fragile"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f == false));
    assert!(run["normal_adhesion"]
        .as_array()
        .unwrap()
        .iter()
        .all(|a| a.as_f64().unwrap() == 1e300));
}
