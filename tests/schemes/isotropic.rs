//! Isotropic scheme through the geometry conventions, against Kumar 2016 Eqs. 1–3, 7–8 and
//! the parallel-bond / modulus closed forms.

use anisobond::schemes::Isotropic;
use anisobond::schemes::Springs;
use anisobond::schemes::{BondLength, BondRadius, Convention, Geometry, Moments, StiffnessScheme};
use anisobond::Vec3;
use std::f64::consts::PI;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
}

fn assert_springs(got: Springs, kn: f64, ks: f64, kr: f64, ktw: f64) {
    assert!(close(got.kn, kn), "kn {} vs {kn}", got.kn);
    assert!(close(got.ks, ks), "ks {} vs {ks}", got.ks);
    assert!(close(got.kr, kr), "kr {} vs {kr}", got.kr);
    assert!(close(got.ktw, ktw), "ktw {} vs {ktw}", got.ktw);
}

#[test]
fn kumar_convention_reproduces_kumar_eqs_2_3_7_8() {
    // Σ_N = 10 GPa, Σ_T = 3 GPa, unequal radii R_p = 1 mm, R_q = 2.5 mm.
    let (sigma_n, sigma_t) = (1.0e10, 3.0e9);
    let (rp, rq) = (1.0e-3, 2.5e-3);
    let r_star = 1.0 / (1.0 / rp + 1.0 / rq); // Eq. 1 written as a reduced radius.
    let scheme = Isotropic::new(sigma_n, sigma_t).unwrap();
    let geometry = Geometry {
        convention: Convention::Kumar,
        moments: Moments::Kumar,
        ..Geometry::default()
    };
    let n = Vec3::new(0.0, 0.6, 0.8);
    // The centre distance must not matter (Kumar's law has no length).
    for length in [3.5e-3, 3.6e-3] {
        let springs = geometry.springs(scheme.magnitudes(&n), rp, rq, length);
        assert_springs(
            springs,
            2.0 * sigma_n * r_star,         // Eq. 2: K_N = 2Σ_N R*
            2.0 * sigma_t * r_star,         // Eq. 3: K_T = 2Σ_T R*
            2.0 * sigma_n * r_star.powi(3), // Eq. 8: bending M_T = 2Σ_N R*³ θ_T
            4.0 * sigma_t * r_star.powi(3), // Eq. 7: twisting M_N = 4Σ_T R*³ θ_N
        );
    }
    // Equal spheres: R* = R/2, K_N = Σ_N R (so Σ_N = K_N/R as in Kumar's appendix).
    let springs = geometry.springs(scheme.magnitudes(&n), 2e-3, 2e-3, 4e-3);
    assert!(close(springs.kn, sigma_n * 2e-3));
}

#[test]
fn area_and_modulus_conventions() {
    let (e_n, e_t) = (70.0e9, 28.0e9); // Pa for modulus; Pa/m read as area magnitude below.
    let scheme = Isotropic::new(e_n, e_t).unwrap();
    let m = scheme.magnitudes(&Vec3::z());
    let (ri, rj, length) = (1.0e-3, 2.0e-3, 3.2e-3);
    // Bond radius rules.
    let rb_min = 1.0e-3;
    let rb_mean = 1.5e-3;
    let rb_harmonic = 2.0 * 1.0e-3 * 2.0e-3 / 3.0e-3;
    for (rule, rb) in [
        (BondRadius::Min, rb_min),
        (BondRadius::Mean, rb_mean),
        (BondRadius::Harmonic, rb_harmonic),
    ] {
        let area = PI * rb * rb;
        // modulus, centre distance: k = E·πR_b²/L (Truszkowska Eqs. 6–7 with L = |l|; Woo).
        let g = Geometry {
            convention: Convention::Modulus,
            bond_radius: rule,
            ..Geometry::default()
        };
        let s = g.springs(m, ri, rj, length);
        assert_springs(s, e_n * area / length, e_t * area / length, 0.0, 0.0);
        // modulus, radii sum: L_b = R_i + R_j (Truszkowska Eq. 7).
        let g = Geometry {
            bond_length: BondLength::RadiiSum,
            ..g
        };
        let s = g.springs(m, ri, rj, length);
        assert_springs(s, e_n * area / (ri + rj), e_t * area / (ri + rj), 0.0, 0.0);
        // area with parallel-bond moments: k = magnitude·A, k_r = k_n·I/A, k_tw = k_s·J/A
        // with I = πR⁴/4, J = πR⁴/2 (Potyondy & Cundall 2004).
        let g = Geometry {
            convention: Convention::Area,
            bond_radius: rule,
            moments: Moments::ParallelBond,
            ..Geometry::default()
        };
        let s = g.springs(m, ri, rj, length);
        let (inertia, polar) = (PI * rb.powi(4) / 4.0, PI * rb.powi(4) / 2.0);
        assert_springs(
            s,
            e_n * area,
            e_t * area,
            e_n * area * inertia / area,
            e_t * area * polar / area,
        );
    }
    // π̂ replaces π in A_b (Šmilauer).
    let g = Geometry {
        convention: Convention::Area,
        pi_hat: PI / 2.0,
        ..Geometry::default()
    };
    assert_springs(
        g.springs(m, ri, rj, length),
        e_n * PI / 2.0 * rb_min * rb_min,
        e_t * PI / 2.0 * rb_min * rb_min,
        0.0,
        0.0,
    );
    // spring: k = magnitude.
    let g = Geometry {
        convention: Convention::Spring,
        ..Geometry::default()
    };
    assert_springs(g.springs(m, ri, rj, length), e_n, e_t, 0.0, 0.0);
}

#[test]
fn isotropic_magnitudes_do_not_depend_on_direction() {
    let s = Isotropic::new(5.0, 0.0).unwrap();
    let a = s.magnitudes(&Vec3::new(1.0, 0.0, 0.0));
    let b = s.magnitudes(&Vec3::new(0.0, -0.8, 0.6));
    assert_eq!(a, b);
    assert_eq!((a.normal, a.shear), (5.0, 0.0));
    let err = Isotropic::new(f64::NAN, 1.0).unwrap_err().to_string();
    assert!(err.contains("normal"), "{err}");
}
