//! The geometric (initial-stress) stiffness against closed forms: a pre-tensioned string
//! and the second derivative of N·|l + w|.

use anisobond::bonds::BondSet;
use anisobond::bonds::BondStiffness;
use anisobond::homogenize::{bond_geometric_stiffness, geometric_stiffness};
use anisobond::homogenize::{LeverArm, Network};
use anisobond::packing::Packing;
use anisobond::Vec3;

/// Hessian of E(w) = N(|l + w| − |l|) at w = 0 by central differences equals (N/|l|)(I − nn).
#[test]
fn second_derivative_of_loaded_bond_energy() {
    let l = Vec3::new(0.3e-3, -1.1e-3, 0.7e-3);
    let n = l.normalize();
    let force = n * -2.5 + Vec3::new(0.1, 0.2, 0.3).cross(&n); // shear part is ignored
    let axial = force.dot(&n);
    let g = bond_geometric_stiffness(&force, &n, l.norm());
    let energy = |w: Vec3| axial * ((l + w).norm() - l.norm());
    let h = 1e-4 * l.norm();
    for a in 0..3 {
        for b in 0..3 {
            let (mut ea, mut eb) = (Vec3::zeros(), Vec3::zeros());
            ea[a] = h;
            eb[b] = h;
            let fd = (energy(ea + eb) - energy(ea - eb) - energy(eb - ea) + energy(-ea - eb))
                / (4.0 * h * h);
            assert!(
                (fd - g[(a, b)]).abs() < 1e-4 * axial.abs() / l.norm(),
                "{a}{b}"
            );
        }
    }
}

/// A string of three particles on a line under tension N: the middle particle's transverse
/// stiffness is 2N/l, its axial one 0, the ends couple by −N/l.
#[test]
fn pre_tensioned_string() {
    let l = 2e-3;
    let p = Packing::new(
        vec![
            Vec3::zeros(),
            Vec3::new(l, 0.0, 0.0),
            Vec3::new(2.0 * l, 0.0, 0.0),
        ],
        vec![1e-3; 3],
        None,
    )
    .unwrap();
    let mut bonds = BondSet::default();
    bonds.push(0, 1, Vec3::new(l, 0.0, 0.0), [0; 3]);
    bonds.push(1, 2, Vec3::new(l, 0.0, 0.0), [0; 3]);
    bonds.push(0, 2, Vec3::new(2.0 * l, 0.0, 0.0), [0; 3]);
    let k = BondStiffness {
        radius: vec![1e-3; 3],
        kn: vec![1.0; 3],
        ks: vec![1.0; 3],
        kr: vec![0.0; 3],
        ktw: vec![0.0; 3],
    };
    let net = Network::build(&p, &bonds, &k, LeverArm::MidGap, false, None).unwrap();
    let tension = 3.0;
    let forces = vec![Vec3::x() * tension, Vec3::x() * tension, Vec3::zeros()];
    let kg = geometric_stiffness(&net, &bonds, &forces).unwrap();
    let mid = net.index[1] as usize;
    let d = kg.diagonal(mid);
    assert!((d[(1, 1)] - 2.0 * tension / l).abs() < 1e-12 * tension / l);
    assert!((d[(2, 2)] - 2.0 * tension / l).abs() < 1e-12 * tension / l);
    assert!(d[(0, 0)].abs() < 1e-12 && d.fixed_view::<3, 3>(3, 3).norm() == 0.0);
    let end = net.index[0] as usize;
    let coupling = kg.row(mid).find(|(c, _)| *c == end).unwrap().1;
    assert!((coupling[(1, 1)] + tension / l).abs() < 1e-12 * tension / l);
    assert!(geometric_stiffness(&net, &bonds, &forces[..2]).is_err());
}
