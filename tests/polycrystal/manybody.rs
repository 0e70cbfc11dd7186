//! A polycrystal with the many-body term (issue 34 item 2, docs/polycrystal.md "Copper
//! polycrystal (many-body term)"): each particle loads its grain's D, rotate(D, gᵀ).
//! One identity grain is the single crystal and one grain g the crystal with `rotation = g`,
//! bit for bit (relaxed tensor, term, integrator); with several grains the forces are the
//! energy's central differences and the Hessian the forces' (the relaxed solve's CG, which
//! applies the term in factored form, agrees with the Cholesky solve of that Hessian); a
//! uniform strain adds exactly the volume-weighted average of the grains' D, each turned here
//! by an explicit fourth-order rotation; 1 and 2 threads give the same bits; YADE, which
//! carries one D, refuses the polycrystal's term. The local fields with the term: the
//! affine field's grain stresses are the Voigt-level closed form, the relaxed particle
//! stresses add up to C·ε (Hill's lemma), and `anisobond polycrystal`'s study takes the term.

use super::common::bonded::generated;
use super::common::reference::{cubic4, rotate4};
use super::common::{bin, on_threads, packing, stderr, tmp, write};
use super::{bits, cubic_model, model, relaxed, rotation_key};
use anisobond::dem::{path_gradient, DemOptions, LawKind};
use anisobond::grains::bunge_deg;
use anisobond::homogenize::{
    bond_lattice_tensor, LocalFields, LocalOptions, RelaxedOptions, RelaxedSolver,
};
use anisobond::manybody::ManyBody;
use anisobond::prelude::*;

/// A copper-like cubic D (C12 > C44, beyond the Cauchy line), of the springs' order.
const D: (f64, f64, f64) = (1.2e10, 1.0e10, 0.5e10);

/// The `[manybody]` table of [`D`] (no rotation: it turns with the scheme's crystal), with
/// `extra` lines.
fn manybody_table(extra: &str) -> String {
    format!(
        "[manybody]\nkind = \"cubic\"\nc11 = {:e}\nc12 = {:e}\nc44 = {:e}\n{extra}",
        D.0, D.1, D.2
    )
}

/// One grain of Bunge angles `angles` (a file in `dir`).
fn one_grain(dir: &std::path::Path, angles: &str) -> String {
    std::fs::write(dir.join("euler.txt"), format!("{angles}\n")).unwrap();
    format!(
        "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"{}\"\n",
        dir.join("euler.txt").display()
    )
}

/// The textbook cubic [`D`] turned by Q (D'_ijkl = Q_ia Q_jb Q_kc Q_ld D_abcd, the tests'
/// explicit rotation `common::reference::rotate4`): independent of the library's rotation.
fn rotated_cubic(q: &Mat3) -> Stiffness6 {
    rotate4(cubic4(D.0, D.1, D.2), q)
}

/// The term of an assembly's model, built on its grains.
fn term_of(a: &Assembly) -> ManyBody {
    a.manybody().unwrap().expect("the model's [manybody]")
}

/// A short damped sheared run of the integrator with the term: the bits of every position and
/// of the term's energy after each step.
fn integrator_bits(a: &Assembly) -> Vec<u64> {
    let opts = DemOptions {
        local_damping: 0.3,
        ..Default::default()
    };
    let mut sim = a.simulation(LawKind::Yade, &opts).unwrap();
    sim.set_velocity_gradient(path_gradient(3, 1e-4) / sim.time_step())
        .unwrap();
    let mut out = Vec::new();
    for s in 0..40 {
        sim.step().unwrap();
        if s == 0 {
            sim.set_velocity_gradient(Mat3::zeros()).unwrap();
        }
        out.push(sim.energies().manybody.to_bits());
        out.extend(sim.stress().iter().map(|x| x.to_bits()));
    }
    assert!(sim.energies().manybody > 0.0, "the term stored no energy");
    for x in &sim.particles.position {
        out.extend([x.x, x.y, x.z].map(f64::to_bits));
    }
    out
}

