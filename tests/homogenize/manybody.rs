//! The many-body term (docs/manybody.md) in the Voigt-level and relaxed tensors: SC and FCC
//! lattices against their closed forms plus D; a disordered packing against a dense solve
//! of the total energy's Hessian built independently (the springs' elements written out
//! here, the term's blocks by differences of its forces and stress); the CLI `tensor`
//! command on a model file with `[manybody]` against the library; the same bits on one and
//! two threads.

use super::common::lattice::{fcc_bonded, max_abs, simple_cubic_bonded, uniform_springs};
use super::common::{bin, on_threads, packing, stderr, tmp, write, CUBIC_MODEL};
use anisobond::assembly::{Assembly, Method};
use anisobond::bonds::{build_bonds, BondSet, BondStiffness, BondingRule};
use anisobond::homogenize::{
    relaxed_tensor, relaxed_tensor_with_term, voigt_tensor, CgPreconditioner, LeverArm,
    RelaxedOptions, RelaxedSolver,
};
use anisobond::manybody::{
    DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions, StrainMeasure,
};
use anisobond::packing::Packing;
use anisobond::tensor::{
    isotropic_from_bulk_shear, rotation_x, rotation_y, rotation_z, Stiffness6,
};
use anisobond::{Error, Mat3, Vec3};
use nalgebra::{DMatrix, Matrix3x6};

/// The term of `d` with `measure`, degenerate particles excluded.
fn term(p: &Packing, b: &BondSet, d: &LocalTensor, measure: StrainMeasure) -> ManyBody {
    ManyBody::new(
        p,
        b,
        d,
        &ManyBodyOptions {
            measure,
            degenerate: DegenerateParticles::Exclude,
            ..Default::default()
        },
    )
    .unwrap()
}

/// A cubic D (a Cauchy-violating C12 > C44) in a general orientation.
fn cubic_d(scale: f64) -> LocalTensor {
    LocalTensor::Cubic {
        c11: 2.0 * scale,
        c12: 1.2 * scale,
        c44: 0.5 * scale,
        rotation: rotation_z(0.3) * rotation_y(-0.7) * rotation_x(1.1),
    }
}

/// Smallest eigenvalue of the symmetric part.
fn min_eig(c: &Stiffness6) -> f64 {
    nalgebra::SymmetricEigen::new((c + c.transpose()) * 0.5)
        .eigenvalues
        .min()
}

/// (a) SC and FCC with the term: relaxed (both solvers) = Voigt level = closed-form C of the
/// lattice + D (centro-symmetric: the load G vanishes, relaxed = affine), to 1e-10.
#[test]
fn lattices_with_the_term_relax_to_their_closed_form_plus_d() {
    let r = 1e-3;
    let (kn, kt) = (2.0e6, 0.7e6);
    let s2r = std::f64::consts::SQRT_2 * r;
    let closed = |c11: f64, c12: f64, c44: f64| {
        Stiffness6::from_fn(|a, b| match (a < 3, b < 3) {
            (true, true) if a == b => c11,
            (true, true) => c12,
            _ if a == b => c44,
            _ => 0.0,
        })
    };
    let cases = [
        (
            "simple cubic",
            simple_cubic_bonded(r),
            closed(kn / (2.0 * r), 0.0, kt / (4.0 * r)),
        ),
        (
            "FCC",
            fcc_bonded(r),
            closed(
                (kn + kt) / s2r,
                (kn - kt) / (2.0 * s2r),
                (kn + kt) / (2.0 * s2r),
            ),
        ),
    ];
    let scale = kn / r;
    let ds = [
        (
            LocalTensor::Isotropic {
                bulk: 0.4 * scale,
                shear: 0.1 * scale,
            },
            isotropic_from_bulk_shear(0.4 * scale, 0.1 * scale),
        ),
        (cubic_d(0.3 * scale), Stiffness6::zeros()),
    ];
    for (name, (p, b), c_lattice) in &cases {
        // Rotational springs lock the lattices' counter-rotating gear modes (a mechanism
        // the Cholesky refuses); they add nothing under a uniform strain.
        let k = uniform_springs(b.len(), kn, kt, kn * r * r / 4.0, kt * r * r / 2.0);
        for (d, d_ref) in &ds {
            let mb = term(p, b, d, StrainMeasure::GreenLagrange);
            assert!(mb.excluded().is_empty());
            // The cubic D's lab matrix comes from the library's own rotation (its textbook
            // form is checked in tests/manybody); the isotropic one is written out.
            let d_lab = if max_abs(d_ref) > 0.0 {
                *d_ref
            } else {
                *mb.tensor().unwrap()
            };
            let expect = c_lattice + d_lab;
            for solver in [RelaxedSolver::Cholesky, RelaxedSolver::default()] {
                let opts = RelaxedOptions {
                    solver,
                    tolerance: 1e-12,
                    ..Default::default()
                };
                let res = relaxed_tensor_with_term(p, b, &k, Some(&mb), &opts).unwrap();
                let err = max_abs(&(res.c - expect)) / max_abs(&expect);
                let err_aff = max_abs(&(res.c_affine - expect)) / max_abs(&expect);
                println!("{name} {solver:?}: relaxed {err:.1e}, affine {err_aff:.1e}");
                assert!(err < 1e-10, "{name} {solver:?}: relaxed {err:e}");
                assert!(err_aff < 1e-10, "{name}: affine {err_aff:e}");
            }
        }
    }
}

