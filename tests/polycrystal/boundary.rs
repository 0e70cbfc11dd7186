//! The contact-point boundary rule (`boundary = "contact-point"`, docs/polycrystal.md): a bond
//! across a grain boundary takes the springs of the one grain whose Voronoi centre is nearer
//! to its mid-gap contact point, against a brute-force recomputation written here (contact
//! point from the positions and the bond's periodic image, minimum image by whole cells) and
//! the single crystals turned into each grain; bonds inside a grain are untouched by the
//! rule; its refusals are typed.

use super::common::bonded::generated;
use super::common::reference::nearest_centre;
use super::{cubic_model, model, rotation_key};
use anisobond::bonds::assign_stiffness_by_grain;
use anisobond::grains::{bunge_deg, nearest_centres, BoundaryRule, Grains};
use anisobond::prelude::*;

/// The springs (k_n, k_s, k_r, k_tw) of bond `b`.
fn springs(s: &BondStiffness, b: usize) -> [f64; 4] {
    [s.kn[b], s.ks[b], s.kr[b], s.ktw[b]]
}

/// The mid-gap contact point of bond `b`, from the positions and the bond's periodic image:
/// x_i + (R_i + gap/2)·l/|l|, l = x_j + image∘L − x_i.
fn contact_point(p: &Packing, bonds: &BondSet, b: usize) -> Vec3 {
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    let l_cell = p.cell.as_ref().unwrap().lengths;
    let shift = Vec3::new(
        bonds.image[b][0] as f64 * l_cell.x,
        bonds.image[b][1] as f64 * l_cell.y,
        bonds.image[b][2] as f64 * l_cell.z,
    );
    let branch = p.positions[j] + shift - p.positions[i];
    let len = branch.norm();
    let (ri, rj) = (p.radii[i], p.radii[j]);
    p.positions[i] + branch * ((ri + 0.5 * (len - ri - rj)) / len)
}

/// Bond by bond, `poly`'s springs against the brute force: a bond inside grain g has the
/// springs of `crystals[g]` (the single crystal turned into g); a bond across grains has
/// `factor` × the springs of the crystal of the nearest centre to its contact point.
/// Returns (bonds inside, bonds across, across bonds that took grain_j's springs).
fn check_against_brute_force(
    p: &Packing,
    bonds: &BondSet,
    grain: &[u32],
    centres: &[Vec3],
    poly: &BondStiffness,
    crystals: &[BondStiffness],
    factor: f64,
) -> (usize, usize, usize) {
    let l = p.cell.as_ref().unwrap().lengths;
    let (mut inside, mut across, mut took_j) = (0, 0, 0);
    for b in 0..bonds.len() {
        let (gi, gj) = (
            grain[bonds.i[b] as usize] as usize,
            grain[bonds.j[b] as usize] as usize,
        );
        let (g, f) = if gi == gj {
            inside += 1;
            (gi, 1.0)
        } else {
            across += 1;
            let g = nearest_centre(&contact_point(p, bonds, b), centres, Some(l));
            assert!(g == gi || g == gj, "two grains only");
            took_j += usize::from(g == gj);
            (g, factor)
        };
        let (got, want) = (springs(poly, b), springs(&crystals[g], b));
        for c in 0..4 {
            assert!(
                (got[c] - f * want[c]).abs() <= 1e-13 * want[c].abs(),
                "bond {b} (grains {gi}, {gj}; contact point in {g}) spring {c}: {} vs {}",
                got[c],
                f * want[c]
            );
        }
    }
    (inside, across, took_j)
}

/// Two seeded Voronoi grains through the model file: every bond across the boundary takes the
/// springs of the grain nearest to its contact point, times `boundary_factor`; bonds inside a
/// grain keep that grain's springs, whatever the rule.
#[test]
fn contact_point_rule_is_the_brute_force_nearest_centre_bond_by_bond() {
    let p = generated(2000, 33);
    let grains = "[grains]\ncount = 2\nseed = 3\nboundary_factor = 0.5\n";
    let poly = |rule: &str| {
        Assembly::new(
            p.clone(),
            model(&cubic_model(
                "",
                &format!("{grains}boundary = \"{rule}\"\n"),
            )),
        )
        .unwrap()
    };
    let a = poly("contact-point");
    let g = a.grains().unwrap();
    let centres = g.centres.clone().expect("Voronoi centres");
    let crystals: Vec<BondStiffness> = g
        .orientation
        .iter()
        .map(|o| {
            Assembly::new(p.clone(), model(&cubic_model(&rotation_key(o), "")))
                .unwrap()
                .springs
        })
        .collect();
    let (inside, across, took_j) =
        check_against_brute_force(&p, &a.bonds, &g.grain, &centres, &a.springs, &crystals, 0.5);
    // A plane boundary (two grains in a periodic cell: two planes) cuts a few hundred bonds;
    // equal-ish radii put the contact point near mid-bond, so either end's grain wins often.
    assert!(
        inside > 3000 && across > 100,
        "{inside} inside, {across} across"
    );
    assert!(
        took_j > across / 5 && took_j < across * 4 / 5,
        "{took_j} of {across} took grain_j"
    );
    // Bonds inside a grain do not depend on the rule: bit for bit the same under all three.
    for rule in ["mean", "series"] {
        let other = poly(rule);
        let mut differ = 0;
        for b in 0..a.bonds.len() {
            let same = springs(&a.springs, b).map(f64::to_bits)
                == springs(&other.springs, b).map(f64::to_bits);
            if g.grain[a.bonds.i[b] as usize] == g.grain[a.bonds.j[b] as usize] {
                assert!(same, "{rule}: bond {b} inside a grain changed");
            } else {
                differ += usize::from(!same);
            }
        }
        assert!(differ > across / 2, "{rule}: {differ} of {across} differ");
    }
}

