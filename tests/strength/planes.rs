//! Planes of weakness: the crossing test against a brute-force search over the planes, its
//! edge convention, strike/dip normals, and which bonds of an assignment become joints.

use anisobond::strength::{strengths_along, PlaneFamily, Strength, StrengthSpec, NO_JOINT};
use anisobond::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Brute force: the segment crosses a plane n·x = o + k·s (k integer, over a range wide
/// enough) with its lower end strictly below and its upper end at or above the plane.
fn crosses_brute(normal: &Vec3, spacing: f64, offset: f64, a: &Vec3, b: &Vec3) -> bool {
    let (da, db) = (normal.dot(a), normal.dot(b));
    let (lo, hi) = (da.min(db), da.max(db));
    let k0 = ((lo - offset) / spacing).floor() as i64 - 2;
    let k1 = ((hi - offset) / spacing).ceil() as i64 + 2;
    (k0..=k1).any(|k| {
        let p = offset + k as f64 * spacing;
        lo < p && p <= hi
    })
}

fn joint() -> Strength {
    Strength {
        friction: 0.6,
        ..Strength::new(1.0e5, 2.0e5)
    }
}

#[test]
fn crossing_agrees_with_brute_force_on_random_segments() {
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    let mut crossings = 0;
    for trial in 0..20_000 {
        let normal = Vec3::new(rng.gen(), rng.gen(), rng.gen()) - Vec3::repeat(0.5);
        let spacing = rng.gen_range(0.05..1.0);
        let offset = rng.gen_range(-2.0..2.0);
        let family = PlaneFamily::new(normal, spacing, offset, joint()).unwrap();
        let a = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 4.0 - Vec3::repeat(2.0);
        let b = a + (Vec3::new(rng.gen(), rng.gen(), rng.gen()) - Vec3::repeat(0.5)) * 0.6;
        let expected = crosses_brute(&family.normal, spacing, offset, &a, &b);
        assert_eq!(family.crosses(&a, &b), expected, "trial {trial}");
        assert_eq!(family.crosses(&b, &a), expected, "trial {trial} reversed");
        crossings += expected as usize;
    }
    // Both outcomes are exercised.
    assert!(crossings > 2_000 && crossings < 18_000, "{crossings}");
}

#[test]
fn ends_on_a_plane_follow_the_half_open_convention() {
    // Planes z = 0.25·k (exact in binary).
    let f = PlaneFamily::new(Vec3::z(), 0.25, 0.0, joint()).unwrap();
    let at = |z: f64| Vec3::new(0.3, -0.1, z);
    // Upper end exactly on a plane: crosses it; lower end exactly on one: does not.
    assert!(f.crosses(&at(0.1), &at(0.25)));
    assert!(!f.crosses(&at(0.25), &at(0.4)));
    assert!(f.crosses(&at(0.25), &at(0.5)));
    // A segment in the plane does not cross it.
    assert!(!f.crosses(&at(0.25), &Vec3::new(5.0, 3.0, 0.25)));
    for (a, b) in [
        (0.1, 0.25),
        (0.25, 0.4),
        (0.25, 0.5),
        (-0.25, 0.0),
        (-0.3, -0.25),
    ] {
        assert_eq!(
            f.crosses(&at(a), &at(b)),
            crosses_brute(&Vec3::z(), 0.25, 0.0, &at(a), &at(b)),
            "{a}..{b}"
        );
    }
}

#[test]
fn strike_and_dip_give_the_cross_anisotropic_axis_convention() {
    // Dip 0: horizontal planes; dip 90° strike 0: normal along x.
    assert!((PlaneFamily::normal_from_strike_dip(17.0, 0.0) - Vec3::z()).norm() < 1e-15);
    assert!((PlaneFamily::normal_from_strike_dip(0.0, 90.0) - Vec3::x()).norm() < 1e-15);
    let n = PlaneFamily::normal_from_strike_dip(90.0, 30.0);
    // (cos α sin β, −sin α sin β, cos β) at α = 90°, β = 30°.
    assert!((n - Vec3::new(0.0, -0.5, 30f64.to_radians().cos())).norm() < 1e-15);
}

#[test]
fn bonds_crossing_a_plane_take_the_first_familys_joint_strength() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 3_000;
    let start: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 10.0)
        .collect();
    let branch: Vec<Vec3> = (0..n)
        .map(|_| (Vec3::new(rng.gen(), rng.gen(), rng.gen()) - Vec3::repeat(0.5)) * 1.5)
        .collect();
    let f0 = PlaneFamily::new(Vec3::new(1.0, 1.0, 0.0), 2.0, 0.3, joint()).unwrap();
    let second = Strength::new(3.0e5, 4.0e5);
    let f1 = PlaneFamily::new(Vec3::new(0.0, 0.2, 1.0), 1.5, -0.1, second).unwrap();
    let intact = Strength::new(5.0e6, 6.0e6);
    let spec = StrengthSpec {
        planes: vec![f0.clone(), f1.clone()],
        ..StrengthSpec::isotropic(intact).unwrap()
    };
    let st = strengths_along(&spec, &start, &branch).unwrap();
    let mut counts = [0; 3];
    for b in 0..n {
        let (a, e) = (start[b], start[b] + branch[b]);
        let c0 = crosses_brute(&f0.normal, 2.0, 0.3, &a, &e);
        let c1 = crosses_brute(&f1.normal, 1.5, -0.1, &a, &e);
        let (want_joint, want) = match (c0, c1) {
            (true, _) => (0, joint()),
            (false, true) => (1, second),
            _ => (NO_JOINT, intact),
        };
        assert_eq!(st.joint[b], want_joint, "bond {b}");
        assert_eq!(st.get(b), want, "bond {b}");
        counts[if want_joint == NO_JOINT {
            2
        } else {
            want_joint as usize
        }] += 1;
    }
    assert!(counts.iter().all(|&c| c > 100), "{counts:?}");
    // Refusals: columns of different lengths, a zero branch vector, bad families.
    assert!(strengths_along(&spec, &start[..2], &branch[..3]).is_err());
    assert!(strengths_along(&spec, &start[..1], &[Vec3::zeros()]).is_err());
    assert!(PlaneFamily::new(Vec3::zeros(), 1.0, 0.0, joint()).is_err());
    assert!(PlaneFamily::new(Vec3::z(), 0.0, 0.0, joint()).is_err());
    assert!(PlaneFamily::new(Vec3::z(), 1.0, f64::NAN, joint()).is_err());
}
