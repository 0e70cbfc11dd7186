//! Forces, stress and Hessian against central finite differences of the energy and forces,
//! at a random perturbed, strained state; rotation invariance of the Green–Lagrange measure
//! (and the small strain's O(θ²) error in closed form); the same bits on 1 and 2 threads.

use super::common::lattice::fcc_bonded;
use super::common::on_threads;
use super::setup::*;
use anisobond::manybody::{ManyBody, StrainMeasure};
use anisobond::packing::Packing;
use anisobond::tensor::rotation_z;
use anisobond::{Mat3, Vec3};

/// A random packing's term and a perturbed state: positions jittered by ±2.5 % R̄ in a cell
/// strained by 2 % (every component).
fn state(measure: StrainMeasure) -> (Packing, ManyBody, Vec<Vec3>, Mat3) {
    let (p, b) = thinned(150, 11);
    let mb = term(&p, &b, &cubic_d(), measure);
    assert!(
        !mb.excluded().is_empty(),
        "the test wants rattlers next to the term"
    );
    let h = Mat3::identity() + general_strain(0.02);
    let (x, _) = perturbed(&mb, &p, &h, 0.05 * p.mean_radius(), 7);
    (p, mb, x, h)
}

#[test]
fn forces_are_the_energys_derivative() {
    for measure in [StrainMeasure::GreenLagrange, StrainMeasure::Small] {
        let (p, mb, x, h) = state(measure);
        let ev = mb.evaluate(&mb.branch_vectors(&x, &h).unwrap()).unwrap();
        let step = 1e-6 * p.mean_radius();
        let fmax = ev.forces.iter().fold(0.0_f64, |m, f| m.max(f.norm()));
        let mut worst = 0.0_f64;
        for q in 0..p.len() {
            for k in 0..3 {
                let mut y = x.clone();
                y[q][k] += step;
                let up = mb.energy(&mb.branch_vectors(&y, &h).unwrap()).unwrap();
                y[q][k] -= 2.0 * step;
                let down = mb.energy(&mb.branch_vectors(&y, &h).unwrap()).unwrap();
                let fd = -(up - down) / (2.0 * step);
                worst = worst.max((fd - ev.forces[q][k]).abs() / fmax);
            }
        }
        println!("{measure:?}: forces vs finite differences, max error / max |f| = {worst:.1e}");
        assert!(worst < 1e-6, "{measure:?}: {worst:e}");
        // Energy and evaluate agree.
        let u = mb.energy(&mb.branch_vectors(&x, &h).unwrap()).unwrap();
        assert_eq!(u, ev.energy);
    }
}

/// The nominal stress is (1/V)·∂U/∂H with the particles' fluctuations held.
#[test]
fn stress_is_the_energys_derivative_in_the_cell_gradient() {
    for measure in [StrainMeasure::GreenLagrange, StrainMeasure::Small] {
        let (p, mb, x, h) = state(measure);
        let l = mb.branch_vectors(&x, &h).unwrap();
        let ev = mb.evaluate(&l).unwrap();
        let step = 1e-7;
        let mut worst = 0.0_f64;
        for a in 0..3 {
            for c in 0..3 {
                let shifted = |sign: f64| -> f64 {
                    let l2: Vec<Vec3> = l
                        .iter()
                        .zip(mb.reference_branches())
                        .map(|(lb, rb)| lb + Vec3::ith(a, sign * step * rb[c]))
                        .collect();
                    mb.energy(&l2).unwrap()
                };
                let fd = (shifted(1.0) - shifted(-1.0)) / (2.0 * step) / p.volume();
                worst = worst.max((fd - ev.stress[(a, c)]).abs() / ev.stress.abs().max());
            }
        }
        println!("{measure:?}: stress vs finite differences {worst:.1e}");
        assert!(worst < 1e-6, "{measure:?}: {worst:e}");
    }
}