/// Hand-placed centres on either side of a cell face, so the minimum image decides which grain
/// holds a contact point: the library's springs (its public `assign_stiffness_by_grain`) are
/// the brute force's, and a brute force without the minimum image would be wrong.
#[test]
fn contact_point_rule_takes_the_minimum_image_across_the_cell_faces() {
    let p = generated(1500, 44);
    let base = model(&cubic_model("", ""));
    let a = Assembly::new(p.clone(), base.clone()).unwrap();
    let l = p.cell.as_ref().unwrap().lengths;
    let centres = vec![
        Vec3::new(0.06 * l.x, 0.5 * l.y, 0.5 * l.z),
        Vec3::new(0.94 * l.x, 0.45 * l.y, 0.55 * l.z),
    ];
    let grain = nearest_centres(&p, &centres).unwrap();
    let orientation = vec![bunge_deg(30.0, 40.0, 50.0), bunge_deg(200.0, 70.0, 10.0)];
    let grains = Grains::new(grain.clone(), orientation.clone(), Some(centres.clone())).unwrap();
    let scheme = base.crystal_scheme(None).unwrap();
    let poly = assign_stiffness_by_grain(
        &p,
        &a.bonds,
        scheme.as_ref(),
        &base.geometry,
        &grains,
        BoundaryRule::ContactPoint,
        1.0,
    )
    .unwrap();
    let crystals: Vec<BondStiffness> = orientation
        .iter()
        .map(|o| {
            Assembly::new(p.clone(), model(&cubic_model(&rotation_key(o), "")))
                .unwrap()
                .springs
        })
        .collect();
    let (inside, across, took_j) =
        check_against_brute_force(&p, &a.bonds, &grain, &centres, &poly, &crystals, 1.0);
    assert!(
        inside > 1000 && across > 100,
        "{inside} inside, {across} across"
    );
    assert!(took_j > 0 && took_j < across, "{took_j} of {across}");
    // Without the minimum image the plane x = 0.5 L would split the cell: many contact points
    // would change grain.
    let wrong = (0..a.bonds.len())
        .filter(|&b| grain[a.bonds.i[b] as usize] != grain[a.bonds.j[b] as usize])
        .filter(|&b| {
            let x = contact_point(&p, &a.bonds, b);
            nearest_centre(&x, &centres, None) != nearest_centre(&x, &centres, Some(l))
        })
        .count();
    assert!(
        wrong > 10,
        "{wrong} boundary bonds decided by the minimum image"
    );
}

/// A grain file has no grain regions: the rule is refused when the model is read (a parse
/// error naming `boundary`) and by the library for a map without centres (`Error::Model`);
/// a misspelt rule is refused at its line; the rule is written back and read identically.
#[test]
fn contact_point_refusals_are_typed_and_the_rule_reads_back() {
    let text = cubic_model(
        "",
        "[grains]\nfile = \"ids.txt\"\nboundary = \"contact-point\"\n",
    );
    match Model::from_toml_str(&text, "model.toml") {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.starts_with("model.toml:"), "{m}");
            assert!(m.contains("boundary") && m.contains("contact-point"), "{m}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    let text = cubic_model("", "[grains]\ncount = 3\nboundary = \"contact_point\"\n");
    let line = text
        .lines()
        .position(|l| l.starts_with("boundary"))
        .unwrap()
        + 1;
    match Model::from_toml_str(&text, "model.toml") {
        Err(e @ Error::Parse { .. }) => {
            let m = e.to_string();
            assert!(m.starts_with(&format!("model.toml:{line}:")), "{m}");
            assert!(m.contains("boundary"), "{m}");
        }
        other => panic!("expected a parse error at line {line}, got {other:?}"),
    }
    // The library, given a user's map (no centres).
    let p = generated(300, 5);
    let base = model(&cubic_model("", ""));
    let a = Assembly::new(p.clone(), base.clone()).unwrap();
    let ids: Vec<u32> = (0..p.len()).map(|k| (k % 2) as u32).collect();
    let grains = Grains::new(ids, vec![bunge_deg(0.0, 0.0, 0.0); 2], None).unwrap();
    let scheme = base.crystal_scheme(None).unwrap();
    match assign_stiffness_by_grain(
        &p,
        &a.bonds,
        scheme.as_ref(),
        &base.geometry,
        &grains,
        BoundaryRule::ContactPoint,
        1.0,
    ) {
        Err(Error::Model(m)) => assert!(m.contains("contact-point"), "{m}"),
        other => panic!("expected Error::Model, got {other:?}"),
    }
    // Written back (TOML and JSON), the rule reads identically.
    let m = model(&cubic_model(
        "",
        "[grains]\ncount = 3\nboundary = \"contact-point\"\n",
    ));
    assert_eq!(
        m.grains.as_ref().unwrap().boundary,
        BoundaryRule::ContactPoint
    );
    assert_eq!(
        Model::from_toml_str(&m.to_toml_string(), "w.toml").unwrap(),
        m
    );
    assert_eq!(
        Model::from_json_str(&m.to_json_string(), "w.json").unwrap(),
        m
    );
}

