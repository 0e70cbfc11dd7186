//! Study (ignored; run with `cargo test --release --test study -- --ignored
//! --nocapture grips::`): Truszkowska 2018 Table 3's measurement-sphere strain noise for a gripped
//! block with the MRV model (zener-above-1, a_n = 4.31, a_s = 10, k_n = 1e13, k_s = 3.55e12,
//! gap 0.17 R̄, parallel bonds), with the gripped tensor beside the periodic relaxed one.
//! Size from GRIPS_N (default 20,000), spheres from GRIPS_SPHERES (default 2,000); relaxation
//! tolerance GRIPS_TOL (1e-6), damping GRIPS_DAMPING (0.6), grip shell GRIPS_SHELL (0.5 R̄).

use anisobond::bonds::{assign_stiffness, build_bonds};
use anisobond::dem::LawKind;
use anisobond::dem::MeasureOptions;
use anisobond::dem::{gripped_tensor, GrippedOptions};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};
use anisobond::model::Model;
use anisobond::schemes::Moments;
use anisobond::tensor::{relative_difference, CubicProjection};

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
#[ignore]
fn table_3_heterogeneity_of_the_mrv_model() {
    let _alone = crate::common::alone();
    let n = env("GRIPS_N", 20_000);
    let count = env("GRIPS_SPHERES", 2_000);
    let t0 = std::time::Instant::now();
    let p = crate::common::bonded::generated(n, 2018);
    // PFC parallel bonds carry bending and twisting springs (k_r = k_n R_b²/4,
    // k_tw = k_s R_b²/2): give them to the relaxed reference too, as the law derives them.
    let mut model = Model::truszkowska_mrv();
    model.geometry.moments = Moments::ParallelBond;
    let b = build_bonds(&p, model.bonding).unwrap();
    let scheme = model.build_scheme(Some((&p, &b))).unwrap();
    let k = assign_stiffness(&p, &b, scheme.as_ref(), &model.geometry).unwrap();
    let t_gen = t0.elapsed().as_secs_f64();
    let relaxed = relaxed_tensor(&p, &b, &k, &RelaxedOptions::default()).unwrap();
    let t_rel = t0.elapsed().as_secs_f64() - t_gen;
    let env_f = |name: &str, default: f64| {
        std::env::var(name)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    let opts = GrippedOptions {
        tolerance: env_f("GRIPS_TOL", 1e-6),
        local_damping: env_f("GRIPS_DAMPING", 0.6),
        grip_shell: env_f("GRIPS_SHELL", 0.5),
        measure: MeasureOptions {
            count,
            radius: 6.0,
            seed: 1,
        },
        ..Default::default()
    };
    let t1 = std::time::Instant::now();
    let g = gripped_tensor(&p, &b, &k, LawKind::ParallelBond, &opts, &|_| {}).unwrap();
    let t_grip = t1.elapsed().as_secs_f64();
    let cg = CubicProjection::from_stiffness(&g.c);
    let cr = CubicProjection::from_stiffness(&relaxed.c);
    println!(
        "N = {n}, Z = {:.2}, {} block bonds, {} grips, {count} spheres of 6 R̄ ({:.0} members each), {} threads",
        b.coordination(p.len()),
        g.bonds,
        g.grips,
        g.mean_members,
        rayon::current_num_threads()
    );
    println!(
        "heterogeneity (Table 3 metric): normal {:.2} %, shear {:.2} % (paper Table 3: 5.4–6.1 %, 4.3–5.1 %)",
        100.0 * g.heterogeneity.normal,
        100.0 * g.heterogeneity.shear
    );
    for path in &g.paths {
        println!(
            "  path {}: spread {:.2} %, mean sphere strain / imposed {:.4}, {} steps",
            path.path + 1,
            100.0 * path.spread,
            path.strain[path.path] / path.imposed_strain[path.path],
            path.steps
        );
    }
    println!(
        "gripped C11 {:.4e} C12 {:.4e} C44 {:.4e}; periodic relaxed C11 {:.4e} C12 {:.4e} C44 {:.4e}; \
         relative difference {:.3e} (affine vs relaxed {:.3e})",
        cg.c11,
        cg.c12,
        cg.c44,
        cr.c11,
        cr.c12,
        cr.c44,
        relative_difference(&g.c, &relaxed.c),
        relative_difference(&relaxed.c_affine, &relaxed.c)
    );
    println!(
        "time: packing + bonds {t_gen:.1} s, relaxed {t_rel:.1} s, gripped six paths {t_grip:.1} s"
    );
    assert!(g.heterogeneity.normal > 0.0 && g.heterogeneity.shear > 0.0);
}
