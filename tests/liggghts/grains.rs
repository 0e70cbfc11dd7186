//! A polycrystal's many-body term in the driver's `pair_style anisobond` (issue 34 with issue
//! 33's term; docs/polycrystal.md "Engines", docs/manybody.md "LIGGGHTS"): `manybody.txt`
//! carries a D per grain (`tensors G`, each particle's tensor) and reads back to the same
//! bits; the driver's forces and energy at a perturbed, strained state are the library's
//! per-grain `ManyBody::evaluate`, two processes equal one within 1e-10, and `validate
//! liggghts` meets the relaxed tensor with the per-grain term. Skipped with a reason only
//! when LIGGGHTS/MPI/make are absent and CI is unset.

use super::manybody::{
    driver_at_strained_state, export_with_term, first_dump, force_error, last_dump, max_diff,
    run_np1_np2, strained_state, validate_engine, TOOLS,
};
use crate::common::liggghts::*;
use crate::common::manybody_term;
use crate::common::reference::{cubic4, rotate4};
use anisobond::assembly::Assembly;
use anisobond::export::liggghts::{manybody_table, read_manybody_table, write_manybody_table};
use anisobond::model::Model;

/// The cubic D (C11, C12, C44 in Pa; Zener 2C44/(C11 − C12) = 3) in the crystal frame.
const D: (f64, f64, f64) = (5e9, 3e9, 3e9);

/// Isotropic springs, four grains of a random texture and the cubic [`D`] that turns with
/// each grain, so the grains differ only by their D.
fn model_toml(grains: bool) -> String {
    format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n\
         [scheme]\nkind = \"isotropic\"\nnormal = 1.0e12\nshear = 4.0e11\n\
         [geometry]\nconvention = \"area\"\nmoments = \"parallel-bond\"\n{}\
         [manybody]\nkind = \"cubic\"\nc11 = {:e}\nc12 = {:e}\nc44 = {:e}\n",
        if grains {
            "[grains]\ncount = 4\nseed = 3\n"
        } else {
            ""
        },
        D.0,
        D.1,
        D.2
    )
}

/// The polycrystal of `n` seeded spheres (the packing of `bonded`, springs and grains by
/// the assembly).
fn polycrystal(n: usize, seed: u64) -> Assembly {
    let b = bonded(n, seed, &model_toml(false));
    let model = Model::from_toml_str(&model_toml(true), "<test model>").unwrap();
    let asm = Assembly::new(b.packing, model).unwrap();
    assert_eq!(asm.grains().unwrap().len(), 4);
    asm
}

/// The table of the per-grain term: `tensors 4`, every particle's tensor its grain, D the
/// term's, which is rotate(D, gᵀ) of the tests' explicit rotation (1e-12 of max |D|);
/// written and read back to the same bits; a tensor index beyond the tensors is refused
/// naming the line.
#[test]
fn the_table_carries_a_d_per_grain_and_reads_back() {
    let asm = polycrystal(150, 5);
    let term = asm.manybody().unwrap().unwrap();
    let t = manybody_table(&asm.packing, &asm.bonds, &term).unwrap();
    let grains = asm.grains().unwrap();
    assert_eq!(t.tensors, term.tensors().to_vec());
    assert_eq!(
        t.tensors,
        asm.model
            .manybody
            .as_ref()
            .unwrap()
            .grain_tensors(grains)
            .unwrap()
    );
    assert_eq!(t.tensor, grains.grain);
    // Each grain's D is the textbook one turned by gᵀ (crystal → lab), independently.
    let scale = D.0.abs().max(D.1.abs()).max(D.2.abs());
    for (g, d) in t.tensors.iter().enumerate() {
        let want = rotate4(cubic4(D.0, D.1, D.2), &grains.orientation[g].transpose());
        let dev = (d - want).amax();
        assert!(
            dev <= 1e-12 * scale,
            "grain {g}: {dev:e} Pa off rotate(D, gᵀ)"
        );
    }
    let dir = fresh_dir("grains_table");
    let path = dir.join("manybody.txt");
    write_manybody_table(&path, &t).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\ntensors 4\n"), "{text}");
    assert_eq!(read_manybody_table(&path).unwrap(), t);
    // A particle naming tensor 4 of 0–3.
    let particles = text.find("\nparticles ").unwrap();
    let line_end = text[particles + 1..].find('\n').unwrap() + particles + 1;
    let next_end = text[line_end + 1..].find('\n').unwrap() + line_end + 1;
    let first = &text[line_end + 1..next_end];
    let mut w: Vec<&str> = first.split_whitespace().collect();
    w[2] = "4";
    let broken = text.replacen(first, &w.join(" "), 1);
    std::fs::write(&path, broken).unwrap();
    let err = read_manybody_table(&path).unwrap_err();
    assert!(matches!(err, anisobond::Error::Parse { .. }), "{err}");
    assert!(err.to_string().contains("tensor `4`"), "{err}");
}