/// Skew matrix [a]× (a × v = [a]× v).
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// ε·l as a linear map of the engineering Voigt strain (order 11 22 33 23 13 12).
fn strain_map(l: &Vec3) -> Matrix3x6<f64> {
    let mut m = Matrix3x6::zeros();
    let pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
    for (a, &(i, j)) in pairs.iter().enumerate() {
        if i == j {
            m[(i, a)] = l[i];
        } else {
            m[(i, a)] += 0.5 * l[j];
            m[(j, a)] += 0.5 * l[i];
        }
    }
    m
}

/// The strain tensor of engineering Voigt component `k` of size `h`.
fn unit_strain(k: usize, h: f64) -> Mat3 {
    let pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
    let (i, j) = pairs[k];
    let mut e = Mat3::zeros();
    if i == j {
        e[(i, i)] = h;
    } else {
        e[(i, j)] = 0.5 * h;
        e[(j, i)] = 0.5 * h;
    }
    e
}

/// The dense energy Hessian [[K, G], [Gᵀ, H]] of the springs and the term over 6 DOFs per
/// particle (translation, rotation) and the 6 strains, built without the library's network
/// or the term's `hessian`/`load`/`affine_tensor`: the springs' Kruyt (2014, Eqs. 10–14)
/// elements written out (mid-gap lever arms), the term's blocks by central differences of
/// its forces (K, G) and nominal stress (H). The small-strain measure is linear in the
/// positions, so the differences are exact up to rounding.
fn dense_hessian(
    p: &Packing,
    b: &BondSet,
    k: &BondStiffness,
    mb: &ManyBody,
) -> (DMatrix<f64>, DMatrix<f64>, Stiffness6) {
    let n = p.len();
    let mut kk = DMatrix::<f64>::zeros(6 * n, 6 * n);
    let mut gg = DMatrix::<f64>::zeros(6 * n, 6);
    let mut hh = Stiffness6::zeros();
    for e in 0..b.len() {
        let (i, j) = (b.i[e] as usize, b.j[e] as usize);
        let nrm = b.normal[e];
        let len = b.length[e];
        let gap = len - p.radii[i] - p.radii[j];
        let (ri, rj) = (p.radii[i] + 0.5 * gap, p.radii[j] + 0.5 * gap);
        let nn = nrm * nrm.transpose();
        let s = Mat3::identity() * k.ks[e] + nn * (k.kn[e] - k.ks[e]);
        // Δ = −u_i + u_j + (r_i n)×ω_i + (r_j n)×ω_j + ε·l; θ = ω_j − ω_i.
        let mut bm = DMatrix::<f64>::zeros(3, 12);
        bm.view_mut((0, 0), (3, 3)).copy_from(&(-Mat3::identity()));
        bm.view_mut((0, 3), (3, 3)).copy_from(&skew(&(nrm * ri)));
        bm.view_mut((0, 6), (3, 3)).copy_from(&Mat3::identity());
        bm.view_mut((0, 9), (3, 3)).copy_from(&skew(&(nrm * rj)));
        let mut tm = DMatrix::<f64>::zeros(3, 12);
        tm.view_mut((0, 3), (3, 3)).copy_from(&(-Mat3::identity()));
        tm.view_mut((0, 9), (3, 3)).copy_from(&Mat3::identity());
        let rot = (Mat3::identity() - nn) * k.kr[e] + nn * k.ktw[e];
        let sd = DMatrix::from_column_slice(3, 3, s.as_slice());
        let rd = DMatrix::from_column_slice(3, 3, rot.as_slice());
        let ke = bm.transpose() * &sd * &bm + tm.transpose() * &rd * &tm;
        let lm = strain_map(&(nrm * len));
        let ld = DMatrix::from_column_slice(3, 6, lm.as_slice());
        let ge = bm.transpose() * &sd * &ld;
        let dofs: Vec<usize> = (0..6)
            .map(|a| 6 * i + a)
            .chain((0..6).map(|a| 6 * j + a))
            .collect();
        for (x, &dx) in dofs.iter().enumerate() {
            for (y, &dy) in dofs.iter().enumerate() {
                kk[(dx, dy)] += ke[(x, y)];
            }
            for c in 0..6 {
                gg[(dx, c)] += ge[(x, c)];
            }
        }
        hh += lm.transpose() * s * lm;
    }
    // The term: K = −∂f/∂x, G = −∂f/∂e, H = V ∂σ/∂e.
    let h = 0.05 * p.mean_radius();
    let forces =
        |x: &[Vec3], cell: &Mat3| mb.evaluate(&mb.branch_vectors(x, cell).unwrap()).unwrap();
    for q in 0..n {
        for a in 0..3 {
            let mut plus = p.positions.clone();
            let mut minus = p.positions.clone();
            plus[q][a] += h;
            minus[q][a] -= h;
            let (fp, fm) = (
                forces(&plus, &Mat3::identity()),
                forces(&minus, &Mat3::identity()),
            );
            for r in 0..n {
                for c in 0..3 {
                    kk[(6 * r + c, 6 * q + a)] -= (fp.forces[r][c] - fm.forces[r][c]) / (2.0 * h);
                }
            }
        }
    }
    let he = 1e-3;
    let v = p.volume();
    for c in 0..6 {
        let e = unit_strain(c, he);
        // A uniform strain of the branch vectors: l_b = (I + ε) L_b.
        let strained = |sign: f64| {
            let l: Vec<Vec3> = mb
                .reference_branches()
                .iter()
                .map(|l| (Mat3::identity() + e * sign) * l)
                .collect();
            mb.evaluate(&l).unwrap()
        };
        let (ep, em) = (strained(1.0), strained(-1.0));
        for r in 0..n {
            for a in 0..3 {
                gg[(6 * r + a, c)] -= (ep.forces[r][a] - em.forces[r][a]) / (2.0 * he);
            }
        }
        let ds = (ep.stress - em.stress) / (2.0 * he);
        let ds = (ds + ds.transpose()) * 0.5;
        let col = [
            ds[(0, 0)],
            ds[(1, 1)],
            ds[(2, 2)],
            ds[(1, 2)],
            ds[(0, 2)],
            ds[(0, 1)],
        ];
        for (a, x) in col.iter().enumerate() {
            hh[(a, c)] += v * x;
        }
    }
    (kk, gg, hh)
}

