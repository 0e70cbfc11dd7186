//! Kumar 2016 Sec. 5's own bars (`RoundBar::in_container`): packed in a rigid cylinder and
//! two planes, bonded once these are removed, clamped on the spheres touching the planes;
//! against the bar cut from a periodic packing of the same route.

use crate::euler::kumar_model;
use anisobond::homogenize::{euler_stress, BucklingOptions, RoundBar};
use anisobond::packing::{prepare, PreparationRoute, RouteOptions};

/// Jammed route, r = 5 R̄, l/r = 20, seed 1: the container bar has as many spheres as the
/// cut bar within 5 % (the same per unit length), its clamped sets are the spheres touching
/// the planes, and its linearised critical stress lies near Euler's with its own E (measured
/// 0.950; seeds 2 and 3: 0.953, 0.968), well above the cut bar's (0.810; 0.705, 0.756 for
/// seeds 2 and 3), whose surface spheres lost their outer bonds. The bending ratios
/// EI/(E·πr⁴/4) are printed, not compared: 0.910 against 0.958 here, 0.979 and 0.953
/// against 0.800 and 0.821 for seeds 2 and 3, no order that holds for every seed.
#[test]
fn container_bar_buckles_near_euler_above_the_cut_bar() {
    let route = RouteOptions {
        route: PreparationRoute::Jammed,
        seed: 1,
        ..RouteOptions::default()
    };
    let rbar = route.mean_radius;
    let (radius, s) = (5.0 * rbar, 20.0);
    let model = kumar_model(1.0, 0.2);
    let (bar, report) = RoundBar::in_container(&route, model.clone(), radius, s).unwrap();
    assert!(report.compressed_solid_fraction < 0.636);
    assert!((bar.radius / radius - 1.0).abs() < 0.01 && (bar.length / bar.radius - s).abs() < 1e-9);
    let pk = &bar.assembly.packing;
    for &p in &bar.boundary.first_end {
        assert!(pk.positions[p as usize].z <= pk.radii[p as usize]);
    }
    for &p in &bar.boundary.second_end {
        assert!(pk.positions[p as usize].z >= bar.length - pk.radii[p as usize]);
    }
    let cell = RouteOptions {
        n_particles: 1000,
        ..route.clone()
    };
    let periodic = prepare(&cell, &|_| {}).unwrap().0;
    let cut = RoundBar::cut(&periodic, model, radius, s, rbar).unwrap();
    let (nc, nk) = (pk.len() as f64, cut.assembly.packing.len() as f64);
    assert!(
        (nc / nk - 1.0).abs() < 0.05,
        "{nc} container vs {nk} cut spheres"
    );

    let opts = BucklingOptions::default();
    let ratio = |b: &RoundBar| {
        let r = b.buckling(&opts).unwrap();
        (
            r.critical_stress / euler_stress(r.modulus, s),
            r.bending_ratio(b.area()),
        )
    };
    let (container, container_ei) = ratio(&bar);
    let (cut_ratio, cut_ei) = ratio(&cut);
    println!(
        "σ_cr/σ_Euler: container {container:.4} (EI ratio {container_ei:.4}), cut {cut_ratio:.4} \
         (EI ratio {cut_ei:.4})"
    );
    assert!(
        container > 0.9 && container < 1.05,
        "container σ/σ_Euler = {container}"
    );
    assert!(
        container > cut_ratio + 0.1,
        "container {container} vs cut {cut_ratio}"
    );
}
