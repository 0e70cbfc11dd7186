//! A long prism periodic across the axis (`Lateral::Periodic`): a periodic packing stacked
//! k times along z and cut at its z faces, loaded along z between frictionless platens. Away
//! from the platens the state is the periodic cell's uniform uniaxial stress, so the strain of
//! a copy in the middle — its particles' mean axial displacement less that of the same
//! particles one copy lower, over the copy's height — gives σ/ε = 1/S₃₃ of the periodic relaxed
//! tensor of the same packing, computed by the homogenization code (a different solve).

use anisobond::assembly::Assembly;
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions, RelaxedSolver};
use anisobond::model::Model;
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::specimen::{solve, Lateral, Platens, SpecimenOptions};
use anisobond::{Error, Vec3};

type Matrix6 = nalgebra::Matrix6<f64>;

/// `copies` copies of `p` stacked along z, in the box (Lx, Ly, copies·Lz) periodic along the
/// axes flagged in `periodic` (`[true; 3]`: the periodic cell; `[true, true, false]`: a slab,
/// `p p f`, whose z faces no bond crosses); particle q of copy c is c·n + q.
pub(crate) fn stacked_in(p: &Packing, copies: usize, periodic: [bool; 3]) -> Packing {
    let l = p.cell.unwrap().lengths;
    let mut pos = Vec::new();
    let mut radii = Vec::new();
    for c in 0..copies {
        for (x, r) in p.positions.iter().zip(&p.radii) {
            pos.push(x + Vec3::new(0.0, 0.0, c as f64 * l.z));
            radii.push(*r);
        }
    }
    let lengths = Vec3::new(l.x, l.y, copies as f64 * l.z);
    let cell = PeriodicCell::with_periodic(lengths, periodic).unwrap();
    Packing::new(pos, radii, Some(cell)).unwrap()
}

/// Middle-copy modulus σ/ε and the lateral Poisson's ratios −ε_lat/ε of a prism of `copies`
/// copies of `cube`, periodic across z.
/// The prism tests' periodic cube (400 generated spheres, Truszkowska's MRV model) and the
/// relaxed tensor C (direct solve, 1e-10) with its compliance S = C⁻¹.
pub(crate) fn cube_and_compliance() -> (Packing, Model, Matrix6, Matrix6) {
    let cube = crate::common::bonded::generated(400, 5);
    let model = Model::truszkowska_mrv();
    let one = Assembly::new(cube.clone(), model.clone()).unwrap();
    let relaxed = relaxed_tensor(
        &one.packing,
        &one.bonds,
        &one.springs,
        &RelaxedOptions {
            solver: RelaxedSolver::Cholesky,
            tolerance: 1e-10,
            ..Default::default()
        },
    )
    .unwrap();
    (cube, model, relaxed.c, relaxed.c.try_inverse().unwrap())
}

fn prism(cube: &Packing, model: &Model, copies: usize, platens: Platens) -> (f64, [f64; 2]) {
    prism_in(cube, model, copies, platens, [true; 3])
}

/// [`prism`] of the copies stacked in a box periodic along the axes flagged in `periodic`.
pub(crate) fn prism_in(
    cube: &Packing,
    model: &Model,
    copies: usize,
    platens: Platens,
    periodic: [bool; 3],
) -> (f64, [f64; 2]) {
    let n = cube.len();
    let lz = cube.cell.unwrap().lengths.z;
    let asm = Assembly::new(stacked_in(cube, copies, periodic), model.clone()).unwrap();
    let mean_r = cube.radii.iter().sum::<f64>() / n as f64;
    let mut o = SpecimenOptions::new(2, mean_r);
    o.lateral = Lateral::Periodic;
    o.platens = platens;
    let r = solve(&asm, &o).unwrap();
    assert_eq!(r.lateral, Lateral::Periodic);
    let l = cube.cell.unwrap().lengths;
    assert!(((r.area - l.x * l.y) / (l.x * l.y)).abs() < 1e-15);
    // The report's ratios: −ε_lat/ε_axial over the whole length, ε_axial = −δ/L.
    for d in 0..2 {
        let whole = r.lateral_strain[d] / (r.displacement / r.length);
        assert!((r.poisson_lateral[d] - whole).abs() < 1e-12 && whole >= 0.0);
    }
    let c = copies / 2;
    let shift: f64 = (0..n)
        .map(|q| r.displacement_field[c * n + q].z - r.displacement_field[(c - 1) * n + q].z)
        .sum::<f64>()
        / n as f64;
    let eps = -shift / lz;
    (
        r.axial_force / r.area / eps,
        [r.lateral_strain[0] / eps, r.lateral_strain[1] / eps],
    )
}