/// C = (H − Gᵀ K⁻¹ G)/V by a dense Cholesky over the DOFs of the bonded particles, the
/// translation of the first one pinned (the three rigid translations; forces balance, so
/// the load is orthogonal to them).
fn dense_relaxed(
    kk: &DMatrix<f64>,
    gg: &DMatrix<f64>,
    hh: &Stiffness6,
    b: &BondSet,
    n: usize,
    v: f64,
) -> Stiffness6 {
    let deg = b.degrees(n);
    let first = (0..n).find(|&q| deg[q] > 0).unwrap();
    let dofs: Vec<usize> = (0..n)
        .filter(|&q| deg[q] > 0)
        .flat_map(|q| (0..6).map(move |a| (q, a)))
        .filter(|&(q, a)| !(q == first && a < 3))
        .map(|(q, a)| 6 * q + a)
        .collect();
    let m = dofs.len();
    let kr = DMatrix::from_fn(m, m, |x, y| kk[(dofs[x], dofs[y])]);
    let gr = DMatrix::from_fn(m, 6, |x, c| gg[(dofs[x], c)]);
    let kr = (&kr + kr.transpose()) * 0.5;
    let chol = kr
        .cholesky()
        .expect("the dense K (translation pinned) is positive definite");
    let q = chol.solve(&gr);
    let gq = gr.transpose() * q;
    let c = Stiffness6::from_fn(|a, c| (hh[(a, c)] - gq[(a, c)]) / v);
    (c + c.transpose()) * 0.5
}