#[test]
fn hessian_is_the_forces_derivative() {
    for measure in [StrainMeasure::GreenLagrange, StrainMeasure::Small] {
        let (p, mb, x, h) = state(measure);
        let k = mb.hessian(&mb.branch_vectors(&x, &h).unwrap()).unwrap();
        let n = p.len();
        let mut dense = vec![0.0; 9 * n * n];
        let mut kmax = 0.0_f64;
        for r in 0..n {
            for (c, blk) in k.row(r) {
                for a in 0..6 {
                    for e in 0..6 {
                        if a >= 3 || e >= 3 {
                            assert_eq!(blk[(a, e)], 0.0, "rotation DOFs carry nothing");
                        } else {
                            dense[(3 * r + a) * 3 * n + 3 * c + e] = blk[(a, e)];
                            kmax = kmax.max(blk[(a, e)].abs());
                        }
                    }
                }
            }
        }
        let step = 1e-6 * p.mean_radius();
        let mut worst = 0.0_f64;
        for c in 0..n {
            for e in 0..3 {
                let mut y = x.clone();
                y[c][e] += step;
                let up = mb
                    .evaluate(&mb.branch_vectors(&y, &h).unwrap())
                    .unwrap()
                    .forces;
                y[c][e] -= 2.0 * step;
                let down = mb
                    .evaluate(&mb.branch_vectors(&y, &h).unwrap())
                    .unwrap()
                    .forces;
                for r in 0..n {
                    for a in 0..3 {
                        let fd = -(up[r][a] - down[r][a]) / (2.0 * step);
                        worst =
                            worst.max((fd - dense[(3 * r + a) * 3 * n + 3 * c + e]).abs() / kmax);
                    }
                }
            }
        }
        println!("{measure:?}: Hessian vs finite differences of the forces {worst:.1e}");
        assert!(worst < 1e-6, "{measure:?}: {worst:e}");
        // Symmetric, and second neighbours coupled (more blocks than bonds + diagonal).
        for r in 0..n {
            for (c, blk) in k.row(r) {
                let back = k.row(c).find(|(q, _)| *q == r).unwrap().1;
                assert!((blk - back.transpose()).abs().max() <= 1e-12 * kmax);
            }
        }
    }
}

#[test]
fn green_lagrange_is_rotation_invariant_small_strain_is_not() {
    let (p, b) = fcc_bonded(1e-3);
    let theta = 0.3;
    let q = rotation_z(theta);
    // Green–Lagrange: a rigid rotation of the reference has no energy and no force; a
    // rotated deformed state has the energy of the unrotated one and rotated forces.
    let mb = term(&p, &b, &cubic_d(), StrainMeasure::GreenLagrange);
    let (x, _) = perturbed(&mb, &p, &Mat3::identity(), 0.0, 0);
    let rot: Vec<Vec3> = x.iter().map(|v| q * v).collect();
    let ev = mb.evaluate(&mb.branch_vectors(&rot, &q).unwrap()).unwrap();
    let h = Mat3::identity() + general_strain(theta * theta / 2.0);
    let (xs, _) = perturbed(&mb, &p, &h, 0.0, 0);
    let strained = mb.evaluate(&mb.branch_vectors(&xs, &h).unwrap()).unwrap();
    println!(
        "rigid rotation {theta}: U = {:e} J vs {:e} J for a strain of θ²/2",
        ev.energy, strained.energy
    );
    assert!(ev.energy <= 1e-24 * strained.energy);
    let scale = strained.stress.abs().max() * p.mean_radius().powi(2);
    assert!(ev.forces.iter().all(|f| f.norm() < 1e-12 * scale));

    let (pr, br) = thinned(150, 11);
    let mbr = term(&pr, &br, &cubic_d(), StrainMeasure::GreenLagrange);
    let h = Mat3::identity() + general_strain(0.02);
    let (x, _) = perturbed(&mbr, &pr, &h, 0.05 * pr.mean_radius(), 7);
    let a = mbr.evaluate(&mbr.branch_vectors(&x, &h).unwrap()).unwrap();
    let xr: Vec<Vec3> = x.iter().map(|v| q * v).collect();
    let c = mbr
        .evaluate(&mbr.branch_vectors(&xr, &(q * h)).unwrap())
        .unwrap();
    assert!((a.energy - c.energy).abs() < 1e-12 * a.energy);
    let fmax = a.forces.iter().fold(0.0_f64, |m, f| m.max(f.norm()));
    for (fa, fc) in a.forces.iter().zip(&c.forces) {
        assert!((q * fa - fc).norm() < 1e-10 * fmax);
    }

    // Small strain: the rotation strains every particle by ε = sym(Q) − I =
    // (cos θ − 1)(e1e1 + e2e2), so U = ½ ε:D:ε·V exactly (O(θ⁴)); not invariant.
    let mbs = term(&p, &b, &cubic_d(), StrainMeasure::Small);
    let ev = mbs
        .evaluate(&mbs.branch_vectors(&rot, &q).unwrap())
        .unwrap();
    let eps = Mat3::from_diagonal(&Vec3::new(theta.cos() - 1.0, theta.cos() - 1.0, 0.0));
    let e6 = voigt_of(&eps);
    let expect = 0.5 * e6.dot(&(mbs.tensor().unwrap() * e6)) * p.volume();
    assert!(
        (ev.energy - expect).abs() < 1e-10 * expect,
        "{} vs {expect}",
        ev.energy
    );
}

