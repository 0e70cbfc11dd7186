//! Cutting free bars out of periodic packings: against the source positions, the region's
//! own inequalities and the packing's density.

use anisobond::packing::{cut, Region};
use anisobond::packing::{prepare, PreparationRoute, RouteOptions};
use anisobond::Vec3;
use std::f64::consts::PI;

fn periodic(n: usize) -> anisobond::packing::Packing {
    let o = RouteOptions {
        route: PreparationRoute::Unjammed,
        n_particles: n,
        seed: 3,
        ..RouteOptions::default()
    };
    prepare(&o, &|_| {}).unwrap().0
}

/// A cylinder four cells long: every kept centre is a periodic image of its source, lies
/// inside the region, and the count matches N/V_cell × πr²l within 5 %.
#[test]
fn cylinder_longer_than_cell_tiles_images() {
    let p = periodic(600);
    let cell = p.cell.unwrap();
    let side = cell.lengths.x;
    let r = 0.3 * side;
    let l = 4.0 * side;
    let region = Region::Cylinder {
        centre: Vec3::new(0.5 * side, 0.5 * side, 0.0),
        axis: Vec3::z(),
        radius: r,
        length: l,
    };
    let c = cut(&p, &region).unwrap();
    assert!(c.packing.cell.is_none());
    for (k, x) in c.packing.positions.iter().enumerate() {
        let src = p.positions[c.source[k] as usize] + cell.shift(c.image[k]);
        assert!((src - x).norm() < 1e-15 * side.max(1.0));
        let d = x - Vec3::new(0.5 * side, 0.5 * side, 0.0);
        assert!(d.z.abs() <= 0.5 * l && (d.x * d.x + d.y * d.y).sqrt() <= r);
    }
    // Brute force: the same set as testing every image in a wide range.
    let mut brute = 0;
    for s in -4..=4 {
        for q in &p.positions {
            let y = q + cell.shift([0, 0, s]);
            let d = y - Vec3::new(0.5 * side, 0.5 * side, 0.0);
            if d.z.abs() <= 0.5 * l && (d.x * d.x + d.y * d.y).sqrt() <= r {
                brute += 1;
            }
        }
    }
    assert_eq!(brute, c.packing.len());
    let expected = p.len() as f64 / cell.volume() * PI * r * r * l;
    let rel = (c.packing.len() as f64 - expected).abs() / expected;
    assert!(
        rel < 0.05,
        "{} kept, {expected:.0} expected",
        c.packing.len()
    );
    assert!(c.image.iter().any(|i| i[2] < 0) && c.image.iter().any(|i| i[2] > 0));
}

/// End sets: exactly the centres within the depth of each end face; the surface set the
/// centres within the depth of the mantle.
#[test]
fn boundary_sets_follow_their_definition() {
    let p = periodic(600);
    let side = p.cell.unwrap().lengths.x;
    let rbar = p.mean_radius();
    let region = Region::Cylinder {
        centre: Vec3::new(0.5 * side, 0.5 * side, 0.5 * side),
        axis: Vec3::z(),
        radius: 0.4 * side,
        length: 2.0 * side,
    };
    let c = cut(&p, &region).unwrap();
    let b = c.boundary(rbar).unwrap();
    let z0 = 0.5 * side - side;
    for (k, x) in c.packing.positions.iter().enumerate() {
        let t = x.z - z0;
        let rho = ((x.x - 0.5 * side).powi(2) + (x.y - 0.5 * side).powi(2)).sqrt();
        assert_eq!(b.first_end.contains(&(k as u32)), t <= rbar);
        assert_eq!(b.second_end.contains(&(k as u32)), t >= 2.0 * side - rbar);
        assert_eq!(b.surface.contains(&(k as u32)), 0.4 * side - rho <= rbar);
    }
    assert!(!b.first_end.is_empty() && !b.second_end.is_empty());
}

/// A box cut of a free packing is a filter; bad regions are refused by name.
#[test]
fn box_and_refusals() {
    let p = periodic(300);
    let side = p.cell.unwrap().lengths.x;
    let region = Region::Box {
        lo: Vec3::zeros(),
        hi: Vec3::new(side, side, 0.5 * side),
        axis: 2,
    };
    let c = cut(&p, &region).unwrap();
    let direct = p.positions.iter().filter(|x| x.z <= 0.5 * side).count();
    assert_eq!(c.packing.len(), direct);
    let again = cut(&c.packing, &region).unwrap();
    assert_eq!(again.packing.len(), c.packing.len());
    let bad = Region::Cylinder {
        centre: Vec3::zeros(),
        axis: Vec3::new(1.0, 1.0, 0.0),
        radius: 1.0,
        length: 1.0,
    };
    assert!(cut(&p, &bad)
        .unwrap_err()
        .to_string()
        .contains("unit vector"));
    let empty = Region::Box {
        lo: Vec3::repeat(1e3),
        hi: Vec3::repeat(1e3 + 1e-9),
        axis: 0,
    };
    assert!(cut(&p, &empty)
        .unwrap_err()
        .to_string()
        .contains("at least 2"));
}