/// The driver's forces and energy at a perturbed, strained state (springs at rest there)
/// equal the library's per-grain `ManyBody::evaluate` (1e-10); they differ clearly from the
/// single crystal's term; a 400-step run on two processes ends where one does (1e-10).
#[test]
fn driver_forces_with_a_d_per_grain_match_the_library_and_np2_equals_np1() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let asm = polycrystal(200, 7);
    let term = asm.manybody().unwrap().unwrap();
    let dir = fresh_dir("grains_forces");
    let s = export_with_term(&dir, &asm.packing, &asm.bonds, &asm.springs, &term);
    let (got, e, x, h) = driver_at_strained_state(&dir, &s, &asm.packing);
    let want = term
        .evaluate(&term.branch_vectors(&x, &h).unwrap())
        .unwrap();
    let single = manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let one_d = single
        .evaluate(&single.branch_vectors(&x, &h).unwrap())
        .unwrap();
    let (err, scale) = force_error(&got, &want.forces);
    let vs_single = want
        .forces
        .iter()
        .zip(&one_d.forces)
        .map(|(a, b)| (a - b).amax())
        .fold(0.0, f64::max);
    let e_err = (e - want.energy).abs() / want.energy.abs();
    eprintln!(
        "per-grain term: max |Δf| / max |f| = {:.3e} (max {scale:.3e} N); energy {e:.9e} J vs \
         {:.9e} J ({e_err:.2e}); one D for all differs by {:.2e}",
        err / scale,
        want.energy,
        vs_single / scale
    );
    assert!(scale > 0.0 && err <= 1e-10 * scale, "{:e}", err / scale);
    assert!(e_err <= 1e-10, "{e_err:e}");
    assert!(
        vs_single > 1e-2 * scale,
        "the grains change nothing: {vs_single:e}"
    );

    // Two processes against one: 400 undamped steps from a perturbed state.
    let _ = strained_state(&dir, &asm.packing, [1.01, 1.0, 0.995], 0.01);
    let body = |name: &str| {
        format!(
            "fix integrate all nve/sphere\n\
             dump d all custom 400 {name}.dump id x y z fx fy fz\n\
             dump_modify d sort id format \"%d %.17g %.17g %.17g %.17g %.17g %.17g\"\nrun 400\n"
        )
    };
    run_np1_np2(&dir, &s, body);
    let first = first_dump(&dir.join("np1.dump"), asm.packing.len());
    let (one, two) = (
        last_dump(&dir.join("np1.dump")),
        last_dump(&dir.join("np2.dump")),
    );
    let motion = max_diff(&one, &first, 0..3);
    let fscale = max_diff(&one, &vec![vec![0.0; 6]; one.len()], 3..6);
    let (dx, df) = (
        max_diff(&one, &two, 0..3) / motion,
        max_diff(&one, &two, 3..6) / fscale,
    );
    eprintln!("np 2 vs np 1 after 400 steps: x {dx:.2e} of the motion {motion:.3e} m, f {df:.2e}");
    assert!(motion > 0.0 && fscale > 0.0);
    assert!(
        dx <= 1e-10 && df <= 1e-10,
        "np 2 differs: x {dx:e}, f {df:e}"
    );
}

/// `validate liggghts` of the polycrystal with the term: every check passes within the usual
/// tolerances (history 1e-6, tensors 5e-3, -np 2 vs -np 1 1e-6); the report's reference is
/// the relaxed tensor with the per-grain term recomputed here, which is away from the one
/// with a single D for all grains by more than the tensor tolerance.
#[test]
fn validate_liggghts_on_a_polycrystal_with_the_term_passes() {
    use anisobond::homogenize::{relaxed_tensor_with_term, RelaxedOptions};
    use anisobond::tensor::relative_difference;
    use anisobond::validate::liggghts::checks_table;
    use anisobond::validate::{validate, Problem};
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let asm = polycrystal(200, 7);
    let dir = fresh_dir("grains_validate");
    let problem = Problem::of(&dir, &asm);
    let engine = validate_engine();
    let r = validate(&engine, &problem, &|s| eprintln!("{s}")).expect("validation runs");
    eprintln!("{}", checks_table(&r));
    let ids: Vec<&str> = r.checks.iter().map(|c| c.id.as_str()).collect();
    for want in [
        "history",
        "mpi-history",
        "tensor-driver-relaxed",
        "tensor-integrator-relaxed",
        "mpi-columns",
    ] {
        assert!(ids.contains(&want), "check {want} missing: {ids:?}");
    }
    assert!(r.failures().is_empty(), "{}", checks_table(&r));
    let text =
        std::fs::read_to_string(dir.join("undamped_driver_np1").join("manybody.txt")).unwrap();
    assert!(
        text.contains("\ntensors 4\n"),
        "the driver decks lack the per-grain D"
    );
    let term = asm.manybody().unwrap().unwrap();
    let single = manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let relaxed = |t| {
        relaxed_tensor_with_term(
            &asm.packing,
            &asm.bonds,
            &asm.springs,
            Some(t),
            &RelaxedOptions::default(),
        )
        .unwrap()
        .c
    };
    let poly = relaxed(&term);
    let same = relative_difference(&r.relaxed_tensor, &poly);
    let away = relative_difference(&relaxed(&single), &poly);
    eprintln!(
        "report's relaxed vs recomputed {same:.2e}; one D for all grains vs per grain {away:.3e}"
    );
    assert!(same < 1e-9, "{same}");
    assert!(
        away > 2.0 * 5e-3,
        "the grains' D should change the tensor: {away}"
    );
}