/// A bicrystal with a `[strength]` table (cross-anisotropic bond strengths, Weibull scatter)
/// and `boundary_strength_factor = 0.6`: every bond across the boundary has exactly 0.6 × the
/// tensile, cohesion, bending and twisting strengths the table gives it without grains (the
/// friction unchanged), every bond inside a grain exactly those; the grains built again from
/// the table give the same bits; YADE's adhesions (a_n = σ_t r², a_s = c r²) carry the factor;
/// the model written back reads back with it.
#[test]
fn boundary_strength_factor_scales_the_strengths_of_boundary_bonds_only() {
    use anisobond::export::yade::yade_adhesions;
    use anisobond::grains::assign_strength_by_grain;
    use anisobond::strength::{assign_strength, StrengthSpec};
    let strength = "[strength]\nstrike_deg = 90.0\ndip_deg = 30.0\n\
                    [strength.bond]\ntensile = 5e6\ncohesion = 1e7\nfriction = 0.5\n\
                    [strength.along]\ntensile = 2e6\ncohesion = 6e6\n\
                    [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 9\n";
    let p = generated(1500, 21);
    let text = |factor: &str| {
        cubic_model(
            "",
            &format!("[grains]\ncount = 2\nseed = 3\n{factor}{strength}"),
        )
    };
    let a = Assembly::new(p.clone(), model(&text("boundary_strength_factor = 0.6\n"))).unwrap();
    let spec = StrengthSpec::from_table(a.model.strength.as_ref().unwrap()).unwrap();
    let grains_spec = a.model.grains.as_ref().unwrap();
    assert_eq!(grains_spec.boundary_strength_factor, 0.6);
    let g = &a.grains().unwrap().grain;
    let (pk, b) = (&a.packing, &a.bonds);
    let got = assign_strength_by_grain(pk, b, &spec, Some(grains_spec), a.grains()).unwrap();
    let rebuilt = assign_strength_by_grain(pk, b, &spec, Some(grains_spec), None).unwrap();
    assert_eq!(got, rebuilt);
    let base = assign_strength(pk, b, &spec).unwrap();
    let (mut inside, mut across) = (0, 0);
    for k in 0..b.len() {
        let (s, t) = (got.get(k), base.get(k));
        if g[b.i[k] as usize] == g[b.j[k] as usize] {
            inside += 1;
            assert_eq!(s, t, "bond {k} inside a grain");
        } else {
            across += 1;
            assert_eq!(s.tensile, 0.6 * t.tensile, "bond {k}: tensile");
            assert_eq!(s.cohesion, 0.6 * t.cohesion, "bond {k}: cohesion");
            assert_eq!(s.bending, 0.6 * t.bending, "bond {k}: bending");
            assert_eq!(s.twisting, 0.6 * t.twisting, "bond {k}: twisting");
            assert_eq!(s.friction, t.friction, "bond {k}: friction");
        }
    }
    println!("bicrystal: {inside} bonds inside a grain, {across} across the boundary");
    assert!(inside > 0 && across > 0);
    // The strengths differ bond to bond (scheme and scatter): the check is not of constants.
    assert!(base.tensile.iter().any(|&x| x != base.tensile[0]));

    // YADE's adhesions through the export path: the factor on boundary bonds only.
    let with = yade_adhesions(pk, b, &a.model).unwrap().unwrap();
    let plain = Assembly::new(p, model(&text(""))).unwrap();
    assert_eq!(
        plain
            .model
            .grains
            .as_ref()
            .unwrap()
            .boundary_strength_factor,
        1.0
    );
    let without = yade_adhesions(pk, b, &plain.model).unwrap().unwrap();
    for k in 0..b.len() {
        let f = if g[b.i[k] as usize] == g[b.j[k] as usize] {
            1.0
        } else {
            0.6
        };
        let close = |x: f64, y: f64| (x - f * y).abs() <= 1e-15 * y.abs();
        assert!(
            close(with[k].normal, without[k].normal),
            "bond {k}: normal adhesion"
        );
        assert!(
            close(with[k].shear, without[k].shear),
            "bond {k}: shear adhesion"
        );
    }

    // Written back (TOML and JSON), the model reads back with the factor.
    let again = Model::from_toml_str(&a.model.to_toml_string(), "back.toml").unwrap();
    assert_eq!(again, a.model);
    let again = Model::from_json_str(&a.model.to_json_string(), "back.json").unwrap();
    assert_eq!(again, a.model);
}
