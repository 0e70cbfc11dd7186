//! Simple-cubic columns under uniaxial load (E = k_n/(2R), ν = 0, platen stiffness
//! n_x n_y k_n/(n_z − 1), whatever the platens); the work of the platen force equals the
//! strain energy summed bond by bond; a random specimen loaded along y equals the same
//! specimen turned so that y becomes z.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::specimen::{solve, Platens, SpecimenOptions};
use anisobond::Vec3;

const R: f64 = 1e-3;
const KN: f64 = 2.0e6;
const KS: f64 = 0.7e6;

/// Isotropic springs k_n = `KN`, k_s = `KS` (N/m, `spring` convention), bonds between touching
/// neighbours.
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

/// An nx × ny × nz simple-cubic block of touching spheres of radius `R` (free, no cell).
fn sc_block(nx: usize, ny: usize, nz: usize) -> Packing {
    let mut pos = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let n = pos.len();
    Packing::new(pos, vec![R; n], None).unwrap()
}

#[test]
fn simple_cubic_column_gives_the_closed_form_for_either_platens() {
    let (nx, ny, nz) = (3, 4, 9);
    let asm = Assembly::new(sc_block(nx, ny, nz), spring_model()).unwrap();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let mut o = SpecimenOptions::new(2, 0.5 * R);
        o.platens = platens;
        let r = solve(&asm, &o).unwrap();
        let k_closed = (nx * ny) as f64 * KN / (nz - 1) as f64;
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(
            rel(r.platen_stiffness, k_closed) < 1e-10,
            "{platens:?}: {} vs {k_closed}",
            r.platen_stiffness
        );
        assert!(
            rel(r.young, KN / (2.0 * R)) < 1e-10,
            "{platens:?}: E = {}",
            r.young
        );
        assert!(
            r.poisson.abs() < 1e-10 && r.poisson_lateral.iter().all(|v| v.abs() < 1e-10),
            "{:?}",
            r.poisson_lateral
        );
        assert!(rel(r.held_force, r.axial_force) < 1e-10);
        assert_eq!((r.held_particles, r.moved_particles), (nx * ny, nx * ny));
        assert_eq!(r.loaded_particles, nx * ny * nz);
    }
}

/// Random specimen (a cube cut from a generated packing, read as free): the platen work
/// ½Fδ equals ½ΣΔᵀSΔ over the bonds, recomputed here from the displacement field; the
/// bonded platens are stiffer than the frictionless ones; loading along y equals loading
/// along z of the same spheres turned by a quarter turn about x.
#[test]
fn random_specimen_energy_platen_order_and_turning() {
    let p = crate::common::bonded::generated(1200, 3);
    let free = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    let model = Model::truszkowska_mrv();
    let iso = Model::from_toml_str(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\nnormal = 1e13\nshear = 4e12\n",
        "<test>",
    )
    .unwrap();
    let asm = Assembly::new(free.clone(), model).unwrap();
    let mean_r = free.radii.iter().sum::<f64>() / free.len() as f64;
    let o = SpecimenOptions::new(2, mean_r);
    let r = solve(&asm, &o).unwrap();
    // Energy: Δ = (u_j + ω_j × (−r_j n)) − (u_i + ω_i × (r_i n)), mid-gap arms.
    let mut energy = 0.0;
    for b in (0..asm.bonds.len()).filter(|&b| r.bond_loaded[b]) {
        let (i, j) = (asm.bonds.i[b] as usize, asm.bonds.j[b] as usize);
        let n = asm.bonds.normal[b];
        let gap = asm.bonds.length[b] - free.radii[i] - free.radii[j];
        let (ri, rj) = (free.radii[i] + 0.5 * gap, free.radii[j] + 0.5 * gap);
        let d = (r.displacement_field[j] + r.rotation_field[j].cross(&(-n * rj)))
            - (r.displacement_field[i] + r.rotation_field[i].cross(&(n * ri)));
        let dn = n.dot(&d);
        energy +=
            0.5 * (asm.springs.kn[b] * dn * dn + asm.springs.ks[b] * (d - n * dn).norm_squared());
    }
    // A compressed isotropic-like solid widens: ν > 0 (the periodic tensor's is about 0.23).
    assert!(r.poisson > 0.1 && r.poisson < 0.4, "nu = {}", r.poisson);
    let work = 0.5 * r.axial_force * r.displacement;
    assert!(
        ((energy - work) / work).abs() < 1e-8,
        "energy {energy} vs work {work}"
    );
    let mut ob = o;
    ob.platens = Platens::Bonded;
    let rb = solve(&asm, &ob).unwrap();
    assert!(
        rb.platen_stiffness > r.platen_stiffness,
        "bonded {} <= frictionless {}",
        rb.platen_stiffness,
        r.platen_stiffness
    );
    // Quarter turn about x: (x, y, z) → (x, −z, y): the old y axis becomes z. An isotropic
    // scheme turns with the spheres.
    let a_iso = Assembly::new(free.clone(), iso.clone()).unwrap();
    let turned = Packing::new(
        free.positions
            .iter()
            .map(|x| Vec3::new(x.x, -x.z, x.y))
            .collect(),
        free.radii.clone(),
        None,
    )
    .unwrap();
    let a_turned = Assembly::new(turned, iso).unwrap();
    let along_y = solve(&a_iso, &SpecimenOptions::new(1, mean_r)).unwrap();
    let along_z = solve(&a_turned, &SpecimenOptions::new(2, mean_r)).unwrap();
    let rel =
        (along_y.platen_stiffness - along_z.platen_stiffness).abs() / along_z.platen_stiffness;
    assert!(
        rel < 1e-9,
        "y {} vs turned z {}",
        along_y.platen_stiffness,
        along_z.platen_stiffness
    );
}

/// Two blocks with no bond between them: no bonded path joins the layers, refused as
/// degenerate; a periodic packing is refused as not a specimen.
#[test]
fn a_specimen_that_falls_apart_or_is_periodic_is_refused() {
    let mut pos = sc_block(2, 2, 3).positions;
    let n0 = pos.len();
    pos.extend(
        sc_block(2, 2, 3)
            .positions
            .iter()
            .map(|x| x + Vec3::new(0.0, 0.0, 8.0 * R)),
    );
    let n = pos.len();
    assert_eq!(n, 2 * n0);
    let asm = Assembly::new(Packing::new(pos, vec![R; n], None).unwrap(), spring_model()).unwrap();
    let e = solve(&asm, &SpecimenOptions::new(2, 0.5 * R)).unwrap_err();
    assert!(matches!(e, anisobond::Error::Degenerate(_)), "{e}");
    let periodic = crate::common::bonded::generated(300, 1);
    let asm = Assembly::new(periodic, Model::truszkowska_mrv()).unwrap();
    let e = solve(&asm, &SpecimenOptions::new(2, 1e-3)).unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
}