/// Branch vectors of a perturbed, sheared state of `term` on `p` (deterministic).
fn perturbed(p: &Packing) -> (Vec<Vec3>, Mat3) {
    let r = p.mean_radius();
    let x: Vec<Vec3> = p
        .positions
        .iter()
        .enumerate()
        .map(|(k, x)| {
            let s = k as f64;
            x + Vec3::new((1.3 * s).sin(), (0.7 * s + 1.0).cos(), (2.1 * s).sin()) * (0.01 * r)
        })
        .collect();
    let h = Mat3::new(
        1.004, 0.003, -0.002, 0.001, 0.997, 0.002, -0.003, 0.001, 1.002,
    );
    (x, h)
}

#[test]
fn one_identity_grain_with_the_term_is_the_single_crystal_bit_for_bit() {
    let dir = tmp();
    let grains = one_grain(dir.path(), "0 0 0");
    let p = generated(500, 3);
    let poly = Assembly::new(
        p.clone(),
        model(&cubic_model("", &format!("{grains}{}", manybody_table("")))),
    )
    .unwrap();
    let single = Assembly::new(p, model(&cubic_model("", &manybody_table("")))).unwrap();
    assert_eq!(poly.grains().unwrap().len(), 1);
    let (tp, ts) = (term_of(&poly), term_of(&single));
    assert_eq!(tp.tensors().len(), 1);
    assert_eq!(bits(tp.tensor().unwrap()), bits(ts.tensor().unwrap()));
    assert_eq!(bits(&relaxed(&poly)), bits(&relaxed(&single)));
    assert_eq!(integrator_bits(&poly), integrator_bits(&single));
}

#[test]
fn one_rotated_grain_with_the_term_is_the_crystal_with_that_rotation_bit_for_bit() {
    let dir = tmp();
    let grains = one_grain(dir.path(), "30, 40, 50");
    let g = bunge_deg(30.0, 40.0, 50.0);
    let p = generated(500, 4);
    let poly = Assembly::new(
        p.clone(),
        model(&cubic_model("", &format!("{grains}{}", manybody_table("")))),
    )
    .unwrap();
    // The crystal's D follows its scheme's `rotation = g` (the table gives none).
    let single = Assembly::new(
        p,
        model(&cubic_model(&rotation_key(&g), &manybody_table(""))),
    )
    .unwrap();
    assert_eq!(poly.grains().unwrap().orientation[0], g);
    let (tp, ts) = (term_of(&poly), term_of(&single));
    assert_eq!(bits(tp.tensor().unwrap()), bits(ts.tensor().unwrap()));
    // And that D is the textbook one turned by gᵀ (crystal → lab), independently.
    let expect = rotated_cubic(&g.transpose());
    let err = (tp.tensor().unwrap() - expect).amax() / expect.amax();
    assert!(err < 1e-14, "grain D vs explicit rotation: {err:e}");
    assert_eq!(bits(&relaxed(&poly)), bits(&relaxed(&single)));
    assert_eq!(integrator_bits(&poly), integrator_bits(&single));
}

