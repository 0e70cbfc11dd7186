//! Wave fronts from the ramp-loaded cavity against the Christoffel speeds of the source
//! packing's relaxed tensor.

use crate::lame::{geometry, isotropic_model, source};
use anisobond::cavity::dynamics::WaveOptions;
use anisobond::cavity::{bulk_density, Cavity};
use anisobond::dem::LawKind;
use anisobond::prelude::*;
use anisobond::tensor::phase_velocities;

#[test]
fn isotropic_front_travels_at_the_longitudinal_speed() {
    let src = source(1000, 7, isotropic_model());
    let c = src.tensor(&Method::relaxed()).unwrap().report.tensor();
    let r = src.packing.mean_radius();
    let (ra, rb, ramp_r, p1, p2) = (8.0, 64.0, 20.0, 24.0, 48.0);
    let cav = Cavity::new(&src, geometry(&src, ra, rb)).unwrap();
    let rho_s = 2600.0;
    let rho = bulk_density(&src.packing, rho_s);
    let dirs = vec![
        0.0,
        std::f64::consts::FRAC_PI_4,
        std::f64::consts::FRAC_PI_2,
    ];
    let vp = phase_velocities(&c, rho, &Vec3::x()).unwrap().fastest();
    let ramp = ramp_r * r / vp;
    let run = cav
        .run_waves(&WaveOptions {
            pressure: 1e6,
            ramp_time: ramp,
            duration: 1.5 * ramp + (p2 - ra + 2.0) * r / vp,
            material_density: rho_s,
            law: LawKind::Yade,
            directions: dirs.clone(),
            probe_radii: vec![p1 * r, p2 * r],
            probe_half_angle: 15f64.to_radians(),
            snapshots: 0,
        })
        .unwrap();
    // measured: 0.9910 (0°), 1.0016 (45°), 0.9938 (90°); 16,800 spheres, 158 steps
    for (d, &phi) in dirs.iter().enumerate() {
        let w = phase_velocities(&c, rho, &Vec3::new(phi.cos(), phi.sin(), 0.0)).unwrap();
        let ratio = run.front_speed[d] / w.fastest();
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{:.0}°: front {} m/s, Christoffel {} m/s",
            phi.to_degrees(),
            run.front_speed[d],
            w.fastest()
        );
        // the front reaches the far probe later
        assert!(run.arrival[d][1] > run.arrival[d][0]);
    }
}
