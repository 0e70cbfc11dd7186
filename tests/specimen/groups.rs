//! Groups chosen by region or by ids, force control, reactions and the lateral confining
//! pressure, on simple-cubic blocks whose response is known in closed form: a chain of n
//! touching spheres along an axis is n − 1 springs k_n in series, and with isotropic springs
//! the rows along x, y and z do not interact under forces along the rows (no shear is
//! excited), so E = k_n/(2R) and ν = 0 exactly.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::specimen::{solve, Cylinder, Load, Platens, Selection, Shape, SpecimenOptions};
use anisobond::{Error, Vec3};

const R: f64 = 1e-3;
const KN: f64 = 2.0e6;
const KS: f64 = 0.7e6;

fn spring_model() -> Model {
    Model::from_toml_str(
        &format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
             normal = {KN}\nshear = {KS}\n[geometry]\nconvention = \"spring\"\n"
        ),
        "<test>",
    )
    .unwrap()
}

/// nx × ny × nz simple-cubic block of touching spheres of radius `R`, index (i ny + j) nz + k,
/// with ids 1000 + index when `ids`.
fn sc_block(nx: usize, ny: usize, nz: usize, ids: bool) -> Packing {
    let mut pos = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let n = pos.len();
    let mut p = Packing::new(pos, vec![R; n], None).unwrap();
    if ids {
        p.ids = Some((0..n as u64).map(|i| 1000 + i).collect());
    }
    p
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// The end layers chosen as a box, as a cylinder and by the user's ids give the same answer
/// as the default end layers; a moved group two layers deep shortens the free column to
/// nz − 2 springs: k = nx ny k_n / (nz − 2).
#[test]
fn groups_by_box_cylinder_and_ids_match_the_end_layers_and_the_closed_form() {
    let (nx, ny, nz) = (3, 4, 8);
    let asm = Assembly::new(sc_block(nx, ny, nz, true), spring_model()).unwrap();
    let top = (nz - 1) as f64 * 2.0 * R;
    let base = solve(&asm, &SpecimenOptions::new(2, 0.5 * R)).unwrap();
    let k1 = (nx * ny) as f64 * KN / (nz - 1) as f64;
    assert!(
        rel(base.platen_stiffness, k1) < 1e-10,
        "{}",
        base.platen_stiffness
    );
    let big = 1.0;
    let ids_of =
        |k: usize| -> Vec<u64> { (0..nx * ny).map(|c| 1000 + (c * nz + k) as u64).collect() };
    let cases: Vec<(Selection, Selection)> = vec![
        (
            Selection::Box {
                lo: Vec3::new(-big, -big, -0.5 * R),
                hi: Vec3::new(big, big, 0.5 * R),
            },
            Selection::Box {
                lo: Vec3::new(-big, -big, top - 0.5 * R),
                hi: Vec3::new(big, big, top + 0.5 * R),
            },
        ),
        (
            Selection::Cylinder(Cylinder {
                dim: 2,
                c1: 2.0 * R,
                c2: 3.0 * R,
                radius: 10.0 * R,
                lo: -0.5 * R,
                hi: 0.5 * R,
            }),
            Selection::Ids(ids_of(nz - 1)),
        ),
    ];
    for (held, moved) in cases {
        let mut o = SpecimenOptions::new(2, 0.5 * R);
        o.held = Some(held.clone());
        o.moved = Some(moved.clone());
        let r = solve(&asm, &o).unwrap();
        assert!(
            rel(r.platen_stiffness, base.platen_stiffness) < 1e-12,
            "{held:?} / {moved:?}: {}",
            r.platen_stiffness
        );
        assert_eq!((r.held_particles, r.moved_particles), (nx * ny, nx * ny));
    }
    // Moved group two layers deep (ids of the top two layers), bonded platens.
    let mut ids = ids_of(nz - 1);
    ids.extend(ids_of(nz - 2));
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.moved = Some(Selection::Ids(ids));
    o.platens = Platens::Bonded;
    let r = solve(&asm, &o).unwrap();
    let k2 = (nx * ny) as f64 * KN / (nz - 2) as f64;
    assert!(
        rel(r.platen_stiffness, k2) < 1e-10,
        "{} vs {k2}",
        r.platen_stiffness
    );
    // A cylinder picking only the middle column's top particle: a punch, softer.
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.moved = Some(Selection::Cylinder(Cylinder {
        dim: 2,
        c1: 2.0 * R,
        c2: 2.0 * R,
        radius: 0.5 * R,
        lo: top - 0.5 * R,
        hi: top + 0.5 * R,
    }));
    let r = solve(&asm, &o).unwrap();
    assert_eq!(r.moved_particles, 1);
    assert!(r.platen_stiffness < k1 && r.platen_stiffness >= KN / (nz - 1) as f64);
}

/// Force control: F on the moved group gives δ = F / k, k = nx ny k_n/(nz − 1); the held and
/// moved reactions balance, each F along the axis.
#[test]
fn force_control_gives_the_closed_form_shortening_and_balanced_reactions() {
    let (nx, ny, nz) = (2, 3, 6);
    let asm = Assembly::new(sc_block(nx, ny, nz, false), spring_model()).unwrap();
    let k = (nx * ny) as f64 * KN / (nz - 1) as f64;
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let mut o = SpecimenOptions::new(2, 0.5 * R);
        o.platens = platens;
        o.load = Load::Force(3.0);
        let r = solve(&asm, &o).unwrap();
        assert_eq!(r.control, "force");
        assert!(rel(r.displacement, 3.0 / k) < 1e-10, "{}", r.displacement);
        assert!(rel(r.axial_force, 3.0) < 1e-10);
        assert!(
            rel(r.moved_reaction[2], -3.0) < 1e-10,
            "{:?}",
            r.moved_reaction
        );
        assert!(
            rel(r.held_reaction[2], 3.0) < 1e-10,
            "{:?}",
            r.held_reaction
        );
        for d in 0..2 {
            assert!(
                r.held_reaction[d].abs() < 1e-9 && r.moved_reaction[d].abs() < 1e-9,
                "{platens:?}: {:?} {:?}",
                r.held_reaction,
                r.moved_reaction
            );
        }
        // Every top particle moved by −δ.
        for (p, x) in asm.packing.positions.iter().enumerate() {
            if r.layer[p] == 2 {
                assert!(rel(-r.displacement_field[p].z, r.displacement).abs() < 1e-12);
                assert!((x.z - (nz - 1) as f64 * 2.0 * R).abs() < 1e-15);
            }
        }
    }
    // Displacement control by length: δ = 1 µm.
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.load = Load::Displacement(1e-6);
    let r = solve(&asm, &o).unwrap();
    assert!(rel(r.axial_force, k * 1e-6) < 1e-10);
    // A load that moves nothing is refused, not answered with a zero field.
    for load in [Load::Force(0.0), Load::Displacement(0.0), Load::Strain(1.5)] {
        o.load = load;
        assert!(
            matches!(solve(&asm, &o), Err(Error::Invalid(_))),
            "{load:?}"
        );
    }
}