/// Several grains: forces = −∂U/∂x by central differences, Hessian = −∂f/∂x by central
/// differences (both Green–Lagrange, at a perturbed sheared state), and the relaxed tensor of
/// the CG (factored term, per-owner D) = that of the sparse Cholesky (the assembled Hessian
/// and load).
#[test]
fn forces_and_hessian_are_derivatives_of_the_energy_with_several_grains() {
    let p = generated(160, 7);
    let a = Assembly::new(
        p.clone(),
        model(&cubic_model(
            "",
            &format!("[grains]\ncount = 5\nseed = 2\n{}", manybody_table("")),
        )),
    )
    .unwrap();
    let term = term_of(&a);
    assert_eq!(term.tensors().len(), 5);
    let grains = a.grains().unwrap();
    for q in 0..p.len() {
        assert_eq!(term.tensor_index(q), grains.grain[q] as usize);
    }
    let (x0, hcell) = perturbed(&p);
    let energy = |x: &[Vec3]| {
        term.energy(&term.branch_vectors(x, &hcell).unwrap())
            .unwrap()
    };
    let forces = |x: &[Vec3]| {
        term.evaluate(&term.branch_vectors(x, &hcell).unwrap())
            .unwrap()
            .forces
    };
    let f0 = forces(&x0);
    let fmax = f0.iter().fold(0.0_f64, |m, f| m.max(f.amax()));
    let h = 1e-6 * p.mean_radius();
    let mut err_f = 0.0_f64;
    let n = p.len();
    let mut dense = vec![vec![Mat3::zeros(); n]; n]; // −∂f_r/∂x_c by differences
    for c in 0..n {
        for d in 0..3 {
            let mut xp = x0.clone();
            let mut xm = x0.clone();
            xp[c][d] += h;
            xm[c][d] -= h;
            let fd = -(energy(&xp) - energy(&xm)) / (2.0 * h);
            err_f = err_f.max((fd - f0[c][d]).abs());
            let (fp, fm) = (forces(&xp), forces(&xm));
            for r in 0..n {
                let col = -(fp[r] - fm[r]) / (2.0 * h);
                for e in 0..3 {
                    dense[r][c][(e, d)] = col[e];
                }
            }
        }
    }
    let k = term
        .hessian(&term.branch_vectors(&x0, &hcell).unwrap())
        .unwrap();
    let mut assembled = vec![vec![Mat3::zeros(); n]; n];
    for (r, row) in assembled.iter_mut().enumerate() {
        for (c, blk) in k.row(r) {
            row[c] = blk.fixed_view::<3, 3>(0, 0).into_owned();
        }
    }
    let kmax = assembled
        .iter()
        .flatten()
        .fold(0.0_f64, |m, b| m.max(b.amax()));
    let err_k = (0..n)
        .flat_map(|r| (0..n).map(move |c| (r, c)))
        .fold(0.0_f64, |m, (r, c)| {
            m.max((assembled[r][c] - dense[r][c]).amax())
        });
    println!(
        "5 grains: forces vs differences {:.1e}, Hessian vs differences {:.1e} (relative)",
        err_f / fmax,
        err_k / kmax
    );
    assert!(err_f < 1e-6 * fmax, "forces: {:e}", err_f / fmax);
    assert!(err_k < 1e-6 * kmax, "Hessian: {:e}", err_k / kmax);

    let solve = |solver| {
        let c = a
            .tensor(&Method::Relaxed(RelaxedOptions {
                solver,
                tolerance: 1e-10,
                ..Default::default()
            }))
            .unwrap()
            .report
            .c;
        Stiffness6::from_fn(|i, j| c[i][j])
    };
    let cg = solve(RelaxedSolver::default());
    let chol = solve(RelaxedSolver::Cholesky);
    let err = (cg - chol).amax() / chol.amax();
    println!("5 grains: relaxed CG vs Cholesky {err:.1e}");
    assert!(err < 1e-9, "relaxed CG vs Cholesky: {err:e}");
    // The term moved the tensor: without it the springs alone are softer.
    let springs_only = relaxed(
        &Assembly::new(
            p,
            model(&cubic_model("", "[grains]\ncount = 5\nseed = 2\n")),
        )
        .unwrap(),
    );
    assert!(chol[(0, 1)] > springs_only[(0, 1)] + 0.1 * D.1);
}

