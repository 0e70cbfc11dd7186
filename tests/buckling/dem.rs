//! Quasi-static compression of a clamped bar with the integrator.

use anisobond::dem::buckling::{compress_clamped_bar, CompressionOptions};
use anisobond::homogenize::buckling::{BucklingOptions, RoundBar};
use anisobond::model::Model;
use anisobond::packing::routes::{prepare, PreparationRoute, RouteOptions};

fn kumar_model(kappa: f64, alpha: f64) -> Model {
    let text = format!(
        "[bonding]\nrule = \"factor\"\nvalue = {kappa}\n[scheme]\nkind = \"isotropic\"\n\
         normal = 1e8\nshear = {}\n[geometry]\nconvention = \"kumar\"\nmoments = \"kumar\"\n",
        alpha * 1e8
    );
    Model::from_toml_str(&text, "kumar").unwrap()
}

/// A short weakly jammed bar (l/r = 10, r = 5 R̄, 627 spheres) compressed by the integrator
/// with Kumar's law over 50,000 steps to 2.5 ε_cr: the initial secant modulus is the static
/// solve's E within 3 %, and the stress maximum (Kumar's critical stress) lies within 10 % of
/// the network's linearised σ_cr, after it; Ẽ_kin (Eq. 16) is reported and finite.
#[test]
fn short_bar_compression_peaks_at_linearised_load() {
    let o = RouteOptions {
        route: PreparationRoute::WeaklyJammed,
        n_particles: 1000,
        seed: 1,
        ..RouteOptions::default()
    };
    let p = prepare(&o, &|_| {}).unwrap().0;
    let rbar = p.mean_radius();
    let bar = RoundBar::cut(&p, kumar_model(1.0, 0.2), 5.0 * rbar, 10.0, rbar).unwrap();
    let lin = bar.buckling(&BucklingOptions::default()).unwrap();
    let opts = CompressionOptions {
        max_strain: 2.5 * lin.critical_strain,
        steps: 50_000,
        record_every: 1000,
        ..Default::default()
    };
    let r = compress_clamped_bar(&bar, &opts).unwrap();
    println!(
        "E {:e} Pa, E_sec {:e} Pa, σ_max/σ_cr {}, ε_max/ε_cr {}, max Ẽ_kin {:e}",
        lin.modulus,
        r.history[0].stress / r.history[0].strain,
        r.max_stress / lin.critical_stress,
        r.strain_at_max / lin.critical_strain,
        r.max_kinetic_ratio_before_peak
    );
    let first = r.history[0];
    let secant = first.stress / first.strain;
    assert!(
        (secant / lin.modulus - 1.0).abs() < 0.03,
        "E_sec {secant:e} vs {:e}",
        lin.modulus
    );
    let ratio = r.max_stress / lin.critical_stress;
    assert!((ratio - 1.0).abs() < 0.1, "σ_max/σ_cr = {ratio}");
    assert!(r.strain_at_max > lin.critical_strain && !r.peak_at_end);
    assert!(r.max_kinetic_ratio_before_peak.is_finite() && r.max_kinetic_ratio_before_peak > 0.0);
}