/// Frictionless platens: the lateral periods are shared by the whole length, so the cut ends
/// (which lack the bonds across the cut) shift the middle's lateral stress by O(1/length):
/// the middle-copy modulus converges to 1/S₃₃ like 1/k, and Richardson's extrapolation from
/// k and 2k copies removes that term. Bonded platens hold the periods: the middle is in
/// uniaxial strain, C₃₃, up to the platens' decaying disturbance.
#[test]
fn long_periodic_prism_reproduces_one_over_s33_of_the_relaxed_tensor() {
    let (cube, model, c, s) = cube_and_compliance();
    let e33 = 1.0 / s[(2, 2)];
    let nu = [-s[(0, 2)] / s[(2, 2)], -s[(1, 2)] / s[(2, 2)]];
    let (k1, k2) = (4usize, 8usize);
    let (e1, nu1) = prism(&cube, &model, k1, Platens::Frictionless);
    let (e2, nu2) = prism(&cube, &model, k2, Platens::Frictionless);
    let richardson = |a: f64, b: f64| (k2 as f64 * b - k1 as f64 * a) / (k2 - k1) as f64;
    let e_inf = richardson(e1, e2);
    let rel = |a: f64, b: f64| ((a - b) / b).abs();
    println!(
        "1/S33 {e33:.6e}: k = {k1}: {e1:.6e}, k = {k2}: {e2:.6e}, extrapolated {e_inf:.6e}; \
         nu {nu:?}: {nu1:?}, {nu2:?}"
    );
    // The 1/k term: halved from k1 to k2.
    let ratio = (e1 - e33) / (e2 - e33);
    assert!((1.6..2.4).contains(&ratio), "error ratio {ratio}");
    assert!(
        rel(e_inf, e33) < 1e-4,
        "extrapolated {e_inf} vs 1/S33 {e33}"
    );
    for d in 0..2 {
        let nu_inf = richardson(nu1[d], nu2[d]);
        assert!(
            (nu_inf - nu[d]).abs() < 1e-3 * nu[d].abs().max(0.1),
            "nu {d}: extrapolated {nu_inf} vs {}",
            nu[d]
        );
    }
    let (c_mid, lat) = prism(&cube, &model, 5, Platens::Bonded);
    assert_eq!(lat, [0.0, 0.0]);
    let c33 = c[(2, 2)];
    assert!(rel(c_mid, c33) < 1e-4, "{c_mid} vs C33 {c33}");
}

/// A periodic packing is refused as a free specimen, and a confining pressure has no free
/// surface to act on across a periodic prism.
#[test]
fn periodic_prism_refusals() {
    let cube = crate::common::bonded::generated(300, 2);
    let asm = Assembly::new(cube, Model::truszkowska_mrv()).unwrap();
    let mut o = SpecimenOptions::new(2, 1e-3);
    o.lateral = Lateral::Periodic;
    o.confining_pressure = Some(1e5);
    assert!(matches!(solve(&asm, &o), Err(Error::Invalid(m)) if m.contains("confining")));
    let free = crate::common::bonded::generated(300, 2);
    let free = Packing::new(free.positions, free.radii, None).unwrap();
    let asm = Assembly::new(free, Model::truszkowska_mrv()).unwrap();
    let mut o = SpecimenOptions::new(2, 1e-3);
    o.lateral = Lateral::Periodic;
    assert!(matches!(solve(&asm, &o), Err(Error::Invalid(m)) if m.contains("periodic")));
    // A simple-cubic block inside a cell twice its width: periodic by option, but no bond
    // crosses a lateral face, so its lateral strain is unmeasurable (not a ν of 0), and a
    // box periodic along x and y only (p p f) is refused by name, not solved as free.
    let r = 1e-3;
    let mut centres = Vec::new();
    for (i, j, k) in (0..3).flat_map(|i| (0..3).flat_map(move |j| (0..5).map(move |k| (i, j, k)))) {
        centres.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * 2.0 * r);
    }
    let n = centres.len();
    let springs = Model::from_toml_str(
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
         normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n",
        "<test>",
    )
    .unwrap();
    let wide = PeriodicCell::new(Vec3::new(12.0 * r, 12.0 * r, 10.0 * r)).unwrap();
    let block = Packing::new(centres.clone(), vec![r; n], Some(wide)).unwrap();
    let asm = Assembly::new(block, springs.clone()).unwrap();
    let mut o = SpecimenOptions::new(2, 0.5 * r);
    o.lateral = Lateral::Periodic;
    assert!(
        matches!(solve(&asm, &o), Err(Error::Degenerate(m)) if m.contains("no loaded bond crosses")),
        "{:?}",
        solve(&asm, &o).map(|r| r.poisson)
    );
    let bed =
        PeriodicCell::with_periodic(Vec3::new(6.0 * r, 6.0 * r, 10.0 * r), [true, true, false])
            .unwrap();
    let bed = Packing::new(centres, vec![r; n], Some(bed)).unwrap();
    let asm = Assembly::new(bed, springs).unwrap();
    let o = SpecimenOptions::new(2, 0.5 * r);
    assert!(matches!(solve(&asm, &o), Err(Error::Invalid(m)) if m.contains("p p f")));
}
