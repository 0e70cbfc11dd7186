//! Quasi-static element tests of the integrator against the exact relaxed tensor
//! (`relaxed_tensor`, LeverArm::MidGap = YADE's contact point): on a periodic ~2,000-particle
//! bonded packing the dynamic 6×6 tensor must match within 0.1 %.

use anisobond::bonds::{rules::build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::dem::element::{dynamic_tensor, ElementTestOptions};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use anisobond::packing::generate::{generate, GenerateOptions};
use anisobond::packing::Packing;
use anisobond::tensor::relative_difference;

fn bonded(n: usize, seed: u64) -> (Packing, BondSet) {
    let p = generate(
        &GenerateOptions {
            n_particles: n,
            seed,
            ..Default::default()
        },
        &|_| {},
    )
    .unwrap();
    let b = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
    (p, b)
}

/// Anisotropic springs: k_n and k_s depend on the bond direction (so that every one of the
/// 21 components is exercised), with bending and twisting springs.
fn springs(p: &Packing, b: &BondSet, moments: bool) -> BondStiffness {
    let nb = b.len();
    let r = p.mean_radius();
    let mut k = BondStiffness {
        radius: vec![r; nb],
        kn: vec![0.0; nb],
        ks: vec![0.0; nb],
        kr: vec![0.0; nb],
        ktw: vec![0.0; nb],
    };
    for e in 0..nb {
        let n = b.normal[e];
        k.kn[e] = 1e6 * (1.0 + 2.0 * n.x * n.x + 0.5 * n.y * n.z);
        k.ks[e] = 0.4e6 * (1.0 + n.z * n.z);
        if moments {
            k.kr[e] = k.kn[e] * r * r / 4.0;
            k.ktw[e] = k.ks[e] * r * r / 2.0;
        }
    }
    k
}

fn compare(moments: bool) {
    let (p, b) = bonded(2000, 7);
    let k = springs(&p, &b, moments);
    let relaxed = relaxed_tensor(
        &p,
        &b,
        &k,
        &RelaxedOptions {
            tolerance: 1e-10,
            ..Default::default()
        },
    )
    .unwrap();
    let law = build_law(LawKind::Yade, &p, &b, &k).unwrap();
    let sim = Simulation::new(&p, &b, law, &DemOptions::default()).unwrap();
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
