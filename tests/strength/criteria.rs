//! Each law's criterion against hand-worked values, at, just below and just above its
//! limits, and the per-law conversions from stresses against their formulas worked by hand.

use anisobond::strength::criteria::{
    bpm_smoothing, joint, lammps_bpm, parallel_bond, resolve_on_plane, yade_cohfrict, BpmLimits,
    JointLimits, LocalLoads, Mode, ParallelBondSection, YadeAdhesion, YadeMoments,
};
use anisobond::strength::Strength;
use anisobond::Vec3;
use std::f64::consts::PI;

fn loads(normal: f64, shear: f64, bending: f64, twisting: f64) -> LocalLoads {
    LocalLoads {
        normal,
        shear,
        bending,
        twisting,
    }
}

const UP: f64 = 1.0 + 1e-12;
const DOWN: f64 = 1.0 - 1e-12;

#[test]
fn loads_from_a_laws_vectors_are_their_magnitudes() {
    let l = LocalLoads::from_vectors(
        -2.0,
        &Vec3::new(3.0, 4.0, 0.0),
        &Vec3::new(0.0, 0.0, -5.0),
        &Vec3::new(1.0, 2.0, 2.0),
    );
    assert_eq!(l, loads(-2.0, 5.0, 5.0, 3.0));
}