/// A uniform small strain ε (l_b = (I + ε)L_b): the stress is (1/V)·Σ_p V_p D_g(p):ε and the
/// energy ½ Σ_p V_p ε:D_g(p):ε, each grain's D turned here by an explicit fourth-order
/// rotation; the closed form and the Voigt-level tensor carry the same average.
#[test]
fn uniform_strain_adds_the_volume_weighted_average_of_the_grains_d() {
    let p = generated(400, 9);
    let a = Assembly::new(
        p.clone(),
        model(&cubic_model(
            "",
            &format!(
                "[grains]\ncount = 6\nseed = 4\n{}",
                manybody_table("measure = \"small\"\n")
            ),
        )),
    )
    .unwrap();
    let term = term_of(&a);
    let grains = a.grains().unwrap();
    assert_eq!(term.tensors().len(), 6);
    let vp = term.particle_volumes();
    let v = p.volume();
    let mut average = Stiffness6::zeros();
    let turned: Vec<Stiffness6> = grains
        .orientation
        .iter()
        .map(|g| rotated_cubic(&g.transpose()))
        .collect();
    for (q, &w) in vp.iter().enumerate() {
        average += turned[grains.grain[q] as usize] * (w / v);
    }
    let cf = term.closed_form_tensor();
    let err_cf = (cf - average).amax() / average.amax();
    assert!(err_cf < 1e-13, "closed form vs average: {err_cf:e}");
    let eps = Mat3::new(
        0.010, 0.003, -0.002, 0.003, -0.006, 0.004, -0.002, 0.004, 0.008,
    );
    let branch: Vec<Vec3> = term
        .reference_branches()
        .iter()
        .map(|l| l + eps * l)
        .collect();
    let ev = anisobond::tensor::Voigt6::new(
        eps[(0, 0)],
        eps[(1, 1)],
        eps[(2, 2)],
        2.0 * eps[(1, 2)],
        2.0 * eps[(0, 2)],
        2.0 * eps[(0, 1)],
    );
    let s = average * ev;
    let expect = Mat3::new(s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2]);
    let got = term.evaluate(&branch).unwrap();
    let err_s = (got.stress - expect).amax() / expect.amax();
    let energy: f64 = vp
        .iter()
        .enumerate()
        .map(|(q, &w)| 0.5 * w * ev.dot(&(turned[grains.grain[q] as usize] * ev)))
        .sum();
    let err_e = (got.energy - energy).abs() / energy;
    println!("6 grains, uniform strain: stress {err_s:.1e}, energy {err_e:.1e}, closed form {err_cf:.1e}");
    assert!(err_s < 1e-11, "stress: {err_s:e}");
    assert!(err_e < 1e-11, "energy: {err_e:e}");
    // The Voigt-level tensor of the assembly: the springs' bond sum + the average.
    let with = a.tensor(&Method::Voigt).unwrap().report.c;
    let without = Assembly::new(
        p,
        model(&cubic_model("", "[grains]\ncount = 6\nseed = 4\n")),
    )
    .unwrap()
    .tensor(&Method::Voigt)
    .unwrap()
    .report
    .c;
    let added = Stiffness6::from_fn(|i, j| with[i][j] - without[i][j]);
    let err_v = (added - average).amax() / average.amax();
    assert!(err_v < 1e-12, "Voigt level: {err_v:e}");
}

#[test]
fn one_and_two_threads_give_the_same_bits_with_grains_and_the_term() {
    let p = generated(400, 11);
    let a = Assembly::new(
        p,
        model(&cubic_model(
            "",
            &format!("[grains]\ncount = 7\nseed = 5\n{}", manybody_table("")),
        )),
    )
    .unwrap();
    let run = |threads| on_threads(threads, || (bits(&relaxed(&a)), integrator_bits(&a)));
    assert!(run(1) == run(2), "1 and 2 threads differ");
}

