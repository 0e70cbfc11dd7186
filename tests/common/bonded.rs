//! Bonded packings, springs, exact relaxed tensors and simulations that several test
//! modules set up the same way (the integrator's element tests, grips, stop rule, lanes,
//! calibration, VTK export).

use anisobond::bonds::{build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::dem::{build_law, DemOptions, LawKind, Simulation};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions, RelaxedResult};
use anisobond::packing::Packing;
use anisobond::packing::{generate, GenerateOptions};

/// A generated periodic packing of `n` particles (`seed`, default generation options).
pub fn generated(n: usize, seed: u64) -> Packing {
    generate(
        &GenerateOptions {
            n_particles: n,
            seed,
            ..Default::default()
        },
        &|_| {},
    )
    .expect("packing")
}

/// [`generated`], bonded with gap 0.17 R̄.
pub fn gap_bonded(n: usize, seed: u64) -> (Packing, BondSet) {
    let p = generated(n, seed);
    let b = build_bonds(&p, BondingRule::Gap(0.17)).expect("bonds");
    (p, b)
}

/// [`gap_bonded`] with springs that depend on the bond direction through k_n only:
/// k_n = 10⁶(1 + n_x²), k_s = 0.4·10⁶ N/m, k_r = 0.1·10⁶ R̄², k_tw = 0.05·10⁶ R̄² N·m/rad.
pub fn periodic_bonded(n: usize, seed: u64) -> (Packing, BondSet, BondStiffness) {
    let (p, b) = gap_bonded(n, seed);
    let r = p.mean_radius();
    let nb = b.len();
    let k = BondStiffness {
        radius: vec![r; nb],
        kn: (0..nb)
            .map(|e| 1e6 * (1.0 + b.normal[e].x.powi(2)))
            .collect(),
        ks: vec![0.4e6; nb],
        kr: vec![0.1e6 * r * r; nb],
        ktw: vec![0.05e6 * r * r; nb],
    };
    (p, b, k)
}

/// Anisotropic springs: k_n and k_s depend on the bond direction (so that every one of the
/// 21 components is exercised); with `moments`, bending k_n R̄²/4 and twisting k_s R̄²/2.
pub fn directional_springs(p: &Packing, b: &BondSet, moments: bool) -> BondStiffness {
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

/// The exact relaxed tensor (solver tolerance 1e-10): the reference of the element tests.
pub fn relaxed_exact(p: &Packing, b: &BondSet, k: &BondStiffness) -> RelaxedResult {
    relaxed_tensor(
        p,
        b,
        k,
        &RelaxedOptions {
            tolerance: 1e-10,
            ..Default::default()
        },
    )
    .unwrap()
}

/// The integrator with YADE's law; `dt` None is the default (critical-step based) step.
pub fn yade_sim(p: &Packing, b: &BondSet, k: &BondStiffness, dt: Option<f64>) -> Simulation {
    let law = build_law(LawKind::Yade, p, b, k).unwrap();
    Simulation::new(
        p,
        b,
        law,
        &DemOptions {
            time_step: dt,
            ..Default::default()
        },
    )
    .unwrap()
}
