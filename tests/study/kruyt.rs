//! Kruyt 2014 (IJSS), Sec. 6: the local-adjustment-field (LAF) moduli against the exact
//! ones, for shells m = 1, 2, 3, at his coordination numbers and k_t/k_n.
//!
//! His assemblies (Sec. 5): 30,000 bidisperse spheres compressed isotropically *with
//! friction*, which leaves Z below the frictionless 6 (4 to 5.52); rattlers (< 3 contacts)
//! left out; contacts then fixed, k_n and k_t the same everywhere, no rolling resistance;
//! moduli from the stress-based estimate (Sec. 6.2 on) along the paths of Eq. 30. anisobond
//! has no frictional preparation; the nearest equilibrium structure it makes at his Z is the
//! frictionless jammed packing (Kumar's route, Z ≈ 6.6 at D = 0.65) with its weakest contacts
//! (smallest overlaps) left unbonded until Z = 5.52 over the particles with ≥ 3 bonds.
//!
//! `cargo test --release --test study -- --ignored --nocapture kruyt::kruyt_table` prints
//! the table of BENCHMARKS.md (benches/regenerate.py --only kruyt).

use crate::common::lattice::uniform_springs;
use anisobond::bonds::build_bonds;
use anisobond::bonds::{BondSet, BondingRule};
use anisobond::homogenize::laf_tensor;
use anisobond::homogenize::LeverArm;
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions, RelaxedResult};
use anisobond::packing::Packing;
use anisobond::packing::{prepare, PreparationRoute, RouteOptions};
use anisobond::tensor::Stiffness6;
use std::time::Instant;

/// Bulk modulus from Kruyt's isotropic path ε^K = ε₀·I (Eq. 30): K = tr σ/(9ε₀).
pub fn bulk(c: &Stiffness6) -> f64 {
    (0..3)
        .flat_map(|a| (0..3).map(move |b| (a, b)))
        .map(|(a, b)| c[(a, b)])
        .sum::<f64>()
        / 9.0
}

/// Shear modulus from Kruyt's path ε^G = ε₀·diag(1, −½, −½) along axis `x` (Eq. 30):
/// σ − ⅓tr σ = 2G dev ε, so G = (σ_xx − ½(σ_yy + σ_zz))/(3ε₀). Works for a non-symmetric
/// (stress-based) C too.
pub fn shear_path(c: &Stiffness6, x: usize) -> f64 {
    let mut e = [-0.5; 3];
    e[x] = 1.0;
    let s = |a: usize| (0..3).map(|b| c[(a, b)] * e[b]).sum::<f64>();
    let (y, z) = ((x + 1) % 3, (x + 2) % 3);
    (s(x) - 0.5 * (s(y) + s(z))) / 3.0
}

