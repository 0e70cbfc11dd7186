//! Strength schemes by orientation: isotropic, cross-anisotropic (sin²θ blend, worked by
//! hand), cubic (Truszkowska's envelopes at the symmetry directions, in closed form, O_h
//! symmetry, a = 1 isotropic) and their refusals.

use anisobond::schemes::CubicModel;
use anisobond::strength::schemes::{CrossStrength, CubicStrength, StrengthScheme};
use anisobond::strength::Strength;
use anisobond::{Mat3, Vec3};

fn base() -> Strength {
    Strength {
        tensile: 4.0e6,
        cohesion: 6.0e6,
        friction: 0.5,
        bending: 5.0e6,
        twisting: 7.0e6,
    }
}

#[test]
fn cross_anisotropic_blends_by_sin_squared_of_the_angle_to_the_axis() {
    let along = Strength {
        friction: 0.2,
        ..Strength::new(1.0e6, 2.0e6)
    };
    let s = StrengthScheme::CrossAnisotropic(CrossStrength {
        along,
        across: base(),
        axis: Vec3::new(0.0, 0.0, 3.0),
    })
    .checked()
    .unwrap();
    assert_eq!(s.strength(&Vec3::z()), along);
    assert_eq!(s.strength(&-Vec3::z()), along);
    assert_eq!(s.strength(&Vec3::x()), base());
    // θ = 60° from the axis: sin²θ = 3/4 across + 1/4 along.
    let n = Vec3::new(0.0, 60f64.to_radians().sin(), 0.5);
    let got = s.strength(&n);
    let want = [
        0.75 * 4.0e6 + 0.25 * 1.0e6,
        0.75 * 6.0e6 + 0.25 * 2.0e6,
        0.75 * 0.5 + 0.25 * 0.2,
        0.75 * 5.0e6 + 0.25 * 1.0e6,
        0.75 * 7.0e6 + 0.25 * 2.0e6,
    ];
    for ((name, g), w) in got.fields().iter().zip(want) {
        assert!((g - w).abs() <= 1e-12 * w.abs(), "{name}: {g} vs {w}");
    }
}

#[test]
fn cubic_scales_by_the_spheroid_envelopes_at_the_symmetry_directions() {
    let (a_t, a_s) = (2.0f64, 3.0f64);
    let s = StrengthScheme::Cubic(CubicStrength {
        model: CubicModel::ZenerAbove1,
        a_tensile: a_t,
        a_shear: a_s,
        base: base(),
        rotation: Mat3::identity(),
    })
    .checked()
    .unwrap();
    // Spheroid radius a^(2/3)/√(c² + (1 − c²)a²) at cosine c to its axis (Truszkowska
    // Eqs. 9–15); Z > 1: tensile on <111> (a_t), cohesion on <100> (a_s).
    let r = |c2: f64, a: f64| a.powf(2.0 / 3.0) / (c2 + (1.0 - c2) * a * a).sqrt();
    // Along [111]: the <111> envelope is a_t^(2/3) (c = 1); the <100> one has c² = 1/3.
    let m111 = Vec3::new(1.0, 1.0, 1.0).normalize();
    let g = s.strength(&m111);
    assert!((g.tensile / (4.0e6 * r(1.0, a_t)) - 1.0).abs() < 1e-14);
    assert!((g.bending / (5.0e6 * r(1.0, a_t)) - 1.0).abs() < 1e-14);
    assert!((g.cohesion / (6.0e6 * r(1.0 / 3.0, a_s)) - 1.0).abs() < 1e-14);
    assert!((g.twisting / (7.0e6 * r(1.0 / 3.0, a_s)) - 1.0).abs() < 1e-14);
    assert_eq!(g.friction, 0.5);
    // Along [100]: <111> at c² = 1/3, <100> at c = 1.
    let g = s.strength(&Vec3::x());
    assert!((g.tensile / (4.0e6 * r(1.0 / 3.0, a_t)) - 1.0).abs() < 1e-14);
    assert!((g.cohesion / (6.0e6 * r(1.0, a_s)) - 1.0).abs() < 1e-14);
    // O_h symmetry: permutations and sign changes of the crystal direction.
    let n = Vec3::new(0.3, -0.5, 0.81).normalize();
    let reference = s.strength(&n);
    for m in [
        Vec3::new(n.y, n.x, n.z),
        Vec3::new(-n.z, n.y, n.x),
        Vec3::new(n.x, -n.y, -n.z),
        -n,
    ] {
        let g = s.strength(&m);
        assert!((g.tensile / reference.tensile - 1.0).abs() < 1e-14);
        assert!((g.cohesion / reference.cohesion - 1.0).abs() < 1e-14);
    }
    // A rotated crystal: the lab direction R^T·[111] sees the crystal's [111].
    let rot = *nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.7).matrix();
    let rotated = StrengthScheme::Cubic(CubicStrength {
        model: CubicModel::ZenerAbove1,
        a_tensile: a_t,
        a_shear: a_s,
        base: base(),
        rotation: rot,
    });
    let g = rotated.strength(&(rot.transpose() * m111));
    assert!((g.tensile / (4.0e6 * r(1.0, a_t)) - 1.0).abs() < 1e-13);
}

#[test]
fn cubic_with_unit_aspect_ratios_is_isotropic() {
    let s = StrengthScheme::Cubic(CubicStrength {
        model: CubicModel::ZenerBelow1,
        a_tensile: 1.0,
        a_shear: 1.0,
        base: base(),
        rotation: Mat3::identity(),
    });
    for n in [
        Vec3::x(),
        Vec3::new(0.6, 0.0, -0.8),
        Vec3::new(1.0, 2.0, 3.0).normalize(),
    ] {
        let g = s.strength(&n);
        for ((name, x), (_, y)) in g.fields().iter().zip(base().fields()) {
            assert!((x - y).abs() <= 1e-15 * y, "{name}: {x} vs {y}");
        }
    }
}

#[test]
fn bad_schemes_are_refused_naming_the_field() {
    let bad = Strength {
        cohesion: -1.0,
        ..base()
    };
    let e = StrengthScheme::Isotropic(bad)
        .checked()
        .unwrap_err()
        .to_string();
    assert!(e.contains("cohesion"), "{e}");
    let nan = Strength {
        friction: f64::NAN,
        ..base()
    };
    assert!(StrengthScheme::Isotropic(nan).checked().is_err());
    let e = StrengthScheme::CrossAnisotropic(CrossStrength {
        along: base(),
        across: base(),
        axis: Vec3::zeros(),
    })
    .checked()
    .unwrap_err()
    .to_string();
    assert!(e.contains("axis"), "{e}");
    let cubic = |a: f64, rotation: Mat3| {
        StrengthScheme::Cubic(CubicStrength {
            model: CubicModel::ZenerAbove1,
            a_tensile: a,
            a_shear: 1.0,
            base: base(),
            rotation,
        })
        .checked()
    };
    assert!(cubic(0.0, Mat3::identity())
        .unwrap_err()
        .to_string()
        .contains("a_tensile"));
    let e = cubic(1.0, Mat3::identity() * 2.0).unwrap_err().to_string();
    assert!(e.contains("rotation"), "{e}");
    let reflection = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0));
    assert!(cubic(1.0, reflection).is_err());
}