/// A gap-bonded generated packing (a few hundred particles) with every tenth particle left
/// with its first two bonds and every tenth from 5 on with one (degenerate: the term
/// excludes them, but they still enter their neighbours' fits, so the dangling ones carry
/// load), and direction-dependent springs with moments.
fn disordered(n: usize) -> (Packing, BondSet, BondStiffness) {
    let p = super::common::bonded::generated(n, 11);
    let all = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
    let mut kept = vec![0u32; p.len()];
    let mut b = BondSet::default();
    for e in 0..all.len() {
        let ends = [all.i[e] as usize, all.j[e] as usize];
        // Every tenth particle keeps two bonds, every tenth from 5 on one (dangling).
        let cap = |q: usize| match q % 10 {
            0 => 2,
            5 => 1,
            _ => u32::MAX,
        };
        if ends.iter().any(|&q| kept[q] >= cap(q)) {
            continue;
        }
        for q in ends {
            kept[q] += 1;
        }
        b.push(all.i[e], all.j[e], all.branch(e), all.image[e]);
    }
    let k = super::common::bonded::directional_springs(&p, &b, true);
    (p, b, k)
}

/// (b) A disordered periodic packing: the relaxed tensor of springs + term (CG and
/// Cholesky) against the dense solve of the independently built total Hessian; the Voigt
/// level = the springs' Voigt sum + (Σ V_p/V)·D; relaxed ≤ Voigt level and (D positive)
/// ≥ the springs' relaxed tensor, in the Loewner order.
#[test]
fn disordered_packing_with_the_term_matches_a_dense_solve_of_the_total_hessian() {
    let (p, b, k) = disordered(250);
    let c_pair = voigt_tensor(&b, &k, p.volume());
    let scale = max_abs(&c_pair);
    for d in [
        cubic_d(0.5 * scale),
        LocalTensor::Isotropic {
            bulk: 0.6 * scale,
            shear: 0.0,
        },
    ] {
        let mb = term(&p, &b, &d, StrainMeasure::Small);
        assert!(
            !mb.excluded().is_empty(),
            "the packing has rattlers to exclude"
        );
        let frac = mb.volume_fraction();
        assert!(frac > 0.7 && frac < 1.0, "{frac}");
        let (kk, gg, hh) = dense_hessian(&p, &b, &k, &mb);
        let dense = dense_relaxed(&kk, &gg, &hh, &b, p.len(), p.volume());
        let voigt_level = c_pair + mb.tensor().unwrap() * frac;
        let err_h = max_abs(&(hh / p.volume() - voigt_level)) / max_abs(&voigt_level);
        assert!(err_h < 1e-9, "dense H vs Voigt level: {err_h:e}");
        // The default CG, and the two-level CG with aggregates of 8 (about 30 of them): the
        // term's K·P for the coarse space, from its factored form, crosses many aggregates.
        let small_aggregates = RelaxedSolver::Cg {
            preconditioner: CgPreconditioner::TwoLevel {
                particles_per_aggregate: 8,
            },
        };
        for solver in [
            RelaxedSolver::Cholesky,
            RelaxedSolver::default(),
            small_aggregates,
        ] {
            let opts = RelaxedOptions {
                solver,
                tolerance: 1e-11,
                ..Default::default()
            };
            let res = relaxed_tensor_with_term(&p, &b, &k, Some(&mb), &opts).unwrap();
            if solver == small_aggregates {
                // The coarse space took part (a coarse matrix that cannot be factored would
                // fall back to block-Jacobi, with its iteration count).
                let jacobi = RelaxedOptions {
                    solver: RelaxedSolver::Cg {
                        preconditioner: CgPreconditioner::BlockJacobi,
                    },
                    ..opts
                };
                let bj = relaxed_tensor_with_term(&p, &b, &k, Some(&mb), &jacobi).unwrap();
                println!(
                    "CG iterations: two-level (8 per aggregate) {}, block-Jacobi {}",
                    res.iterations, bj.iterations
                );
                assert!(
                    res.iterations < bj.iterations,
                    "two-level {} vs block-Jacobi {}",
                    res.iterations,
                    bj.iterations
                );
            }
            let err = max_abs(&(res.c - dense)) / max_abs(&dense);
            let err_aff = max_abs(&(res.c_affine - voigt_level)) / max_abs(&voigt_level);
            println!(
                "{solver:?}: relaxed vs dense {err:.1e}, affine vs Voigt + (ΣV_p/V)·D {err_aff:.1e}, \
                 {} active of {} particles",
                res.active_particles,
                p.len()
            );
            assert!(err < 1e-8, "{solver:?}: relaxed vs dense {err:e}");
            assert!(err_aff < 1e-12, "{solver:?}: affine {err_aff:e}");
            // The energy's order: relaxing lowers it, a positive D raises it.
            let below = min_eig(&(voigt_level - res.c));
            assert!(
                below > -1e-10 * scale,
                "relaxed above the Voigt level: {below:e}"
            );
            assert!(
                max_abs(&(voigt_level - res.c)) > 1e-3 * scale,
                "no relaxation"
            );
            let pair = relaxed_tensor(&p, &b, &k, &opts).unwrap().c;
            let above = min_eig(&(res.c - pair));
            assert!(
                above > -1e-10 * scale,
                "the term lowered the tensor: {above:e}"
            );
            let gain = res.c - pair;
            assert!(
                max_abs(&gain) > 0.1 * max_abs(&(mb.tensor().unwrap() * frac)),
                "the term hardly changed the relaxed tensor"
            );
        }
    }
}

