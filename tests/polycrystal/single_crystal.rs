//! A polycrystal reduces to the single crystal: one grain in the identity orientation, one
//! grain in orientation g against the crystal given `rotation = g`, isotropic grains against
//! the isotropic assembly, and boundary bonds against the mean of two single crystals.

use super::common::bonded::generated;
use super::{bits, cubic_model, isotropic_model, model, relaxed, rotation_key};
use anisobond::grains::bunge_deg;
use anisobond::prelude::*;

fn same_springs(a: &BondStiffness, b: &BondStiffness) -> bool {
    let columns = |k: &BondStiffness| -> Vec<u64> {
        [&k.radius, &k.kn, &k.ks, &k.kr, &k.ktw]
            .iter()
            .flat_map(|c| c.iter().map(|x| x.to_bits()))
            .collect()
    };
    columns(a) == columns(b)
}

/// One grain with the identity orientation (Bunge 0, 0, 0 from a file) gives the single
/// crystal's springs and relaxed tensor bit for bit.
#[test]
fn one_identity_grain_is_the_single_crystal_bit_for_bit() {
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("euler.txt"), "# phi1 Phi phi2\n0 0 0\n").unwrap();
    let path = dir.path().join("model.toml");
    std::fs::write(
        &path,
        cubic_model(
            "",
            "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"euler.txt\"\n",
        ),
    )
    .unwrap();
    let p = generated(800, 3);
    let poly = Assembly::new(p.clone(), Model::from_path(&path).unwrap()).unwrap();
    let single = Assembly::new(p, model(&cubic_model("", ""))).unwrap();
    let grains = poly.grains().expect("grains");
    assert_eq!(grains.len(), 1);
    assert!(grains.grain.iter().all(|&g| g == 0));
    assert!(same_springs(&poly.springs, &single.springs));
    assert_eq!(bits(&relaxed(&poly)), bits(&relaxed(&single)));
}

/// One grain in orientation g (Bunge 30°, 40°, 50°) is the cubic crystal whose own
/// `rotation` key is g (lab → crystal, the Bunge sense), bit for bit.
#[test]
fn one_rotated_grain_is_the_crystal_with_that_rotation_key() {
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("euler.txt"), "30, 40, 50\n").unwrap();
    let path = dir.path().join("model.toml");
    let grains = "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"euler.txt\"\n";
    std::fs::write(&path, cubic_model("", grains)).unwrap();
    let p = generated(800, 4);
    let poly = Assembly::new(p.clone(), Model::from_path(&path).unwrap()).unwrap();
    let g = bunge_deg(30.0, 40.0, 50.0);
    let single = Assembly::new(p, model(&cubic_model(&rotation_key(&g), ""))).unwrap();
    assert_eq!(poly.grains().unwrap().orientation[0], g);
    assert!(same_springs(&poly.springs, &single.springs));
    assert_eq!(bits(&relaxed(&poly)), bits(&relaxed(&single)));
    // The grain's turn composes on top of the model's own rotation: a model turned by h
    // with one grain g is the crystal turned by h·g.
    let h = bunge_deg(10.0, 20.0, 30.0);
    let text = cubic_model(&rotation_key(&h), grains);
    std::fs::write(&path, text).unwrap();
    let p = generated(800, 4);
    let both = Assembly::new(p.clone(), Model::from_path(&path).unwrap()).unwrap();
    let composed = Assembly::new(p, model(&cubic_model(&rotation_key(&(h * g)), ""))).unwrap();
    for b in 0..both.bonds.len() {
        let (x, y) = (both.springs.kn[b], composed.springs.kn[b]);
        assert!((x - y).abs() <= 1e-12 * y, "bond {b}: {x} vs {y}");
    }
}

/// The cross-anisotropic scheme (its lattice scaling μ from the packing) in one grain g is
/// the scheme with axis gᵀ·a: (g·n)·a = n·(gᵀa).
#[test]
fn one_rotated_cross_anisotropic_grain_turns_the_axis() {
    let cross = |axis: [f64; 3], tables: &str| {
        format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
             C11 = 30e9\nC33 = 15e9\nC13 = 6e9\nC12 = 8e9\naxis = [{:?}, {:?}, {:?}]\n{tables}",
            axis[0], axis[1], axis[2]
        )
    };
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("euler.txt"), "30 40 50\n").unwrap();
    let path = dir.path().join("model.toml");
    let grains = "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"euler.txt\"\n";
    std::fs::write(&path, cross([0.0, 0.0, 1.0], grains)).unwrap();
    let p = generated(800, 5);
    let poly = Assembly::new(p.clone(), Model::from_path(&path).unwrap()).unwrap();
    let a = bunge_deg(30.0, 40.0, 50.0).transpose() * Vec3::z();
    let single = Assembly::new(p, model(&cross([a.x, a.y, a.z], ""))).unwrap();
    for (x, y) in [
        (&poly.springs.kn, &single.springs.kn),
        (&poly.springs.ks, &single.springs.ks),
    ] {
        for b in 0..x.len() {
            assert!(
                (x[b] - y[b]).abs() <= 1e-12 * y[b],
                "bond {b}: {} vs {}",
                x[b],
                y[b]
            );
        }
    }
}