/// Šmilauer's cross-anisotropic scheme with the tilted axis (strike 270°, dip 25°): every
/// bond of a bar cut by `Assembly::cut` has the springs of the periodic assembly's bond
/// between the same source spheres (found through the cut's index map), so the lattice
/// scaling μ is the material's, not the bar's bounding box's.
#[test]
fn cut_bar_keeps_the_materials_springs() {
    use anisobond::assembly::Assembly;
    use anisobond::model::Model;
    use std::collections::HashMap;
    let text = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
                C11 = 30e9\nC33 = 12e9\nC13 = 5e9\nC12 = 8e9\nstrike_deg = 270\ndip_deg = 25\n\
                [geometry]\nconvention = \"modulus\"\n";
    let model = Model::from_toml_str(text, "cross").unwrap();
    let o = RouteOptions {
        route: PreparationRoute::WeaklyJammed,
        n_particles: 600,
        seed: 2,
        ..RouteOptions::default()
    };
    let p = prepare(&o, &|_| {}).unwrap().0;
    let side = p.cell.unwrap().lengths.x;
    let periodic = Assembly::new(p.clone(), model.clone()).unwrap();
    let mut kn = HashMap::new();
    for b in 0..periodic.bonds.len() {
        let key = (periodic.bonds.i[b], periodic.bonds.j[b]);
        kn.insert(key, periodic.springs.kn[b]);
    }
    let region = Region::Cylinder {
        centre: Vec3::new(0.5 * side, 0.5 * side, 0.5 * side),
        axis: Vec3::z(),
        radius: 0.3 * side,
        length: 0.9 * side,
    };
    let (bar, c) = Assembly::cut(&p, &region, model).unwrap();
    assert!(bar.bonds.len() > 100);
    for b in 0..bar.bonds.len() {
        let (i, j) = (
            c.source[bar.bonds.i[b] as usize],
            c.source[bar.bonds.j[b] as usize],
        );
        let k = kn[&(i.min(j), i.max(j))];
        assert!((bar.springs.kn[b] / k - 1.0).abs() < 1e-12, "bond {b}");
    }
}

/// `RoundBar::imperfect`: every centre moves by amplitude × its mode vector, the bonds
/// (same pairs, same springs) take the moved centres' lengths and normals (a stress-free
/// imperfect bar); amplitude 0 changes nothing; bad modes and amplitudes are refused.
#[test]
fn imperfect_bar_moves_centres_along_the_mode() {
    use anisobond::homogenize::RoundBar;
    let p = periodic(600);
    let rbar = p.mean_radius();
    let model = anisobond::model::Model::from_toml_str(
        "[bonding]\nrule = \"factor\"\nvalue = 1.0\n[scheme]\nkind = \"isotropic\"\nnormal = 1e8\n\
         shear = 2e7\n[geometry]\nconvention = \"kumar\"\nmoments = \"kumar\"\n",
        "kumar",
    )
    .unwrap();
    let bar = RoundBar::cut(&p, model, 4.0 * rbar, 8.0, rbar).unwrap();
    let l = bar.length;
    let mode: Vec<Vec3> = bar
        .assembly
        .packing
        .positions
        .iter()
        .map(|x| Vec3::new((PI * x.z / l).sin(), 0.0, 0.0))
        .collect();
    let amp = 0.1 * rbar;
    let imp = bar.imperfect(&mode, amp).unwrap();
    let moved = imp.assembly.packing.positions.iter();
    for ((x1, x0), m) in moved.zip(&bar.assembly.packing.positions).zip(&mode) {
        assert!(((x1 - x0) - m * amp).norm() < 1e-15 * l);
    }
    let (b0, b1) = (&bar.assembly.bonds, &imp.assembly.bonds);
    assert_eq!((&b0.i, &b0.j), (&b1.i, &b1.j));
    assert_eq!(bar.assembly.springs.kn, imp.assembly.springs.kn);
    for b in 0..b1.len() {
        let x = &imp.assembly.packing.positions;
        let branch = x[b1.j[b] as usize] - x[b1.i[b] as usize];
        assert!((branch - b1.normal[b] * b1.length[b]).norm() < 1e-12 * b1.length[b]);
    }
    let same = bar.imperfect(&mode, 0.0).unwrap();
    assert_eq!(
        same.assembly.packing.positions,
        bar.assembly.packing.positions
    );
    assert_eq!(same.assembly.bonds.length, bar.assembly.bonds.length);
    assert!(bar.imperfect(&mode[1..], amp).is_err());
    assert!(bar.imperfect(&mode, -amp).is_err());
    assert!(bar.imperfect(&mode, f64::NAN).is_err());
}