/// (d) The relaxed solve with the term gives the same bits on one and two threads.
#[test]
fn relaxed_with_the_term_same_bits_on_one_and_two_threads() {
    let (p, b, k) = disordered(400);
    let mb = term(&p, &b, &cubic_d(1e9), StrainMeasure::GreenLagrange);
    for solver in [RelaxedSolver::Cholesky, RelaxedSolver::default()] {
        let opts = RelaxedOptions {
            solver,
            ..Default::default()
        };
        let run = |t: usize| {
            on_threads(t, || {
                relaxed_tensor_with_term(&p, &b, &k, Some(&mb), &opts)
                    .unwrap()
                    .c
            })
        };
        let (one, two) = (run(1), run(2));
        assert!(
            one.iter()
                .zip(two.iter())
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{solver:?}: {one} vs {two}"
        );
    }
}

/// The demo model with an isotropic `[manybody]` of bulk 30 GPa, shear 8 GPa.
fn model_with_term() -> String {
    format!(
        "{CUBIC_MODEL}\n[manybody]\nkind = \"isotropic\"\nbulk = 30e9\nshear = 8e9\nmeasure = \
         \"small\"\n"
    )
}

/// (c) `anisobond tensor --method relaxed|voigt` on a model file with `[manybody]` gives the
/// library's numbers (the relaxed tensor of springs + term; the Voigt sum + (Σ V_p/V)·D) and
/// reports the term's volume fraction; a method that cannot carry the term (LAF) is refused
/// by name, with exit code 1 and no output file.
#[test]
fn cli_tensor_of_a_model_with_the_term_matches_the_library() {
    let d = tmp();
    let pk = packing(d.path(), 300);
    let model = write(d.path(), "model.toml", &model_with_term());
    let asm = Assembly::from_files(&pk, &model).unwrap();
    let mb = asm.manybody().unwrap().expect("the model has a term");
    let frac = mb.volume_fraction();
    let lib_relaxed = relaxed_tensor_with_term(
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        Some(&mb),
        &RelaxedOptions::default(),
    )
    .unwrap()
    .c;
    let lib_voigt = voigt_tensor(&asm.bonds, &asm.springs, asm.packing.volume())
        + isotropic_from_bulk_shear(30e9, 8e9) * frac;
    for (method, want) in [("relaxed", lib_relaxed), ("voigt", lib_voigt)] {
        let json = d.path().join(format!("{method}.json"));
        let out = bin()
            .arg("tensor")
            .arg(&pk)
            .arg("--model")
            .arg(&model)
            .args(["--method", method, "--json", "-o"])
            .arg(&json)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let c: Vec<Vec<f64>> = serde_json::from_value(v["C"].clone()).unwrap();
        let got = Stiffness6::from_fn(|i, j| c[i][j]);
        let err = max_abs(&(got - want)) / max_abs(&want);
        assert!(err < 1e-12, "{method}: CLI vs library {err:e}");
        assert_eq!(
            v["manybody_volume_fraction"].as_f64(),
            Some(frac),
            "{method}"
        );
        // The library's own tensor call carries the term too.
        let m = if method == "relaxed" {
            Method::relaxed()
        } else {
            Method::Voigt
        };
        let r = asm.tensor(&m).unwrap().report;
        let lib = Stiffness6::from_fn(|i, j| r.c[i][j]);
        assert!(max_abs(&(lib - want)) <= 1e-12 * max_abs(&want), "{method}");
    }
    // Without the term the relaxed tensor differs: the term is really in it.
    let plain = write(d.path(), "plain.toml", CUBIC_MODEL);
    let a0 = Assembly::from_files(&pk, &plain).unwrap();
    let c0 = a0.tensor(&Method::relaxed()).unwrap().report.c;
    assert!((lib_relaxed[(0, 1)] - c0[0][1]).abs() > 1e-2 * lib_relaxed[(0, 1)].abs());
    // LAF cannot carry the term: refused by name, exit code 1, nothing written.
    let json = d.path().join("laf.json");
    let out = bin()
        .arg("tensor")
        .arg(&pk)
        .arg("--model")
        .arg(&model)
        .args(["--method", "laf", "--json", "-o"])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("laf") && err.contains("relaxed"), "{err}");
    assert!(!json.exists());
    match asm.tensor(&Method::Laf {
        shell: 1,
        energy: false,
        lever_arm: LeverArm::default(),
    }) {
        Err(Error::Invalid(_)) => {}
        other => panic!("expected Error::Invalid, got {other:?}"),
    }
}