/// The bonds of particles with at least `min` bonds, removed repeatedly (Kruyt 2014 Sec. 5:
/// "rattlers with fewer than three contacts are not taken into account").
pub fn without_rattlers(bonds: &BondSet, n: usize, min: u32) -> BondSet {
    let mut keep = vec![true; bonds.len()];
    loop {
        let mut deg = vec![0u32; n];
        for b in 0..bonds.len() {
            if keep[b] {
                deg[bonds.i[b] as usize] += 1;
                deg[bonds.j[b] as usize] += 1;
            }
        }
        let mut changed = false;
        for b in 0..bonds.len() {
            if keep[b] && (deg[bonds.i[b] as usize] < min || deg[bonds.j[b] as usize] < min) {
                keep[b] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut out = BondSet::default();
    for b in (0..bonds.len()).filter(|&b| keep[b]) {
        out.push(bonds.i[b], bonds.j[b], bonds.branch(b), bonds.image[b]);
    }
    out
}

/// Z over the particles that carry a bond, and their number.
pub fn coordination_of_bonded(bonds: &BondSet, n: usize) -> (f64, usize) {
    let deg = bonds.degrees(n);
    let np = deg.iter().filter(|&&d| d > 0).count();
    (2.0 * bonds.len() as f64 / np as f64, np)
}

/// The relative deviations (LAF − exact)/exact of one network, in %.
#[derive(Clone, Debug)]
pub struct Errors {
    /// Z over the particles that keep a bond (Kruyt's count, rattlers removed).
    pub z: f64,
    /// Particles that keep a bond.
    pub particles: usize,
    /// G_affine/G_exact − 1.
    pub affine_g: f64,
    /// Stress-based K error for m = 1, 2, 3.
    pub k: Vec<f64>,
    /// Stress-based G error for m = 1, 2, 3.
    pub g: Vec<f64>,
    /// Energy-based K and G errors, m = 3.
    pub energy3: (f64, f64),
}

fn exact(p: &Packing, bonds: &BondSet, k: &anisobond::bonds::BondStiffness) -> RelaxedResult {
    relaxed_tensor(
        p,
        bonds,
        k,
        &RelaxedOptions {
            tolerance: 1e-7,
            lever_arm: LeverArm::Proportional,
            ..Default::default()
        },
    )
    .unwrap()
}

/// Kruyt's comparison on one network: exact (relaxed) K and G, and the LAF errors for
/// shells 1..=`m_max` (k_n = 1, k_t = `ratio`, no rolling resistance; contact point on the
/// line of centres dividing it as the radii, Kruyt Eq. 2).
pub fn laf_errors(p: &Packing, bonds: &BondSet, ratio: f64, m_max: usize) -> Errors {
    let (z, particles) = coordination_of_bonded(bonds, p.len());
    let k = uniform_springs(bonds.len(), 1.0, ratio, 0.0, 0.0);
    let ex = exact(p, bonds, &k);
    let (kx, gx) = (bulk(&ex.c), shear_path(&ex.c, 0));
    let pc = |v: f64, x: f64| 100.0 * (v / x - 1.0);
    let mut e = Errors {
        z,
        particles,
        affine_g: pc(shear_path(&ex.c_affine, 0), gx),
        k: vec![],
        g: vec![],
        energy3: (f64::NAN, f64::NAN),
    };
    for m in 1..=m_max {
        let l = laf_tensor(p, bonds, &k, LeverArm::Proportional, m).unwrap();
        e.k.push(pc(bulk(&l.c_stress), kx));
        e.g.push(pc(shear_path(&l.c_stress, 0), gx));
        if m == 3 {
            e.energy3 = (
                pc(bulk(&l.c_energy), kx),
                pc(shear_path(&l.c_energy, 0), gx),
            );
        }
    }
    e
}

fn route_packing(route: PreparationRoute, n: usize, seed: u64) -> Packing {
    let o = RouteOptions {
        route,
        n_particles: n,
        seed,
        ..RouteOptions::default()
    };
    prepare(&o, &|_| {}).unwrap().0
}

/// Bonds of the pairs with the smallest gaps, as many as make Z = `z` over the particles
/// left after removing those with fewer than three (Kruyt's count): bisection on the
/// `coordination` rule's target.
pub fn bonds_at_z(p: &Packing, z: f64) -> BondSet {
    let (mut lo, mut hi) = (z - 1.0, z + 2.0);
    let mut best = BondSet::default();
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        let b = without_rattlers(
            &build_bonds(p, BondingRule::Coordination(mid)).unwrap(),
            p.len(),
            3,
        );
        let (zb, _) = coordination_of_bonded(&b, p.len());
        if zb < z {
            lo = mid;
        } else {
            hi = mid;
        }
        best = b;
        if (zb - z).abs() < 2e-3 {
            break;
        }
    }
    best
}

/// Kumar's contact bonds (κ = 1), rattlers (< 3) removed.
fn contact_bonds(p: &Packing) -> BondSet {
    without_rattlers(
        &build_bonds(p, BondingRule::Factor(1.0)).unwrap(),
        p.len(),
        3,
    )
}

/// Kruyt 2014 Sec. 6.1/6.4 (Z = 5.52, k_t/k_n = 0.8, stress-based): G errors 29 / 12 / 4 %
/// for m = 1 / 2 / 3; m = 3: K 1 % (energy-based 4 %), G energy-based 14 %. On a 1000-sphere
/// jammed packing thinned to his Z (seeds 1–3 measured: G 25.3–30.1 / 10.2–12.0 / 2.6–3.9,
/// K m = 3 1.2–1.3, energy m = 3 K 4.8–5.1, G 13.9–16.1) his numbers hold within the
/// tolerances below; the weakly jammed route at the same Z (κ = 1) gives half as much again
/// at m = 1, which is the structure, not the method.
#[test]
fn kruyt_errors_at_z_5_52_on_a_thinned_jammed_packing() {
    let _alone = crate::common::alone();
    let p = route_packing(PreparationRoute::Jammed, 1000, 1);
    let e = laf_errors(&p, &bonds_at_z(&p, 5.52), 0.8, 3);
    eprintln!("{e:?}");
    assert!((e.z - 5.52).abs() < 0.01, "Z = {}", e.z);
    for (m, (his, tol)) in [(29.0, 6.0), (12.0, 4.0), (4.0, 2.5)]
        .into_iter()
        .enumerate()
    {
        assert!(
            (e.g[m] - his).abs() < tol,
            "m = {}: G {:.1} % against his {his} %",
            m + 1,
            e.g[m]
        );
    }
    assert!(
        e.k[2].abs() < 3.0,
        "m = 3: K {:.1} % against his 1 %",
        e.k[2]
    );
    assert!((e.energy3.0 - 4.0).abs() < 3.0 && (e.energy3.1 - 14.0).abs() < 5.0);
    // His orderings (Sec. 6.1): errors fall with m, K's below G's, stress below energy.
    for m in 0..3 {
        assert!(e.k[m] > 0.0 && e.k[m] < e.g[m]);
        if m > 0 {
            assert!(e.g[m] < e.g[m - 1] && e.k[m] < e.k[m - 1]);
        }
    }
    assert!(e.k[2] < e.energy3.0 && e.g[2] < e.energy3.1);
    // The weakly jammed route at about the same Z: larger fluctuations, larger errors.
    let w = route_packing(PreparationRoute::WeaklyJammed, 1000, 1);
    let ew = laf_errors(&w, &contact_bonds(&w), 0.8, 1);
    eprintln!("weakly jammed: {ew:?}");
    assert!((ew.z - 5.52).abs() < 0.25, "Z = {}", ew.z);
    assert!(ew.g[0] > e.g[0] + 8.0 && ew.affine_g > e.affine_g + 15.0);
}

/// "mean (min–max)" of per-seed values.
fn spread(v: &[f64]) -> String {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    if v.len() == 1 {
        return format!("{mean:.1}");
    }
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    format!("{mean:.1} ({lo:.1}–{hi:.1})")
}

fn row(label: &str, es: &[Errors], t: f64) -> String {
    let col = |f: &dyn Fn(&Errors) -> f64| spread(&es.iter().map(f).collect::<Vec<_>>());
    format!(
        "ROW| {label} | {} | {} | {} | {} / {} / {} | {} / {} / {} | {} / {} | {t:.0} s |",
        spread3(&es.iter().map(|e| e.z).collect::<Vec<_>>()),
        es[0].particles,
        col(&|e| e.affine_g),
        col(&|e| e.k[0]),
        col(&|e| e.k[1]),
        col(&|e| e.k[2]),
        col(&|e| e.g[0]),
        col(&|e| e.g[1]),
        col(&|e| e.g[2]),
        col(&|e| e.energy3.0),
        col(&|e| e.energy3.1),
    )
}

/// Z to two decimals (mean over seeds).
fn spread3(v: &[f64]) -> String {
    format!("{:.2}", v.iter().sum::<f64>() / v.len() as f64)
}

/// Kruyt 2014's table beside ours: 5000 spheres (Kumar's size; Kruyt 30,000), seeds 1–3.
#[test]
#[ignore]
fn kruyt_table() {
    let _alone = crate::common::alone();
    let n = 5000;
    let seeds = [1u64, 2, 3];
    println!(
        "ROW| Kruyt 2014 (Secs. 6.1, 6.4; 30,000 frictional spheres) | 5.52 | 30,000 | – | – / – / 1 | 29 / 12 / 4 | 4 / 14 | – |"
    );
    let (mut thin, mut contact, mut weak) = (vec![], vec![], vec![]);
    let (mut t_thin, mut t_contact, mut t_weak) = (0.0, 0.0, 0.0);
    let mut sweep = vec![];
    for &seed in &seeds {
        let t = Instant::now();
        let p = route_packing(PreparationRoute::Jammed, n, seed);
        let t_prep = t.elapsed().as_secs_f64();
        let b = bonds_at_z(&p, 5.52);
        thin.push(laf_errors(&p, &b, 0.8, 3));
        t_thin += t.elapsed().as_secs_f64();
        let t = Instant::now();
        contact.push(laf_errors(&p, &contact_bonds(&p), 0.8, 3));
        t_contact += t_prep + t.elapsed().as_secs_f64();
        if seed == 1 {
            for ratio in [0.2, 0.4, 0.6, 0.8, 1.0] {
                sweep.push((ratio, laf_errors(&p, &b, ratio, 3)));
            }
        }
        let t = Instant::now();
        let w = route_packing(PreparationRoute::WeaklyJammed, n, seed);
        weak.push(laf_errors(&w, &contact_bonds(&w), 0.8, 3));
        t_weak += t.elapsed().as_secs_f64();
    }
    println!(
        "{}",
        row(
            "jammed, thinned to Z = 5.52 (weakest contacts unbonded)",
            &thin,
            t_thin
        )
    );
    println!(
        "{}",
        row(
            "weakly jammed, κ = 1 (Kumar's route; Z ≈ 5.4 before rattlers are removed)",
            &weak,
            t_weak
        )
    );
    println!(
        "{}",
        row("jammed, κ = 1 (all contacts)", &contact, t_contact)
    );
    let t = Instant::now();
    let p = route_packing(PreparationRoute::Jammed, n, 1);
    let b = bonds_at_z(&p, 4.5);
    let low = std::panic::catch_unwind(|| laf_errors(&p, &b, 0.8, 3));
    match low {
        Ok(e) => println!("{}", row("jammed, thinned to Z = 4.5 (seed 1)", &[e], t.elapsed().as_secs_f64())),
        Err(_) => println!("ROW| jammed, thinned to Z = 4.5 (seed 1) | 4.50 | – | – | refused: see the log | | | |"),
    }
    println!("ROW| Kruyt 2014 (Sec. 6.2), Z = 4 to 5.52, m = 3 | 4–5.52 | 30,000 | – | – / – / 1–6 | – / – / 2–16 | – | – |");
    for (ratio, e) in sweep {
        println!(
            "SWEEP| {ratio} | {:.1} | {:.1} / {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.1} / {:.1} |",
            e.affine_g, e.k[0], e.k[1], e.k[2], e.g[0], e.g[1], e.g[2], e.energy3.0, e.energy3.1
        );
    }
    println!("SWEEP| Kruyt 2014 (Sec. 6.3), 0.2–1.0 | – | – / – / 1–2 | – / – / 3–6 | – |");
}
