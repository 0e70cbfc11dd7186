//! A fibre texture (spread 0) of cubic grains: the relaxed tensor is transversely
//! isotropic about the fibre axis within its statistical error.

use super::common::bonded::generated;
use super::{cubic_model, isotropic_model, model, relaxed};
use anisobond::prelude::*;
use anisobond::tensor::{rotate, TransverseProjection};

/// Relative distance of `c` from transverse isotropy about `axis`: the Frobenius norm of
/// C minus its transversely isotropic projection (in the frame whose z is the axis), over
/// that of C.
fn distance(c: &Stiffness6, axis: &Vec3) -> f64 {
    let (p, q) = TransverseProjection::about_axis(c, axis).unwrap();
    (rotate(c, &q) - p.to_matrix()).norm() / c.norm()
}

/// The crystal's [001] along the sample x axis in every grain, each grain turned at random
/// about it. Each grain's deviation from transverse isotropy about x is the cubic crystal's
/// in-plane term, a phase 4ω: over G grains of weights w_g its sum shrinks as
/// 1/√G_eff, G_eff = (Σw)²/Σw² (w: particles per grain), a 2-D Gaussian whose modulus
/// exceeds 3/√G_eff of the single crystal's with probability e⁻⁹. The packing's own
/// fabric adds the isotropic scheme's distance (doubled: the cubic springs weight the same
/// bonds unevenly). The bound: d_poly ≤ 2·d_iso + 3·d_single/√G_eff, and d_poly is well
/// below d_single.
#[test]
fn fibre_texture_is_transversely_isotropic_about_its_axis() {
    let p = generated(2000, 41);
    let fibre = |count: usize| {
        cubic_model(
            "",
            &format!(
                "[grains]\ncount = {count}\nseed = 3\norientation = \"fibre\"\n\
                 axis = [1, 0, 0]\ndirection = [0, 0, 1]\nspread_deg = 0\n"
            ),
        )
    };
    let x = Vec3::x();
    let single = Assembly::new(p.clone(), model(&fibre(1))).unwrap();
    let d_single = distance(&relaxed(&single), &x);
    let iso = Assembly::new(p.clone(), model(&isotropic_model(""))).unwrap();
    let d_iso = distance(&relaxed(&iso), &x);
    let poly = Assembly::new(p, model(&fibre(200))).unwrap();
    let sizes = poly.grains().unwrap().sizes();
    let (s1, s2) = sizes
        .iter()
        .fold((0.0, 0.0), |(a, b), &n| (a + n as f64, b + (n * n) as f64));
    let g_eff = s1 * s1 / s2;
    let d_poly = distance(&relaxed(&poly), &x);
    let bound = 2.0 * d_iso + 3.0 * d_single / g_eff.sqrt();
    println!(
        "distance from transverse isotropy about x: single crystal {d_single:.4}, isotropic \
         scheme {d_iso:.4}, fibre polycrystal {d_poly:.4} (G_eff = {g_eff:.1}, bound {bound:.4})"
    );
    assert!(d_poly <= bound, "{d_poly} > {bound}");
    assert!(
        d_poly < 0.5 * d_single,
        "{d_poly} vs single crystal {d_single}"
    );
}
