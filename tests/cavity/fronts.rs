//! Wave fronts from the ramp-loaded cavity against the Christoffel speeds of the source
//! packing's relaxed tensor.

use crate::lame::{geometry, isotropic_model, source};
use anisobond::cavity::WaveOptions;
use anisobond::cavity::{bulk_density, Cavity};
use anisobond::dem::LawKind;
use anisobond::model::Model;
use anisobond::prelude::*;
use anisobond::tensor::phase_velocities;

/// The fronts of a ramp-loaded run on the source's slab (a = 8 R̄, b = 64 R̄, probes at 24
/// and 48 R̄, ±15°, along 0°, 45°, 90° from x; ramp 20 R̄/v_x, v_x the Christoffel quasi-P
/// speed along x), lasting 1.5 ramps + `travel`·R̄ at the quasi-P speed along `along`; with
/// the Christoffel quasi-P speed of each direction (m/s).
pub fn front_run(
    model: Model,
    pressure: f64,
    travel: f64,
    along: Vec3,
) -> (anisobond::cavity::WaveRun, Vec<f64>) {
    let src = source(1000, 7, model);
    let c = src.tensor(&Method::relaxed()).unwrap().report.tensor();
    let r = src.packing.mean_radius();
    let cav = Cavity::new(&src, geometry(&src, 8.0, 64.0)).unwrap();
    let rho_s = 2600.0;
    let rho = bulk_density(&src.packing, rho_s);
    let dirs = vec![
        0.0,
        std::f64::consts::FRAC_PI_4,
        std::f64::consts::FRAC_PI_2,
    ];
    let quasi_p = |n: &Vec3| phase_velocities(&c, rho, n).unwrap().fastest();
    let ramp = 20.0 * r / quasi_p(&Vec3::x());
    let run = cav
        .run_waves(&WaveOptions {
            pressure,
            ramp_time: ramp,
            duration: 1.5 * ramp + travel * r / quasi_p(&along),
            material_density: rho_s,
            law: LawKind::Yade,
            directions: dirs.clone(),
            probe_radii: vec![24.0 * r, 48.0 * r],
            probe_half_angle: 15f64.to_radians(),
            snapshots: 0,
        })
        .unwrap();
    let christoffel = dirs
        .iter()
        .map(|&phi| quasi_p(&Vec3::new(phi.cos(), phi.sin(), 0.0)))
        .collect();
    (run, christoffel)
}

#[test]
fn isotropic_front_travels_at_the_longitudinal_speed() {
    // from the hole (8 R̄) to 2 R̄ past the far probe (48 R̄)
    let (run, christoffel) = front_run(isotropic_model(), 1e6, 42.0, Vec3::x());
    // measured: 0.9910 (0°), 1.0016 (45°), 0.9938 (90°); 16,800 spheres, 158 steps
    for (d, v) in christoffel.iter().enumerate() {
        let ratio = run.front_speed[d] / v;
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "direction {d}: front {} m/s, Christoffel {v} m/s",
            run.front_speed[d],
        );
        // the front reaches the far probe later
        assert!(run.arrival[d][1] > run.arrival[d][0]);
    }
}