/// (e) A term stiff in volume and soft in shear, as the calibrated metals' D (copper's
/// docs/manybody.md row: (C11 + 2C12)/(C11 − C12) ≈ 44), on a 1,500-particle gap-bonded
/// packing with rattlers excluded: the default two-level CG (rigid and uniform-strain coarse
/// modes, term_preconditioner.rs) gives the tensor of the sparse Cholesky of the assembled
/// total Hessian to 1e-8, with the same bits on one and two threads; and its coarse space
/// needs less than half the iterations of block-Jacobi CG.
#[test]
fn a_metal_like_term_converges_to_the_direct_solve_with_the_default_preconditioner() {
    let p = super::common::bonded::generated(1500, 5);
    let b = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
    let k = super::common::bonded::directional_springs(&p, &b, true);
    let s = max_abs(&voigt_tensor(&b, &k, p.volume()));
    let d = LocalTensor::Cubic {
        c11: 2.0 * s,
        c12: 1.87 * s,
        c44: 0.7 * s,
        rotation: rotation_z(0.3) * rotation_y(-0.7) * rotation_x(1.1),
    };
    let mb = term(&p, &b, &d, StrainMeasure::GreenLagrange);
    let solve = |solver: RelaxedSolver| {
        let opts = RelaxedOptions {
            solver,
            tolerance: 1e-10,
            ..Default::default()
        };
        relaxed_tensor_with_term(&p, &b, &k, Some(&mb), &opts).unwrap()
    };
    let direct = solve(RelaxedSolver::Cholesky).c;
    let cg = on_threads(1, || solve(RelaxedSolver::default()));
    let cg2 = on_threads(2, || solve(RelaxedSolver::default()));
    let jacobi = solve(RelaxedSolver::Cg {
        preconditioner: CgPreconditioner::BlockJacobi,
    });
    let err = max_abs(&(cg.c - direct)) / max_abs(&direct);
    println!(
        "metal-like term: CG iterations two-level {}, block-Jacobi {}; vs Cholesky {err:.1e}",
        cg.iterations, jacobi.iterations
    );
    assert!(err < 1e-8, "two-level CG vs Cholesky: {err:e}");
    assert!(
        cg.c.iter()
            .zip(cg2.c.iter())
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "1 vs 2 threads: {} vs {}",
        cg.c,
        cg2.c
    );
    assert_eq!(cg.iterations, cg2.iterations);
    assert!(
        2 * cg.iterations < jacobi.iterations,
        "two-level {} vs block-Jacobi {}",
        cg.iterations,
        jacobi.iterations
    );
}
