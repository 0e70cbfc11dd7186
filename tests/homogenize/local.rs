//! The relaxed solution's local fields (docs/references.md "Local fields"): the particles'
//! Love–Weber stresses add up to the relaxed tensor's stress C·ε; on SC and FCC lattices
//! every particle carries the closed-form stress and the applied strain; grouped statistics
//! against sums done here; the same bits on one and two threads; refusals.

use super::common::lattice::{disordered_fcc, fcc_bonded, simple_cubic_bonded, uniform_springs};
use super::common::{on_threads, CUBIC_MODEL};
use anisobond::assembly::{Assembly, Method};
use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::homogenize::{
    local_fields, DegenerateFit, LocalFields, LocalOptions, RelaxedOptions, RelaxedSolver,
    UnfittedReason,
};
use anisobond::model::Model;
use anisobond::packing::{generate, GenerateOptions, Packing};
use anisobond::tensor::{Stiffness6, Voigt6};
use anisobond::{Error, Vec3};

/// A general small strain (engineering, Voigt).
fn strain() -> Voigt6 {
    Voigt6::new(1.0e-4, -0.4e-4, 0.7e-4, 0.9e-4, -0.5e-4, 0.3e-4)
}

/// Springs that differ from bond to bond, with rotational springs (a disordered network
/// whose particles carry moments too).
fn varied_springs(n: usize) -> BondStiffness {
    let mut k = uniform_springs(n, 1e6, 0.6e6, 2e-3, 1e-3);
    for b in 0..n {
        let s = 1.0 + 0.5 * (b as f64 * 0.7).sin();
        k.kn[b] *= s;
        k.ks[b] *= 2.0 - s;
        k.kr[b] *= s * s;
    }
    k
}

/// `p` with radii between 0.85 and 1.15 of its own (the bonds and their branch vectors
/// unchanged): unequal contact arms and particle volumes.
fn polydisperse(p: &Packing) -> Packing {
    let radii = (0..p.len())
        .map(|q| p.radii[q] * (1.0 + 0.15 * (1.3 * q as f64).sin()))
        .collect();
    Packing::new(p.positions.clone(), radii, p.cell).unwrap()
}