/// Isotropic grains, many and randomly turned, are the isotropic assembly exactly: springs
/// and relaxed tensor bit for bit.
#[test]
fn isotropic_grains_are_the_isotropic_assembly_exactly() {
    let p = generated(1000, 6);
    let poly = Assembly::new(
        p.clone(),
        model(&isotropic_model("[grains]\ncount = 60\nseed = 11\n")),
    )
    .unwrap();
    let single = Assembly::new(p, model(&isotropic_model(""))).unwrap();
    let g = poly.grains().unwrap();
    assert_eq!(g.len(), 60);
    let boundary = (0..poly.bonds.len())
        .filter(|&b| g.grain[poly.bonds.i[b] as usize] != g.grain[poly.bonds.j[b] as usize])
        .count();
    assert!(boundary > 100, "{boundary} boundary bonds");
    assert!(same_springs(&poly.springs, &single.springs));
    assert_eq!(bits(&relaxed(&poly)), bits(&relaxed(&single)));
}

/// A user's grain map and Bunge angles (relative paths, against the model file's folder):
/// a bond inside grain g has the springs of the crystal turned by g; a bond across grains g,
/// h the mean of both crystals' springs times `boundary_factor`.
#[test]
fn grain_files_and_the_boundary_rule_against_single_crystals() {
    boundary_rule_against_single_crystals("", |x, y| 0.5 * (x + y) * 0.5);
    // The series rule: the bond's two halves in series (a spring both grains leave at 0,
    // e.g. no rotational spring, stays 0).
    boundary_rule_against_single_crystals("boundary = \"series\"\n", |x, y| {
        if x + y > 0.0 {
            2.0 * x * y / (x + y) * 0.5
        } else {
            0.0
        }
    });
}

/// [`grain_files_and_the_boundary_rule_against_single_crystals`] with `rule` added to the
/// table and `across(k_g, k_h)` the expected spring of a boundary bond.
fn boundary_rule_against_single_crystals(rule: &str, across: fn(f64, f64) -> f64) {
    let p = generated(600, 8);
    let dir = super::common::tmp();
    let sub = dir.path().join("models");
    std::fs::create_dir(&sub).unwrap();
    let ids: Vec<u32> = (0..p.len()).map(|k| (k % 3) as u32).collect();
    let text: String = ids.iter().map(|g| format!("{g}\n")).collect();
    std::fs::write(sub.join("ids.txt"), format!("# grain per particle\n{text}")).unwrap();
    let angles = [[0.0, 0.0, 0.0], [45.0, 30.0, 10.0], [120.0, 80.0, 250.0]];
    let euler: String = angles
        .iter()
        .map(|a| format!("{} {} {}\n", a[0], a[1], a[2]))
        .collect();
    std::fs::write(sub.join("euler.txt"), euler).unwrap();
    let path = sub.join("model.toml");
    std::fs::write(
        &path,
        cubic_model(
            "",
            &format!(
                "[grains]\nfile = \"ids.txt\"\norientation = \"euler-file\"\n\
                 euler_file = \"euler.txt\"\nboundary_factor = 0.5\n{rule}"
            ),
        ),
    )
    .unwrap();
    let poly = Assembly::new(p.clone(), Model::from_path(&path).unwrap()).unwrap();
    assert_eq!(poly.grains().unwrap().grain, ids);
    let crystals: Vec<Assembly> = angles
        .iter()
        .map(|a| {
            let g = bunge_deg(a[0], a[1], a[2]);
            Assembly::new(p.clone(), model(&cubic_model(&rotation_key(&g), ""))).unwrap()
        })
        .collect();
    let (mut inside, mut crossing) = (0, 0);
    for b in 0..poly.bonds.len() {
        let (gi, gj) = (
            ids[poly.bonds.i[b] as usize] as usize,
            ids[poly.bonds.j[b] as usize] as usize,
        );
        let k = |a: &Assembly| {
            [
                a.springs.kn[b],
                a.springs.ks[b],
                a.springs.kr[b],
                a.springs.ktw[b],
            ]
        };
        let expected = if gi == gj {
            inside += 1;
            k(&crystals[gi])
        } else {
            crossing += 1;
            let (x, y) = (k(&crystals[gi]), k(&crystals[gj]));
            [0, 1, 2, 3].map(|c| across(x[c], y[c]))
        };
        let got = k(&poly);
        for c in 0..4 {
            assert!(
                (got[c] - expected[c]).abs() <= 1e-13 * expected[c].abs(),
                "bond {b} ({gi}, {gj}) spring {c}: {} vs {}",
                got[c],
                expected[c]
            );
        }
    }
    assert!(
        inside > 100 && crossing > 100,
        "{inside} inside, {crossing} across"
    );
}
