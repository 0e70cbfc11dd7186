//! External forces in the integrator (Simulation::set_external_forces) against the
//! two-sphere closed form, and the holed-slab cut against a brute-force count.

use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::packing::Packing;
use anisobond::packing::{cut_holed_slab, HoledSlab};
use anisobond::Vec3;

#[test]
fn pulled_pair_stretches_by_force_over_normal_stiffness() {
    let r = 1e-3;
    let p = Packing::new(
        vec![Vec3::zeros(), Vec3::new(2.0 * r, 0.0, 0.0)],
        vec![r, r],
        None,
    )
    .unwrap();
    let b = BondSet::from_pairs(&p, &[0], &[1], None).unwrap();
    let kn = 2e6;
    let k = BondStiffness {
        radius: vec![r],
        kn: vec![kn],
        ks: vec![0.5 * kn],
        kr: vec![0.0],
        ktw: vec![0.0],
    };
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let mut sim = Simulation::new(
        &p,
        &b,
        law,
        &DemOptions {
            local_damping: 0.5,
            ..Default::default()
        },
    )
    .unwrap();
    let f = 3.0;
    sim.set_external_forces(Some(vec![Vec3::new(-f, 0.0, 0.0), Vec3::new(f, 0.0, 0.0)]))
        .unwrap();
    // ramp to full force, then hold
    for s in 0..4000 {
        sim.set_external_force_scale((s as f64 / 1000.0).min(1.0))
            .unwrap();
        sim.step().unwrap();
    }
    let stretch = (sim.particles.position[1] - sim.particles.position[0]).x - 2.0 * r;
    assert!(
        (stretch / (f / kn) - 1.0).abs() < 1e-6,
        "{stretch} vs {}",
        f / kn
    );
    // the centre of mass does not move (the forces balance)
    let c = 0.5 * (sim.particles.position[0] + sim.particles.position[1]);
    assert!((c - Vec3::new(r, 0.0, 0.0)).norm() < 1e-12);
    // refusals
    assert!(sim.set_external_forces(Some(vec![Vec3::zeros()])).is_err());
    assert!(sim
        .set_external_forces(Some(vec![Vec3::zeros(), Vec3::new(f64::NAN, 0.0, 0.0)]))
        .is_err());
    assert!(sim.set_external_force_scale(f64::INFINITY).is_err());
    sim.set_external_forces(None).unwrap();
    assert!(sim.set_external_force_scale(1.0).is_err());
}

#[test]
fn holed_slab_keeps_exactly_the_annulus_of_the_tiled_packing() {
    let src = crate::common::bonded::generated(200, 11);
    let l = src.cell.unwrap().lengths;
    let (a, b, margin) = (3e-3, 12e-3, 2.5e-3);
    let cut = cut_holed_slab(
        &src,
        &HoledSlab {
            inner_radius: a,
            outer_radius: b,
        },
        margin,
    )
    .unwrap();
    let cell = cut.packing.cell.unwrap().lengths;
    assert_eq!(cell.z, l.z);
    let n = (2.0 * (b + margin) / l.x).ceil();
    assert_eq!(cell.x, n * l.x);
    // brute force: every tile image of every sphere, tested against the annulus
    let mut count = 0;
    for sx in 0..n as i32 {
        for sy in 0..n as i32 {
            for x in &src.positions {
                let y = x + Vec3::new(sx as f64 * l.x, sy as f64 * l.y, 0.0);
                let rho = (y.x - 0.5 * cell.x).hypot(y.y - 0.5 * cell.y);
                if rho >= a && rho <= b {
                    count += 1;
                }
            }
        }
    }
    assert_eq!(cut.packing.len(), count);
    for p in 0..cut.packing.len() {
        let rho = cut.radial_distance(p);
        assert!(rho >= a && rho <= b);
        // margin to the x and y faces
        let x = cut.packing.positions[p];
        assert!(x.x >= margin && x.x <= cell.x - margin);
        assert!(x.y >= margin && x.y <= cell.y - margin);
        assert_eq!(cut.packing.radii[p], src.radii[cut.source[p] as usize]);
    }
    assert!(cut_holed_slab(
        &src,
        &HoledSlab {
            inner_radius: b,
            outer_radius: a
        },
        margin
    )
    .is_err());
    let free = Packing::new(src.positions.clone(), src.radii.clone(), None).unwrap();
    assert!(cut_holed_slab(
        &free,
        &HoledSlab {
            inner_radius: a,
            outer_radius: b
        },
        margin
    )
    .is_err());
}