/// The relaxed options with the direct solver (exact up to rounding).
fn cholesky() -> LocalOptions {
    LocalOptions {
        relaxed: RelaxedOptions {
            solver: RelaxedSolver::Cholesky,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Σ_p V_p σ_p / V, summed here.
fn volume_mean_stress(f: &LocalFields) -> Voigt6 {
    let mut s = Voigt6::zeros();
    for (v, sigma) in f.particle_volume.iter().zip(&f.particle_stress) {
        s += sigma * *v;
    }
    s / f.volume
}

/// Largest |entry| of a Voigt vector.
fn amax(v: &Voigt6) -> f64 {
    v.amax()
}

/// (a) On a disordered network with rotational springs (and with a pruned particle and a
/// two-bond one) Σ_p V_p σ_p / V equals C_relaxed·ε of the same (direct) solve to 1e-12 and the
/// particle volumes add to V (unequal radii); every load-carrying particle is in force and
/// torque balance.
#[test]
fn particle_stresses_add_up_to_the_relaxed_stress() {
    for thin in [false, true] {
        let (p, b) = if thin {
            thinned_network(7)
        } else {
            disordered_fcc(3, 7, 0.25)
        };
        let p = polydisperse(&p);
        let k = varied_springs(b.len());
        let e = strain();
        let f = local_fields(&p, &b, &k, &e, &cholesky()).unwrap();
        let ce: Voigt6 = f.relaxed.c * e;
        let mean = volume_mean_stress(&f);
        let err = amax(&(mean - ce)) / amax(&ce);
        println!("thinned {thin}: |Σ V_p σ_p / V − C·ε| / |C·ε| = {err:.2e}");
        assert!(err < 1e-12, "thinned {thin}: {mean} vs {ce}");
        assert!(amax(&(f.stress - ce)) < 1e-12 * amax(&ce));
        let vsum: f64 = f.particle_volume.iter().sum();
        assert!((vsum - p.volume()).abs() < 1e-14 * p.volume());
        // Force balance of every particle carrying load (exact solve).
        let mut net = vec![Vec3::zeros(); p.len()];
        let fmax = f.bond_force.iter().map(|x| x.norm()).fold(0.0, f64::max);
        for (bi, force) in f.bond_force.iter().enumerate() {
            net[b.i[bi] as usize] += force;
            net[b.j[bi] as usize] -= force;
        }
        let worst = net.iter().map(|x| x.norm()).fold(0.0, f64::max);
        assert!(
            worst < 1e-9 * fmax,
            "thinned {thin}: unbalanced {worst:e} of {fmax:e}"
        );
        // Torque balance about every centre, with the mid-gap contact arms written out here
        // (r_i = R_i + gap/2): the force arms of the stresses and the bond moments are those
        // of the solve.
        let mut torque = vec![Vec3::zeros(); p.len()];
        for (bi, force) in f.bond_force.iter().enumerate() {
            let (i, j) = (b.i[bi] as usize, b.j[bi] as usize);
            let (n, l) = (b.normal[bi], b.length[bi]);
            let gap = l - p.radii[i] - p.radii[j];
            let (ri, rj) = (p.radii[i] + 0.5 * gap, p.radii[j] + 0.5 * gap);
            torque[i] += (n * ri).cross(force) + f.bond_moment[bi];
            torque[j] += (n * rj).cross(force) - f.bond_moment[bi];
        }
        let worst = torque.iter().map(|x| x.norm()).fold(0.0, f64::max);
        let scale = fmax * 1e-3;
        assert!(
            worst < 1e-9 * scale,
            "thinned {thin}: torque {worst:e} of {scale:e}"
        );
        let mmax = f.bond_moment.iter().map(|x| x.norm()).fold(0.0, f64::max);
        assert!(mmax > 1e-6 * scale, "the bonds carry moments: {mmax:e}");
        if thin {
            assert_eq!(f.relaxed.null_space.removed_particles, 1);
            let reasons: Vec<_> = f
                .unfitted
                .iter()
                .map(|u| (u.particle, u.bonds, u.reason))
                .collect();
            assert!(
                reasons.contains(&(3, 0, UnfittedReason::NoLoad)),
                "{reasons:?}"
            );
            assert!(
                reasons.contains(&(8, 2, UnfittedReason::FewBonds)),
                "{reasons:?}"
            );
            assert_eq!(f.particle_stress[3], Voigt6::zeros());
        }
    }
}

/// The closed-form lattice tensor with C11, C12, C44.
fn cubic(c11: f64, c12: f64, c44: f64) -> Stiffness6 {
    Stiffness6::from_fn(|a, b| match (a < 3, b < 3) {
        (true, true) if a == b => c11,
        (true, true) => c12,
        _ if a == b => c44,
        _ => 0.0,
    })
}

/// (b) SC and FCC (centro-symmetric: no fluctuation): every particle's stress is the
/// closed-form C·ε (docs/references.md "Relaxed (static) stiffness") and its strain ε, to
/// rounding; fluctuations and rotations zero; every particle fitted.
#[test]
fn lattices_are_affine_particle_by_particle() {
    let r = 1e-3;
    let (kn, kt) = (2.0e6, 0.7e6);
    let s2r = std::f64::consts::SQRT_2 * r;
    let cases = [
        (
            "simple cubic",
            simple_cubic_bonded(r),
            cubic(kn / (2.0 * r), 0.0, kt / (4.0 * r)),
        ),
        (
            "FCC",
            fcc_bonded(r),
            cubic(
                (kn + kt) / s2r,
                (kn - kt) / (2.0 * s2r),
                (kn + kt) / (2.0 * s2r),
            ),
        ),
    ];
    let e = strain();
    for (name, (p, b), c) in cases {
        let k = uniform_springs(b.len(), kn, kt, 1e-3, 5e-4);
        let f = local_fields(&p, &b, &k, &e, &LocalOptions::default()).unwrap();
        let sigma = c * e;
        assert!(f.unfitted.is_empty(), "{name}: {:?}", f.unfitted);
        for q in 0..p.len() {
            let ds = amax(&(f.particle_stress[q] - sigma));
            assert!(
                ds < 1e-12 * amax(&sigma),
                "{name} particle {q}: stress off by {ds:e}"
            );
            let de = amax(&(f.particle_strain[q].unwrap() - e));
            assert!(
                de < 1e-12 * amax(&e),
                "{name} particle {q}: strain off by {de:e}"
            );
            assert!(
                f.fluctuation[q].amax() < 1e-15 * r,
                "{name}: {}",
                f.fluctuation[q]
            );
            assert!(f.rotation[q].amax() < 1e-15, "{name}: {}", f.rotation[q]);
        }
        let cell = f.cell_statistics();
        assert!(cell.std_stress_pa.iter().all(|s| *s < 1e-12 * amax(&sigma)));
        assert!(f.bond_moment.iter().all(|m| m.amax() < 1e-15));
    }
}

/// (c) One label's statistics are the cell's; with labels by a plane cut the two groups'
/// volume-weighted means average back to the cell's, and a group's mean and spread equal
/// those summed here; counts and the JSON keys.
#[test]
fn grouped_statistics_recombine_to_the_cell() {
    let (p, b) = thinned_network(11);
    let k = varied_springs(b.len());
    let f = local_fields(&p, &b, &k, &strain(), &cholesky()).unwrap();
    let n = p.len();
    assert_eq!(f.unfitted.len(), 2, "{:?}", f.unfitted);

    let one = f.statistics(&vec![4; n]).unwrap();
    assert_eq!(one.groups.len(), 1);
    let mut g = one.groups[0].clone();
    assert_eq!(g.label, Some(4));
    g.label = None;
    assert_eq!(g, one.cell);
    assert_eq!(one.cell, f.cell_statistics());
    assert_eq!(one.cell.particles, n);
    assert_eq!(one.cell.fitted_particles, n - f.unfitted.len());
    let s: Voigt6 = one.cell.mean_stress_pa.into();
    assert!(amax(&(s - f.stress)) < 1e-12 * amax(&f.stress));

    let half = p.cell.unwrap().lengths.x / 2.0;
    let labels: Vec<u32> = p.positions.iter().map(|x| u32::from(x.x >= half)).collect();
    let rep = f.statistics(&labels).unwrap();
    assert_eq!(rep.groups.len(), 2);
    let (g0, g1) = (&rep.groups[0], &rep.groups[1]);
    assert_eq!(g0.particles + g1.particles, n);
    assert_eq!(
        g0.fitted_particles + g1.fitted_particles,
        rep.cell.fitted_particles
    );
    let v = g0.volume_m3 + g1.volume_m3;
    let fv = g0.fitted_volume_m3 + g1.fitted_volume_m3;
    for c in 0..6 {
        let back = (g0.volume_m3 * g0.mean_stress_pa[c] + g1.volume_m3 * g1.mean_stress_pa[c]) / v;
        let scale = rep
            .cell
            .mean_stress_pa
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!((back - rep.cell.mean_stress_pa[c]).abs() < 1e-12 * scale);
        let (m0, m1, mc) = (
            g0.mean_strain.unwrap(),
            g1.mean_strain.unwrap(),
            rep.cell.mean_strain.unwrap(),
        );
        let back = (g0.fitted_volume_m3 * m0[c] + g1.fitted_volume_m3 * m1[c]) / fv;
        assert!((back - mc[c]).abs() < 1e-12 * amax(&strain()));
    }

    // Group 1's mean and spread summed here, strain over its fitted particles only.
    let members: Vec<usize> = (0..n).filter(|&q| labels[q] == 1).collect();
    let (mut w, mut ws) = (0.0, Voigt6::zeros());
    let (mut we, mut wes) = (0.0, Voigt6::zeros());
    for &q in &members {
        w += f.particle_volume[q];
        ws += f.particle_stress[q] * f.particle_volume[q];
        if let Some(e) = f.particle_strain[q] {
            we += f.particle_volume[q];
            wes += e * f.particle_volume[q];
        }
    }
    let (ms, me) = (ws / w, wes / we);
    for c in 0..6 {
        let var_s: f64 = members
            .iter()
            .map(|&q| f.particle_volume[q] * (f.particle_stress[q][c] - ms[c]).powi(2))
            .sum::<f64>()
            / w;
        let var_e: f64 = members
            .iter()
            .filter_map(|&q| {
                f.particle_strain[q].map(|e| f.particle_volume[q] * (e[c] - me[c]).powi(2))
            })
            .sum::<f64>()
            / we;
        assert!((g1.mean_stress_pa[c] - ms[c]).abs() <= 1e-12 * amax(&ms));
        assert!((g1.std_stress_pa[c] - var_s.sqrt()).abs() <= 1e-10 * var_s.sqrt());
        assert!((g1.mean_strain.unwrap()[c] - me[c]).abs() <= 1e-12 * amax(&me));
        assert!((g1.std_strain.unwrap()[c] - var_e.sqrt()).abs() <= 1e-10 * var_e.sqrt());
    }
    // The spread is real: a disordered network's particles do not all carry the mean.
    assert!(rep.cell.std_stress_pa[0] > 1e-3 * rep.cell.mean_stress_pa[0].abs());

    let json: serde_json::Value = serde_json::from_str(&rep.to_json().unwrap()).unwrap();
    assert_eq!(json["groups"][1]["label"], 1);
    assert!(json["cell"]["mean_stress_pa"].is_array());
    assert!(json["cell"]["std_strain"].is_array());
    assert!(json["cell"].get("label").is_none());
    assert_eq!(json["unfitted"].as_array().unwrap().len(), f.unfitted.len());
}

/// (d) The default solver (two-level CG) gives the same bits on one and two threads, fields
/// and report alike.
#[test]
fn local_fields_are_thread_count_independent() {
    let (p, b) = disordered_fcc(4, 3, 0.2);
    let k = varied_springs(b.len());
    let labels: Vec<u32> = (0..p.len() as u32).map(|q| q % 5).collect();
    let run = |t: usize| {
        on_threads(t, || {
            let f = local_fields(&p, &b, &k, &strain(), &LocalOptions::default()).unwrap();
            let json = f.statistics(&labels).unwrap().to_json().unwrap();
            (f, json)
        })
    };
    let (f1, j1) = run(1);
    let (f2, j2) = run(2);
    assert_eq!(j1, j2);
    assert_eq!(f1.fluctuation, f2.fluctuation);
    assert_eq!(f1.rotation, f2.rotation);
    assert_eq!(f1.particle_stress, f2.particle_stress);
    assert_eq!(f1.particle_strain, f2.particle_strain);
    assert_eq!(f1.bond_force, f2.bond_force);
    assert_eq!(f1.bond_moment, f2.bond_moment);
    assert_eq!(f1.stress, f2.stress);
}

/// `bonds` without those of particle `q`.
fn without_bonds_of(b: &BondSet, q: u32) -> BondSet {
    let mut out = BondSet::default();
    for k in 0..b.len() {
        if b.i[k] != q && b.j[k] != q {
            out.push(b.i[k], b.j[k], b.branch(k), b.image[k]);
        }
    }
    out
}

/// `bonds` with particle `q` keeping only its first `keep` bonds (in bond order).
fn thinned(b: &BondSet, q: u32, keep: usize) -> BondSet {
    let mut out = BondSet::default();
    let mut kept = 0;
    for k in 0..b.len() {
        if b.i[k] == q || b.j[k] == q {
            if kept == keep {
                continue;
            }
            kept += 1;
        }
        out.push(b.i[k], b.j[k], b.branch(k), b.image[k]);
    }
    out
}

/// A disordered network (gap 0.25 R) where particle 3 keeps one bond (pruned: no load) and
/// particle 8 two (load-carrying, too few bonds for a strain fit).
fn thinned_network(seed: u64) -> (Packing, BondSet) {
    let (p, b) = disordered_fcc(3, seed, 0.25);
    (p, thinned(&thinned(&b, 3, 1), 8, 2))
}

/// (e) A particle without bonds: refused by `DegenerateFit::Refuse` naming it; by default
/// left out of the strain fit and named (no load, zero stress, volume still counted, the
/// identity of (a) kept). Bad labels, strains and cells are refused by kind.
#[test]
fn refusals_and_the_particle_without_bonds() {
    let (p, b) = disordered_fcc(3, 5, 0.25);
    let b = without_bonds_of(&b, 5);
    let k = varied_springs(b.len());
    let e = strain();
    let refuse = LocalOptions {
        degenerate: DegenerateFit::Refuse,
        ..cholesky()
    };
    match local_fields(&p, &b, &k, &e, &refuse) {
        Err(Error::Degenerate(m)) => assert!(m.contains("particle 5 "), "{m}"),
        other => panic!("expected Error::Degenerate, got {other:?}"),
    }
    let f = local_fields(&p, &b, &k, &e, &cholesky()).unwrap();
    let u = f.unfitted.iter().find(|u| u.particle == 5).unwrap();
    assert_eq!((u.bonds, u.reason), (0, UnfittedReason::NoLoad));
    assert!(!f.active[5] && f.particle_strain[5].is_none());
    assert_eq!(f.particle_stress[5], Voigt6::zeros());
    assert!(f.particle_volume[5] > 0.0);
    let ce: Voigt6 = f.relaxed.c * e;
    assert!(amax(&(volume_mean_stress(&f) - ce)) < 1e-12 * amax(&ce));
    let cell = f.cell_statistics();
    assert!((cell.volume_m3 - p.volume()).abs() < 1e-14 * p.volume());
    assert!(cell.fitted_volume_m3 < cell.volume_m3 - 0.5 * f.particle_volume[5]);

    // Labels of the wrong count.
    assert!(matches!(f.statistics(&[0; 3]), Err(Error::Invalid(_))));
    // Strains that are not small or not finite; a conditioning out of range.
    for bad in [0.5, f64::NAN, f64::INFINITY] {
        let mut s = e;
        s[3] = bad;
        match local_fields(&p, &b, &k, &s, &cholesky()) {
            Err(Error::Invalid(m)) => assert!(m.contains("strain"), "{m}"),
            other => panic!("strain {bad}: expected Error::Invalid, got {other:?}"),
        }
    }
    let cond = LocalOptions {
        conditioning: 1.0,
        ..cholesky()
    };
    assert!(matches!(
        local_fields(&p, &b, &k, &e, &cond),
        Err(Error::Invalid(_))
    ));
    // A free cluster (no periodic cell).
    let free = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    assert!(matches!(
        local_fields(&free, &b, &k, &e, &cholesky()),
        Err(Error::Invalid(_))
    ));
}

/// `Assembly::local_fields` on a generated packing with the cubic model: the stress of the
/// solve as `Assembly::tensor(relaxed)` gives it (the same options), Σ V_p σ_p / V equal to
/// the Love stress; with `[manybody]` the same with the term's share.
#[test]
fn assembly_local_fields_match_its_relaxed_tensor() {
    let packing = generate(
        &GenerateOptions {
            n_particles: 300,
            seed: 2,
            ..Default::default()
        },
        &|_| {},
    )
    .unwrap();
    let model = Model::from_toml_str(CUBIC_MODEL, "<cubic>").unwrap();
    let a = Assembly::new(packing.clone(), model).unwrap();
    let opts = LocalOptions::default();
    let f = a.local_fields(&strain(), &opts).unwrap();
    let t = a.tensor(&Method::Relaxed(opts.relaxed)).unwrap();
    let c: Stiffness6 = Stiffness6::from_fn(|i, j| t.report.c[i][j]);
    let ce: Voigt6 = c * strain();
    let mean = volume_mean_stress(&f);
    assert!(amax(&(mean - f.stress)) < 1e-12 * amax(&f.stress));
    // The CG's tolerance (1e-6) bounds the Love stress's distance from the variational C·ε.
    let err = amax(&(mean - ce)) / amax(&ce);
    println!("generated 300: |Σ V_p σ_p / V − C·ε| / |C·ε| = {err:.2e} (CG 1e-6)");
    assert!(err < 1e-5, "{err:e}");

    let with_term = Model::from_toml_str(
        &format!(
            "{CUBIC_MODEL}\n[manybody]\nkind = \"isotropic\"\nbulk = 30e9\nshear = 8e9\n\
             measure = \"small\"\n"
        ),
        "<cubic+term>",
    )
    .unwrap();
    // With the term: its share joins each particle's stress, and Σ V_p σ_p / V is the
    // relaxed tensor's C·ε with the term (tests/polycrystal/manybody.rs checks it per grain).
    let a = Assembly::new(packing, with_term).unwrap();
    let f = a.local_fields(&strain(), &opts).unwrap();
    let t = a.tensor(&Method::Relaxed(opts.relaxed)).unwrap();
    let ce: Voigt6 = Stiffness6::from_fn(|i, j| t.report.c[i][j]) * strain();
    let mean = volume_mean_stress(&f);
    assert!(amax(&(mean - f.stress)) < 1e-12 * amax(&f.stress));
    let err = amax(&(mean - ce)) / amax(&ce);
    println!("generated 300 with the term: |Σ V_p σ_p / V − C·ε| / |C·ε| = {err:.2e} (CG 1e-6)");
    assert!(err < 1e-5, "{err:e}");
}