/// Overlapping groups, an empty group and an id the packing does not have are refused.
#[test]
fn bad_groups_are_refused() {
    let asm = Assembly::new(sc_block(2, 2, 5, true), spring_model()).unwrap();
    let all = Selection::Box {
        lo: Vec3::repeat(-1.0),
        hi: Vec3::repeat(1.0),
    };
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.moved = Some(all);
    let e = solve(&asm, &o).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("overlap")),
        "{e}"
    );
    o.moved = Some(Selection::Box {
        lo: Vec3::repeat(5.0),
        hi: Vec3::repeat(6.0),
    });
    let e = solve(&asm, &o).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("no particle")),
        "{e}"
    );
    o.moved = Some(Selection::Ids(vec![1000, 7]));
    let e = solve(&asm, &o).unwrap_err();
    assert!(matches!(&e, Error::Invalid(m) if m.contains("id 7")), "{e}");
}

/// A confining pressure p on the sides of a free simple-cubic block with frictionless
/// platens: every surface particle carries p (2R)² (the grid of one diameter matches the
/// lattice), every row along x and y is a chain of springs under that end force, so the
/// lateral strain is −p·2R/k_n exactly and superposes on the axial one (ν = 0); under force
/// control the platen force is what was asked. The cylinder rule loads the mantle with
/// p × its area, self-equilibrated.
#[test]
fn confining_pressure_on_a_simple_cubic_block_gives_the_closed_form_lateral_strain() {
    let (nx, ny, nz) = (4, 5, 7);
    let asm = Assembly::new(sc_block(nx, ny, nz, false), spring_model()).unwrap();
    let p = 3e5;
    let lateral = -p * 2.0 * R / KN;
    let k = (nx * ny) as f64 * KN / (nz - 1) as f64;
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.confining_pressure = Some(p);
    o.load = Load::Force(2.0);
    let r = solve(&asm, &o).unwrap();
    let c = r.confining.as_ref().unwrap();
    let face = |a: usize, b: usize| (a as f64 * 2.0 * R) * (b as f64 * 2.0 * R);
    assert!(rel(c.area, 2.0 * face(nx, nz) + 2.0 * face(ny, nz)) < 1e-12);
    assert_eq!(c.empty_cells, 0);
    assert!(c.correction < 1e-12, "{}", c.correction);
    // Surface particles: those on the four side faces.
    let on_side = |i: usize, j: usize| i == 0 || j == 0 || i == nx - 1 || j == ny - 1;
    assert_eq!(c.particles, (nx * ny - (nx - 2) * (ny - 2)) * nz);
    for (q, x) in asm.packing.positions.iter().enumerate() {
        let (i, j) = (
            (x.x / (2.0 * R)).round() as usize,
            (x.y / (2.0 * R)).round() as usize,
        );
        let f = r.confining_force[q];
        if on_side(i, j) {
            let ex = f64::from(u8::from(i == 0)) - f64::from(u8::from(i == nx - 1));
            let ey = f64::from(u8::from(j == 0)) - f64::from(u8::from(j == ny - 1));
            let expect = Vec3::new(ex, ey, 0.0) * p * 4.0 * R * R;
            assert!(
                (f - expect).norm() < 1e-9 * p * R * R,
                "{q}: {f:?} vs {expect:?}"
            );
        } else {
            assert_eq!(f, Vec3::zeros());
        }
    }
    assert!(rel(r.axial_force, 2.0) < 1e-10);
    assert!(rel(r.displacement, 2.0 / k) < 1e-10);
    for eps in r.lateral_strain {
        assert!(rel(eps, lateral) < 1e-9, "{eps} vs {lateral}");
    }
    assert!(r.poisson.abs() < 1e-10);
    // Every particle's lateral displacement relative to the support is ε_lat (x − x_s).
    let s = (0..asm.packing.len())
        .find(|&q| r.layer[q] == 1 && r.displacement_field[q].x == 0.0)
        .unwrap();
    let xs = asm.packing.positions[s];
    for (q, x) in asm.packing.positions.iter().enumerate() {
        let u = r.displacement_field[q];
        let tol = 1e-9 * lateral.abs() * R;
        assert!(
            (u.x - lateral * (x.x - xs.x)).abs() < tol
                && (u.y - lateral * (x.y - xs.y)).abs() < tol,
            "{q}: u {u:?} at {x:?}, support {s} at {xs:?}, lateral strain {lateral}"
        );
    }
    // The cylinder rule: p × mantle area in total, no net force.
    o.shape = Shape::Cylinder;
    let r = solve(&asm, &o).unwrap();
    let c = r.confining.as_ref().unwrap();
    let total: f64 = r.confining_force.iter().map(|f| f.norm()).sum();
    let net: Vec3 = r.confining_force.iter().sum();
    assert!(
        rel(total, p * c.area) < 0.1,
        "{total} vs {} ({} correction)",
        p * c.area,
        c.correction
    );
    assert!(net.norm() < 1e-12 * total, "{net:?}");
    assert!(r.lateral_strain.iter().all(|e| *e < 0.0));
}