#[test]
fn same_bits_on_one_and_two_threads() {
    for measure in [StrainMeasure::GreenLagrange, StrainMeasure::Small] {
        let (_, mb, x, h) = state(measure);
        let l = mb.branch_vectors(&x, &h).unwrap();
        let run = || {
            let ev = mb.evaluate(&l).unwrap();
            let k = mb.hessian(&l).unwrap();
            let rows: Vec<Vec<(usize, Vec<u64>)>> = (0..k.rows())
                .map(|r| {
                    k.row(r)
                        .map(|(c, b)| (c, b.iter().map(|v| v.to_bits()).collect()))
                        .collect()
                })
                .collect();
            let c = mb.affine_tensor(&l).unwrap();
            (
                ev.energy.to_bits(),
                ev.forces
                    .iter()
                    .flat_map(|f| f.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
                    .collect::<Vec<_>>(),
                ev.stress.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                rows,
                c.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            )
        };
        assert!(on_threads(1, run) == on_threads(2, run), "{measure:?}");
    }
}

/// The load G_r = ∂²U/∂x_r∂e against central differences of the forces in a uniform
/// strain increment δl_b = δe·M(L_b); its rows sum to zero; zero on FCC.
#[test]
fn load_is_the_forces_strain_derivative() {
    for measure in [StrainMeasure::GreenLagrange, StrainMeasure::Small] {
        let (p, mb, x, h) = state(measure);
        let l = mb.branch_vectors(&x, &h).unwrap();
        let g = mb.load(&l).unwrap();
        let gmax = g.iter().fold(0.0_f64, |m, b| m.max(b.abs().max()));
        let step = 1e-7;
        let mut worst = 0.0_f64;
        for a in 0..6 {
            let forces = |sign: f64| {
                let mut e = nalgebra::Vector6::zeros();
                e[a] = sign * step;
                let l2: Vec<Vec3> = l
                    .iter()
                    .zip(mb.reference_branches())
                    .map(|(lb, rb)| lb + affine_map_of(rb) * e)
                    .collect();
                mb.evaluate(&l2).unwrap().forces
            };
            let (up, down) = (forces(1.0), forces(-1.0));
            for r in 0..p.len() {
                for c in 0..3 {
                    let fd = -(up[r][c] - down[r][c]) / (2.0 * step);
                    worst = worst.max((fd - g[r][(c, a)]).abs() / gmax);
                }
                for c in 3..6 {
                    assert_eq!(g[r][(c, a)], 0.0);
                }
            }
        }
        println!("{measure:?}: load vs finite differences {worst:.1e}");
        assert!(worst < 1e-6, "{measure:?}: {worst:e}");
        let total = g
            .iter()
            .fold(nalgebra::Matrix6::<f64>::zeros(), |acc, b| acc + b);
        assert!(total.abs().max() < 1e-10 * gmax);
    }
    let (p, b) = fcc_bonded(1e-3);
    let mb = term(&p, &b, &cubic_d(), StrainMeasure::GreenLagrange);
    let g = mb.load(mb.reference_branches()).unwrap();
    let scale = mb.tensor().unwrap().abs().max() * p.mean_radius().powi(3);
    assert!(g.iter().all(|blk| blk.abs().max() < 1e-10 * scale));
}

/// The affine map ε·L as a 3×6 matrix of the engineering Voigt strain, written out.
fn affine_map_of(l: &Vec3) -> nalgebra::Matrix3x6<f64> {
    nalgebra::Matrix3x6::new(
        l.x,
        0.0,
        0.0,
        0.0,
        0.5 * l.z,
        0.5 * l.y, //
        0.0,
        l.y,
        0.0,
        0.5 * l.z,
        0.0,
        0.5 * l.x, //
        0.0,
        0.0,
        l.z,
        0.5 * l.y,
        0.5 * l.x,
        0.0,
    )
}