#[test]
fn yade_adhesions_are_stress_times_min_radius_squared() {
    let s = Strength {
        friction: 0.5,
        ..Strength::new(2.0e6, 3.0e6)
    };
    let a = YadeAdhesion::of(&s, 2.0e-3, 1.0e-3, true);
    // r = 1 mm: a_n = 2e6·1e-6 = 2 N, a_s = 3 N; rolling ¼·2e6·1e-9 = 5e-4 N·m,
    // twisting ½·3e6·1e-9 = 1.5e-3 N·m.
    assert!((a.normal - 2.0).abs() < 1e-15 && (a.shear - 3.0).abs() < 1e-15);
    assert_eq!(a.tan_friction, 0.5);
    match a.moments {
        YadeMoments::Adhesion { rolling, twisting } => {
            assert!((rolling - 5.0e-4).abs() < 1e-18 && (twisting - 1.5e-3).abs() < 1e-18)
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        YadeAdhesion::of(&s, 1e-3, 1e-3, false).moments,
        YadeMoments::Elastic
    );
}

#[test]
fn yade_breaks_strictly_above_its_adhesions() {
    let a = YadeAdhesion {
        normal: 100.0,
        shear: 50.0,
        tan_friction: 0.5,
        cohesion_disables_friction: false,
        moments: YadeMoments::Elastic,
    };
    // Tension: −F_n > a_n; exactly at a_n holds (YADE's strict test).
    let f = yade_cohfrict(&a, &loads(-100.0, 0.0, 0.0, 0.0));
    assert!(
        !f.broken && f.mode == Mode::Tension && f.index == 1.0,
        "{f:?}"
    );
    let f = yade_cohfrict(&a, &loads(-100.0 * UP, 0.0, 0.0, 0.0));
    assert!(f.broken && f.mode == Mode::Tension, "{f:?}");
    // Shear under compression F_n = 20: limit 50 + 20·0.5 = 60.
    let f = yade_cohfrict(&a, &loads(20.0, 60.0, 0.0, 0.0));
    assert!(
        !f.broken && f.mode == Mode::Shear && f.index == 1.0,
        "{f:?}"
    );
    assert!(yade_cohfrict(&a, &loads(20.0, 60.0 * UP, 0.0, 0.0)).broken);
    // Under tension F_n = −20 the friction term lowers it: 50 − 10 = 40.
    assert!(!yade_cohfrict(&a, &loads(-20.0, 40.0, 0.0, 0.0)).broken);
    let f = yade_cohfrict(&a, &loads(-20.0, 40.0 * UP, 0.0, 0.0));
    assert!(f.broken && f.mode == Mode::Shear);
    // Tension is tested first: both exceeded → tension.
    let f = yade_cohfrict(&a, &loads(-200.0, 1000.0, 0.0, 0.0));
    // (the shear limit 50 − 200·0.5 < 0 is clamped at 0: an infinite shear index.)
    assert!(
        f.broken && f.mode == Mode::Tension && f.index.is_infinite(),
        "{f:?}"
    );
    // cohesionDisablesFriction: the limit is a_s alone.
    let no_friction = YadeAdhesion {
        cohesion_disables_friction: true,
        ..a
    };
    assert!(!yade_cohfrict(&no_friction, &loads(20.0, 50.0, 0.0, 0.0)).broken);
    assert!(yade_cohfrict(&no_friction, &loads(20.0, 50.0 * UP, 0.0, 0.0)).broken);
    // 2023.02a moments never break.
    assert!(!yade_cohfrict(&a, &loads(0.0, 0.0, 1e9, 1e9)).broken);
    // Later YADE's moment adhesions.
    let m = YadeAdhesion {
        moments: YadeMoments::Adhesion {
            rolling: 2.0,
            twisting: 3.0,
        },
        ..a
    };
    assert!(!yade_cohfrict(&m, &loads(0.0, 0.0, 2.0, 3.0)).broken);
    let f = yade_cohfrict(&m, &loads(0.0, 0.0, 2.0 * UP, 0.0));
    assert!(f.broken && f.mode == Mode::Bending, "{f:?}");
    let f = yade_cohfrict(&m, &loads(0.0, 0.0, 0.0, 3.0 * UP));
    assert!(f.broken && f.mode == Mode::Twisting, "{f:?}");
}

#[test]
fn lammps_limits_and_its_sum_with_signed_normal_term() {
    let s = Strength {
        bending: 4.0e6,
        twisting: 8.0e6,
        ..Strength::new(1.0e6, 2.0e6)
    };
    // R_b = 1 mm, π̂ = π: A = π·1e-6 m²; τ_bc = σ_b·πR³/4 = π·1e-3, τ_tc = τ_t·πR³/2 = 4π·1e-3.
    let l = BpmLimits::of(&s, 1.0e-3, PI);
    let close = |x: f64, y: f64| (x / y - 1.0).abs() < 1e-14;
    assert!(close(l.f_rc, PI) && close(l.f_sc, 2.0 * PI), "{l:?}");
    assert!(
        close(l.t_bc, PI * 1e-3) && close(l.t_tc, 4.0 * PI * 1e-3),
        "{l:?}"
    );
    let lim = BpmLimits {
        f_rc: 10.0,
        f_sc: 20.0,
        t_bc: 1.0,
        t_tc: 2.0,
    };
    // 5/10 + 10/20 = 1: breaks (LAMMPS tests breaking >= 1.0).
    let f = lammps_bpm(&lim, &loads(-5.0, 10.0, 0.0, 0.0));
    assert!(f.broken && f.index == 1.0, "{f:?}");
    let f = lammps_bpm(&lim, &loads(-5.0, 10.0 * DOWN, 0.0, 0.0));
    assert!(!f.broken && f.index < 1.0, "{f:?}");
    // All four terms: 0.25 + 0.25 + 0.25 + 0.25.
    let f = lammps_bpm(&lim, &loads(-2.5, 5.0, 0.25, 0.5));
    assert!(f.broken && (f.index - 1.0).abs() < 1e-15, "{f:?}");
    // Compression enters with its sign: −10/10 + 20/20 = 0, nothing breaks.
    let f = lammps_bpm(&lim, &loads(10.0, 20.0, 0.0, 0.0));
    assert!(!f.broken && f.index == 0.0, "{f:?}");
    // Clamped at 0 under pure compression.
    assert_eq!(lammps_bpm(&lim, &loads(1e3, 0.0, 0.0, 0.0)).index, 0.0);
    // The smoothing w = 1 − B⁴: 1 unloaded, 15/16 at B = ½, 0 at breaking.
    assert_eq!(
        (bpm_smoothing(0.0), bpm_smoothing(0.5), bpm_smoothing(1.0)),
        (1.0, 0.9375, 0.0)
    );
    // The mode is the largest term.
    assert_eq!(
        lammps_bpm(&lim, &loads(0.0, 1.0, 0.9, 0.0)).mode,
        Mode::Bending
    );
    assert_eq!(
        lammps_bpm(&lim, &loads(0.0, 1.0, 0.0, 1.9)).mode,
        Mode::Twisting
    );
}

#[test]
fn parallel_bond_stresses_of_potyondy_and_cundall() {
    let (r, sc, tc) = (1.0e-3, 5.0e6, 8.0e6);
    let sec = ParallelBondSection::of(&Strength::new(sc, tc), r, PI);
    let (a, i, j) = (PI * r * r, PI * r.powi(4) / 4.0, PI * r.powi(4) / 2.0);
    assert!((sec.area / a - 1.0).abs() < 1e-15);
    assert!((sec.inertia / i - 1.0).abs() < 1e-15 && (sec.polar / j - 1.0).abs() < 1e-15);
    // Half the tensile strength from tension, half from bending: σ = σ_c (to rounding);
    // just above breaks, just below holds.
    let fn_ = -0.5 * sc * a;
    let mb = 0.5 * sc * i / r;
    let f = parallel_bond(&sec, &loads(fn_ * UP, 0.0, mb * UP, 0.0));
    assert!(f.broken && (f.index - 1.0).abs() < 1e-11, "{f:?}");
    let f = parallel_bond(&sec, &loads(fn_ * DOWN, 0.0, mb * DOWN, 0.0));
    assert!(!f.broken && (f.index - 1.0).abs() < 1e-11, "{f:?}");
    // Bending dominates: mode bending.
    let f = parallel_bond(&sec, &loads(-0.1 * sc * a, 0.0, 0.9 * sc * i / r * UP, 0.0));
    assert!(f.broken && f.mode == Mode::Bending, "{f:?}");
    // Compression offsets bending.
    assert!(!parallel_bond(&sec, &loads(0.5 * sc * a, 0.0, 1.4 * sc * i / r, 0.0)).broken);
    // Shear: τ = |F_s|/A at τ_c breaks; twisting τ = M_t R/J.
    let f = parallel_bond(&sec, &loads(0.0, tc * a * UP, 0.0, 0.0));
    assert!(f.broken && f.mode == Mode::Shear, "{f:?}");
    assert!(!parallel_bond(&sec, &loads(0.0, tc * a * DOWN, 0.0, 0.0)).broken);
    let f = parallel_bond(&sec, &loads(0.0, 0.0, 0.0, tc * j / r * UP));
    assert!(f.broken && f.mode == Mode::Twisting, "{f:?}");
    let f = parallel_bond(&sec, &loads(0.0, 0.0, 0.0, 0.5 * tc * j / r));
    assert!(!f.broken && (f.index - 0.5).abs() < 1e-12, "{f:?}");
}

#[test]
fn joint_is_mohr_coulomb_with_a_tension_cut_off() {
    let lim = JointLimits {
        area: 1.0,
        tensile: 1.0e6,
        cohesion: 2.0e6,
        friction: 0.5,
    };
    let f = joint(&lim, &loads(-1.0e6, 0.0, 0.0, 0.0));
    assert!(
        f.broken && f.mode == Mode::Tension && f.index == 1.0,
        "{f:?}"
    );
    assert!(!joint(&lim, &loads(-1.0e6 * DOWN, 0.0, 0.0, 0.0)).broken);
    // σ_n = 4 MPa compression: τ_max = 2 + 0.5·4 = 4 MPa.
    let f = joint(&lim, &loads(4.0e6, 4.0e6, 0.0, 0.0));
    assert!(f.broken && f.mode == Mode::Shear && f.index == 1.0, "{f:?}");
    assert!(!joint(&lim, &loads(4.0e6, 4.0e6 * DOWN, 0.0, 0.0)).broken);
    // σ_n = 0.5 MPa tension: τ_max = 2 − 0.25 = 1.75 MPa.
    assert!(!joint(&lim, &loads(-0.5e6, 1.75e6 * DOWN, 0.0, 0.0)).broken);
    assert!(joint(&lim, &loads(-0.5e6, 1.75e6, 0.0, 0.0)).broken);
    // Moments are not judged.
    assert!(!joint(&lim, &loads(0.0, 0.0, 1e9, 1e9)).broken);
    // Joint limits from a strength: A = π̂R².
    let l = JointLimits::of(
        &Strength {
            friction: 0.7,
            ..Strength::new(1.0, 2.0)
        },
        2.0,
        PI,
    );
    assert!((l.area - 4.0 * PI).abs() < 1e-14 && l.friction == 0.7 && l.cohesion == 2.0);
}

#[test]
fn forces_resolve_on_the_plane_whichever_way_its_normal_points() {
    // Bond along z pulled apart with 10 N (force on j towards i), plane normal 30° from z
    // in the y–z plane: normal −10 cos 30°, shear 10 sin 30°.
    let f = Vec3::new(0.0, 0.0, -10.0);
    let (s, c) = 30f64.to_radians().sin_cos();
    for p in [Vec3::new(0.0, s, c), Vec3::new(0.0, -s, -c)] {
        let (fn_, fs) = resolve_on_plane(&f, &Vec3::z(), &p);
        assert!((fn_ + 10.0 * c).abs() < 1e-12 && (fs - 10.0 * s).abs() < 1e-12);
    }
    // Pushed together: compression positive.
    let (fn_, _) = resolve_on_plane(&Vec3::new(0.0, 0.0, 10.0), &Vec3::z(), &Vec3::z());
    assert_eq!(fn_, 10.0);
}