/// YADE carries one D: `export yade` (library) refuses a polycrystal with the term
/// (Error::Model), writing nothing. LAMMPS and LIGGGHTS carry a D per grain (tests/lammps/
/// grains.rs, tests/liggghts/grains.rs): the CLI's `export lammps` on stock bpm/rotational
/// (route a, which cannot carry the term at all) is refused naming the plugin route (exit
/// code 1, nothing written), and `export liggghts` writes the per-grain table.
#[test]
fn engines_refuse_the_polycrystal_term_writing_nothing() {
    use anisobond::export::yade::{write_assembly_export, YadeRunOptions};
    let text = cubic_model(
        "",
        &format!("[grains]\ncount = 4\nseed = 1\n{}", manybody_table("")),
    );
    let a = Assembly::new(generated(300, 12), model(&text)).unwrap();
    let dir = tmp();
    let out = dir.path().join("yade");
    match write_assembly_export(&out, &a, &YadeRunOptions::default()) {
        Err(Error::Model(m)) => assert!(m.contains("[grains]") && m.contains("export yade"), "{m}"),
        other => panic!(
            "export yade: expected Error::Model, got {:?}",
            other.map(|_| ())
        ),
    }
    assert!(!out.exists());
    // The CLI.
    let packing = packing(dir.path(), 300);
    let m = write(dir.path(), "poly.toml", &text);
    let export = |engine: &str, out: &std::path::Path| {
        bin()
            .args(["export", engine])
            .arg(&packing)
            .arg("--model")
            .arg(&m)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let out = dir.path().join("lammps");
    let run = export("lammps", &out);
    assert_eq!(run.status.code(), Some(1), "{}", stderr(&run));
    let err = stderr(&run);
    assert!(err.contains("--bond-style anisobond"), "{err}");
    assert!(!out.exists(), "export lammps left {}", out.display());
    let out = dir.path().join("liggghts");
    let run = export("liggghts", &out);
    assert!(run.status.success(), "{}", stderr(&run));
    let table = std::fs::read_to_string(out.join("manybody.txt")).unwrap();
    assert!(table.contains("\ntensors 4\n"), "{table}");
}

/// The must-show measurement (docs/polycrystal.md "Copper polycrystal (many-body term)"), run
/// by hand: `ANISOBOND_COPPER_MODEL=copper.toml ANISOBOND_COPPER_PACK=pack.txt
/// [ANISOBOND_GRAIN_COUNTS=8,50,200] [ANISOBOND_GRAIN_SEED=1] cargo test --release --test
/// polycrystal copper_polycrystal -- --ignored --nocapture`. The model is a single crystal
/// (no `[grains]`); each row adds `[grains] count = n`, random texture. Prints the single
/// crystal's relaxed tensor's references (Voigt, Reuss, Hill, HS bounds, self-consistent) and
/// per grain count the relaxed tensor's K, G (Voigt projection), its distance from isotropy,
/// and the sampling noise of that texture: the distance from isotropy of the volume-weighted
/// Voigt average of the grains' actual orientations, and its Reuss average's G − G_Reuss.
/// `ANISOBOND_GRAIN_BOUNDARY=series` sets the boundary rule (default mean).
#[test]
#[ignore = "a measurement: minutes per relaxed solve with the term at 8,000 particles"]
fn copper_polycrystal() {
    use anisobond::study::polycrystal::anisotropy_distance;
    use anisobond::tensor::{orientation_averages, voigt_average, PolycrystalReference};
    let (Some(m), Some(pk)) = (
        std::env::var_os("ANISOBOND_COPPER_MODEL"),
        std::env::var_os("ANISOBOND_COPPER_PACK"),
    ) else {
        eprintln!("SKIPPED: set ANISOBOND_COPPER_MODEL and ANISOBOND_COPPER_PACK");
        return;
    };
    let counts: Vec<usize> = std::env::var("ANISOBOND_GRAIN_COUNTS")
        .unwrap_or_else(|_| "8,50,200".into())
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let seed: u64 = std::env::var("ANISOBOND_GRAIN_SEED")
        .map(|s| s.parse().unwrap())
        .unwrap_or(1);
    let boundary = std::env::var("ANISOBOND_GRAIN_BOUNDARY").unwrap_or_else(|_| "mean".into());
    let base = std::fs::read_to_string(&m).unwrap();
    let packing = read_packing(std::path::Path::new(&pk)).unwrap();
    let gpa = |x: f64| x / 1e9;
    let t0 = std::time::Instant::now();
    let single = Assembly::new(packing.clone(), model(&base)).unwrap();
    let c1 = relaxed(&single);
    let r = PolycrystalReference::of(&c1).unwrap();
    let m1 = voigt_average(&c1);
    println!(
        "single crystal ({} particles, {} bonds), relaxed in {:.0} s: K_V {:.3} G_V {:.3} GPa, distance from isotropy {:.4}",
        packing.len(),
        single.bonds.len(),
        t0.elapsed().as_secs_f64(),
        gpa(m1.bulk),
        gpa(m1.shear),
        anisotropy_distance(&c1)
    );
    println!(
        "  Voigt K {:.3} G {:.3}; Reuss K {:.3} G {:.3}; Hill K {:.3} G {:.3}",
        gpa(r.voigt_bulk_pa),
        gpa(r.voigt_shear_pa),
        gpa(r.reuss_bulk_pa),
        gpa(r.reuss_shear_pa),
        gpa(r.hill_bulk_pa),
        gpa(r.hill_shear_pa)
    );
    println!(
        "  HS lower K {:.3} G {:.3}; HS upper K {:.3} G {:.3}; self-consistent K {:.3} G {:.3}",
        gpa(r.hs_lower_bulk_pa),
        gpa(r.hs_lower_shear_pa),
        gpa(r.hs_upper_bulk_pa),
        gpa(r.hs_upper_shear_pa),
        gpa(r.self_consistent_bulk_pa),
        gpa(r.self_consistent_shear_pa)
    );
    for n in counts {
        let t = std::time::Instant::now();
        let text =
            format!("{base}\n[grains]\ncount = {n}\nseed = {seed}\nboundary = \"{boundary}\"\n");
        let poly = Assembly::new(packing.clone(), model(&text)).unwrap();
        let c = relaxed(&poly);
        let mc = voigt_average(&c);
        let grains = poly.grains().unwrap();
        let turns: Vec<Mat3> = grains.orientation.iter().map(|g| g.transpose()).collect();
        let w: Vec<f64> = grains.sizes().iter().map(|&s| s as f64).collect();
        let sample = orientation_averages(&c1, &turns, Some(&w)).unwrap();
        // K_V and G_V are invariants (every orientation sample has the crystal's); the
        // sample's Reuss average is not: its G − G_R(∞) is the texture sample's noise in G.
        let ms = voigt_average(&sample.reuss);
        let neff = w.iter().sum::<f64>().powi(2) / w.iter().map(|x| x * x).sum::<f64>();
        println!(
            "{n} grains (N_eff {neff:.1}), {:.0} s: K {:.3} G {:.3} GPa, distance {:.4}; \
             sample: Voigt-average distance {:.4}, Reuss G − G_R {:+.3} GPa; \
             K in HS [{:.3}, {:.3}]: {}, G in HS [{:.3}, {:.3}]: {}, G − G_SC {:+.3} GPa",
            t.elapsed().as_secs_f64(),
            gpa(mc.bulk),
            gpa(mc.shear),
            anisotropy_distance(&c),
            anisotropy_distance(&sample.voigt),
            gpa(ms.shear - r.reuss_shear_pa),
            gpa(r.hs_lower_bulk_pa),
            gpa(r.hs_upper_bulk_pa),
            r.hs_lower_bulk_pa <= mc.bulk && mc.bulk <= r.hs_upper_bulk_pa,
            gpa(r.hs_lower_shear_pa),
            gpa(r.hs_upper_shear_pa),
            r.hs_lower_shear_pa <= mc.shear && mc.shear <= r.hs_upper_shear_pa,
            gpa(mc.shear - r.self_consistent_shear_pa)
        );
    }
}

/// The polycrystal with the term under `tables`' grains, small strain (the local fields are
/// linear).
fn small_strain_polycrystal(p: &Packing, grains: &str) -> Assembly {
    Assembly::new(
        p.clone(),
        model(&cubic_model(
            "",
            &format!("{grains}{}", manybody_table("measure = \"small\"\n")),
        )),
    )
    .unwrap()
}

/// A general small engineering strain (Voigt).
fn local_strain() -> Voigt6 {
    Voigt6::new(2.0e-4, -1.0e-4, 0.5e-4, 1.0e-4, -0.6e-4, 0.8e-4)
}

/// Σ_p V_p σ_p / V of local fields.
fn volume_mean(f: &LocalFields) -> Voigt6 {
    let mut s = Voigt6::zeros();
    for (v, sigma) in f.particle_volume.iter().zip(&f.particle_stress) {
        s += sigma * *v;
    }
    s / f.volume
}

/// A uniform strain without fluctuation (the affine field): each grain's mean stress is the
/// Voigt-level closed form over its particles, Σ_p [Σ_{b∋p} r_p(b)·|l_b|·C_lat(n_b) +
/// V_p^D·D_g]·ε / Σ_p V_p, the bond's lattice tensor split by its contact arms (mid-gap) and
/// each grain's D turned here by an explicit fourth-order rotation; every particle's fitted
/// strain is ε.
#[test]
fn uniform_strain_grain_stresses_are_the_voigt_closed_form_with_the_term() {
    let p = generated(400, 9);
    let a = small_strain_polycrystal(&p, "[grains]\ncount = 6\nseed = 4\n");
    let e = local_strain();
    let opts = LocalOptions {
        relaxed: RelaxedOptions {
            fluctuations: false,
            ..Default::default()
        },
        ..Default::default()
    };
    let f = a.local_fields(&e, &opts).unwrap();
    let grains = a.grains().unwrap();
    let term = term_of(&a);
    let vd = term.particle_volumes();
    let turned: Vec<Stiffness6> = grains
        .orientation
        .iter()
        .map(|g| rotated_cubic(&g.transpose()))
        .collect();
    // Particle volumes V r³ / Σ r³ and per-particle tensors, summed here.
    let r3: f64 = p.radii.iter().map(|r| r.powi(3)).sum();
    let v = p.volume();
    let mut tensor = vec![Stiffness6::zeros(); p.len()];
    let (b, k) = (&a.bonds, &a.springs);
    for n in 0..b.len() {
        let (i, j) = (b.i[n] as usize, b.j[n] as usize);
        let l = b.length[n];
        let gap = l - p.radii[i] - p.radii[j];
        let lat = bond_lattice_tensor(&b.normal[n], k.kn[n], k.ks[n]);
        tensor[i] += lat * ((p.radii[i] + 0.5 * gap) * l);
        tensor[j] += lat * ((p.radii[j] + 0.5 * gap) * l);
    }
    let mut worst = 0.0_f64;
    let stats = f.statistics(&grains.grain).unwrap();
    for st in &stats.groups {
        let g = st.label.unwrap();
        let mut sum = Stiffness6::zeros();
        let mut vol = 0.0;
        for q in (0..p.len()).filter(|&q| grains.grain[q] == g) {
            sum += tensor[q] + turned[g as usize] * vd[q];
            vol += v * p.radii[q].powi(3) / r3;
        }
        let expect = sum * e / vol;
        let got = Voigt6::from_column_slice(&st.mean_stress_pa);
        worst = worst.max((got - expect).amax() / expect.amax());
        let strain = Voigt6::from_column_slice(&st.mean_strain.unwrap());
        assert!(
            (strain - e).amax() < 1e-14,
            "grain {g}: mean strain {strain:?}"
        );
    }
    println!("6 grains, affine field: grain mean stress vs closed form {worst:.1e}");
    assert!(worst < 1e-12, "grain stress vs closed form: {worst:e}");
    // The term's share is there: each grain's D is of the springs' order.
    assert!(f.particle_term_stress.iter().any(|s| s.amax() > 0.0));
}

/// Hill's lemma with the term: after the relaxed solve (sparse Cholesky) the particle
/// stresses, each with its share of the term, add up to V·C·ε with C the relaxed tensor of
/// the springs and the term (`Assembly::tensor`, the same solve); the term carries a
/// substantial share of it, and the fluctuation moves the grains' stresses off the affine
/// ones.
#[test]
fn particle_stresses_with_the_term_add_up_to_the_relaxed_stress() {
    let p = generated(400, 10);
    let a = small_strain_polycrystal(&p, "[grains]\ncount = 5\nseed = 3\n");
    let relaxed = RelaxedOptions {
        solver: RelaxedSolver::Cholesky,
        ..Default::default()
    };
    let e = local_strain();
    let f = a
        .local_fields(
            &e,
            &LocalOptions {
                relaxed,
                ..Default::default()
            },
        )
        .unwrap();
    let t = a.tensor(&Method::Relaxed(relaxed)).unwrap().report.c;
    let ce = Stiffness6::from_fn(|i, j| t[i][j]) * e;
    let mean = volume_mean(&f);
    let err_c = (mean - ce).amax() / ce.amax();
    let err_s = (mean - f.stress).amax() / ce.amax();
    let mut term_part = Voigt6::zeros();
    for (v, s) in f.particle_volume.iter().zip(&f.particle_term_stress) {
        term_part += s * *v;
    }
    let share = (term_part / f.volume).amax() / ce.amax();
    println!(
        "5 grains, Cholesky: |Σ V_p σ_p / V − C·ε| / |C·ε| = {err_c:.1e}, vs the macroscopic \
         stress {err_s:.1e}; the term's share {share:.2}"
    );
    assert!(err_c < 1e-10, "Hill's lemma with the term: {err_c:e}");
    assert!(
        err_s < 1e-13,
        "particle stresses vs macroscopic stress: {err_s:e}"
    );
    assert!(share > 0.2, "the term's share {share}");
    let affine = a
        .local_fields(
            &e,
            &LocalOptions {
                relaxed: RelaxedOptions {
                    fluctuations: false,
                    ..relaxed
                },
                ..Default::default()
            },
        )
        .unwrap();
    let moved = (volume_mean(&affine) - mean).amax() / ce.amax();
    assert!(moved > 1e-3, "the fluctuation changed nothing: {moved:e}");
}

/// `anisobond polycrystal`'s study accepts `[manybody]`: its cell mean stress is the relaxed
/// tensor's C·ε (the CG's tolerance), one row per grain, the correlation finite.
#[test]
fn the_polycrystal_study_takes_the_term() {
    use anisobond::study::polycrystal::run;
    let p = generated(400, 13);
    let text = cubic_model(
        "",
        &format!("[grains]\ncount = 5\nseed = 1\n{}", manybody_table("")),
    );
    let opts = PolycrystalOptions::default();
    let r = run(&p, &model(&text), &opts, OptionNames::Flags, &|_| {}).unwrap();
    assert_eq!(r.grains.len(), 5);
    let a = opts.load_axis;
    let expect = r.tensor_pa[a][a] * opts.strain;
    let err = (r.cell_mean_stress_pa - expect).abs() / expect;
    println!(
        "study with the term: cell stress vs C·ε {err:.1e}, r = {:.2}",
        r.stress_stiffness_correlation
    );
    assert!(err < 1e-5, "cell stress vs C·ε: {err:e}");
    assert!(r.stress_stiffness_correlation.is_finite());
}
