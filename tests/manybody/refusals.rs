//! Degenerate particles refused by name (or excluded, with their volume share left out),
//! and bad tensors, volumes and states refused by kind.

use super::common::lattice::simple_cubic_bonded;
use anisobond::bonds::BondSet;
use anisobond::manybody::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::tensor::Stiffness6;
use anisobond::{Error, Mat3, Vec3};

const ISO: LocalTensor = LocalTensor::Isotropic {
    bulk: 1e9,
    shear: 0.5e9,
};

/// The 4³ simple-cubic lattice with particle 17's bonds kept only where `keep(normal)`.
fn sc_without(keep: impl Fn(&Vec3) -> bool) -> (Packing, BondSet) {
    let (p, b) = simple_cubic_bonded(1e-3);
    let mut out = BondSet::default();
    for e in 0..b.len() {
        let touches = b.i[e] == 17 || b.j[e] == 17;
        if !touches || keep(&b.normal[e]) {
            out.push(b.i[e], b.j[e], b.branch(e), b.image[e]);
        }
    }
    (p, out)
}

fn refused_as_degenerate(p: &Packing, b: &BondSet) -> String {
    match ManyBody::new(p, b, &ISO, &ManyBodyOptions::default()) {
        Err(Error::Degenerate(m)) => m,
        other => panic!("expected Degenerate, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn particle_with_two_bonds_is_refused_by_name() {
    let (p, b) = sc_without(|n| n.x.abs() > 0.5);
    assert_eq!(b.degrees(p.len())[17], 2);
    let m = refused_as_degenerate(&p, &b);
    assert!(m.contains("particle 17 ") && m.contains("2 bonds"), "{m}");
}

#[test]
fn particle_with_coplanar_bonds_is_refused_by_name() {
    let (p, b) = sc_without(|n| n.z.abs() < 0.5);
    assert_eq!(b.degrees(p.len())[17], 4);
    let m = refused_as_degenerate(&p, &b);
    assert!(m.contains("particle 17 ") && m.contains("one plane"), "{m}");
}

#[test]
fn excluded_particle_leaves_its_share_out() {
    let (p, b) = sc_without(|n| n.z.abs() < 0.5);
    let mb = ManyBody::new(
        &p,
        &b,
        &ISO,
        &ManyBodyOptions {
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(mb.excluded(), &[17]);
    assert_eq!(mb.particle_volumes()[17], 0.0);
    assert!((mb.volume_fraction() - 63.0 / 64.0).abs() < 1e-15);
}

#[test]
fn bad_tensors_are_refused_as_models() {
    let mut asym = Stiffness6::identity();
    asym[(0, 1)] = 0.3;
    let bad = [
        LocalTensor::Isotropic {
            bulk: f64::NAN,
            shear: 1.0,
        },
        LocalTensor::Cubic {
            c11: 1.0,
            c12: 0.5,
            c44: 0.3,
            rotation: Mat3::identity() * 1.01,
        },
        LocalTensor::Cubic {
            c11: 1.0,
            c12: 0.5,
            c44: 0.3,
            rotation: -Mat3::identity(),
        },
        LocalTensor::TransverselyIsotropic {
            c11: 1.0,
            c33: 1.0,
            c13: 0.1,
            c12: 0.2,
            c44: 0.3,
            axis: Vec3::zeros(),
        },
        LocalTensor::Voigt(asym),
    ];
    let (p, b) = simple_cubic_bonded(1e-3);
    for d in bad {
        assert!(matches!(d.voigt(), Err(Error::Model(_))), "{d:?}");
        assert!(matches!(
            ManyBody::new(&p, &b, &d, &ManyBodyOptions::default()),
            Err(Error::Model(_))
        ));
    }
}

#[test]
fn bad_volumes_and_states_are_refused() {
    let (p, b) = simple_cubic_bonded(1e-3);
    let invalid = |o: ManyBodyOptions, p: &Packing| {
        assert!(
            matches!(ManyBody::new(p, &b, &ISO, &o), Err(Error::Invalid(_))),
            "{o:?}"
        );
    };
    invalid(
        ManyBodyOptions {
            volumes: Some(vec![1.0; 3]),
            ..Default::default()
        },
        &p,
    );
    let mut v = vec![1e-9; p.len()];
    v[5] = -1.0;
    invalid(
        ManyBodyOptions {
            volumes: Some(v),
            ..Default::default()
        },
        &p,
    );
    invalid(
        ManyBodyOptions {
            conditioning: 1.0,
            ..Default::default()
        },
        &p,
    );
    // Default volumes need a fully periodic cell.
    let free = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    invalid(ManyBodyOptions::default(), &free);
    let mixed = Packing::new(
        p.positions.clone(),
        p.radii.clone(),
        Some(PeriodicCell::with_periodic(p.cell.unwrap().lengths, [true, true, false]).unwrap()),
    )
    .unwrap();
    invalid(ManyBodyOptions::default(), &mixed);
    // A periodic bond in a free cluster is refused; given volumes make a free cluster's term.
    let given = ManyBodyOptions {
        volumes: Some(vec![1e-9; p.len()]),
        degenerate: DegenerateParticles::Exclude,
        ..Default::default()
    };
    assert!(matches!(
        ManyBody::new(&free, &b, &ISO, &given),
        Err(Error::Invalid(_))
    ));
    let mut inner = BondSet::default();
    for e in (0..b.len()).filter(|&e| b.image[e] == [0, 0, 0]) {
        inner.push(b.i[e], b.j[e], b.branch(e), b.image[e]);
    }
    let mb = ManyBody::new(&free, &inner, &ISO, &given).unwrap();
    // The 2³ inner particles of the 4³ block keep all six bonds; corners and edges too
    // (a free block's face particle has five, an edge particle four, a corner three).
    assert!(mb.excluded().is_empty());

    let mb = ManyBody::new(&p, &b, &ISO, &ManyBodyOptions::default()).unwrap();
    assert!(matches!(
        mb.evaluate(&[Vec3::zeros(); 3]),
        Err(Error::Invalid(_))
    ));
    let mut l = mb.reference_branches().to_vec();
    l[4].y = f64::NAN;
    assert!(matches!(mb.evaluate(&l), Err(Error::Invalid(_))));
    assert!(matches!(mb.hessian(&l), Err(Error::Invalid(_))));
    assert!(matches!(
        mb.branch_vectors(&p.positions[1..], &Mat3::identity()),
        Err(Error::Invalid(_))
    ));
}
