//! Quasi-static element tests of the integrator against the exact relaxed tensor
//! (`relaxed_tensor`, LeverArm::MidGap = YADE's contact point): on a periodic ~2,000-particle
//! bonded packing the dynamic 6×6 tensor must match within 0.1 %.

use crate::common::bonded::{directional_springs, gap_bonded, relaxed_exact, yade_sim};
use anisobond::dem::{dynamic_tensor, ElementTestOptions};
use anisobond::tensor::relative_difference;

fn compare(moments: bool) {
    let (p, b) = gap_bonded(2000, 7);
    let k = directional_springs(&p, &b, moments);
    let relaxed = relaxed_exact(&p, &b, &k);
    let sim = yade_sim(&p, &b, &k, None);
    let opts = ElementTestOptions {
        tolerance: 1e-6,
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let dynamic = dynamic_tensor(&sim, &opts, &|_| {}).unwrap();
    let d = relative_difference(&dynamic.c, &relaxed.c);
    let da = relative_difference(&relaxed.c_affine, &relaxed.c);
    let steps: Vec<usize> = dynamic.paths.iter().map(|p| p.steps).collect();
    println!(
        "moments {moments}: {} particles, {} bonds (Z = {:.2}; {} with 1 bond, {} with 2): dynamic vs relaxed {:.2e} (affine vs relaxed {:.2e}); steps per path {steps:?}; {:.1} s",
        p.len(),
        b.len(),
        b.coordination(p.len()),
        sim.stability().one_bond_particles.len(),
        sim.stability().two_bond_particles.len(),
        d,
        da,
        t0.elapsed().as_secs_f64()
    );
    assert!(
        da > 0.02,
        "the test needs a packing whose relaxation matters"
    );
    assert!(d < 1e-3, "dynamic tensor differs from relaxed by {d:.3e}");
}

#[test]
fn dynamic_matches_relaxed_without_moments() {
    compare(false);
}

#[test]
fn dynamic_matches_relaxed_with_bending_and_twisting() {
    compare(true);
}
