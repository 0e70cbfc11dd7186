//! Studies against the papers' numbers (Kumar 2016 Fig. 5/Tables 2–3; Truszkowska 2018
//! Sec. 5.1 Fig. 5, Sec. 5.4 Eqs. 31–34, Sec. 5.5 Table 2). The `#[ignore]`d ones print
//! tables for BENCHMARKS.md: run with
//! `cargo test --release --test study -- --ignored --nocapture papers::<name>`.
//! The one always run asserts Kumar's trend on a small packing.

use anisobond::bonds::build_bonds;
use anisobond::bonds::{assign_stiffness, BondSet, BondStiffness, BondingRule};
use anisobond::homogenize::voigt_tensor;
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions, RelaxedResult};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::packing::{generate, GenerateOptions, Polydispersity, TRUSZKOWSKA_2018_HALF_WIDTH};
use anisobond::packing::{prepare, PreparationRoute, RouteOptions};
use anisobond::tensor::rotate;
use anisobond::tensor::CubicProjection;
use anisobond::tensor::{voigt_average, Stiffness6};
use anisobond::Mat3;
use std::f64::consts::PI;
use std::time::Instant;

/// Kumar 2016 Eq. 12/13 with Table 2 (0 < α ≤ 1) parameters [a1, a2, a3, n, b1, b2, b3].
const KUMAR_TABLE_2: [[f64; 7]; 3] = [
    [0.18, 5.45, 9.64, 5.0, 0.24, 3.38, 6.91],
    [0.42, 7.45, 8.68, 2.0, 0.55, 3.02, 5.75],
    [1.09, 6.72, 5.12, 1.0, 0.80, 3.07, 4.07],
];
/// Kumar 2016 Table 3 (1 ≤ α ≤ 10).
const KUMAR_TABLE_3: [[f64; 7]; 3] = [
    [1.10, 0.86, 0.72, 6.0, 0.54, 6.41, 1.10],
    [1.62, 1.33, 0.72, 3.0, 0.75, 6.00, 1.07],
    [2.06, 2.07, 0.78, 1.5, 0.91, 5.09, 0.99],
];

/// (Ẽ, ν) of Kumar Eqs. 12–13 for parameters p at interaction range κ and ratio α.
fn kumar_fit(p: &[f64; 7], kappa: f64, alpha: f64) -> (f64, f64) {
    let e = kappa.powf(p[3]) / (2.0 * PI) * (p[0] + p[1] * alpha) / (4.0 + p[2] * alpha);
    let nu = (1.0 - p[4] * alpha) / (p[5] + p[6] * alpha);
    (e, nu)
}

/// Mean field, Kumar Eqs. (.2)–(.3): ν = (1 − α)/(4 + α), Ẽ = (2 + 3α)/(2π(4 + α)).
fn kumar_mean_field(alpha: f64) -> (f64, f64) {
    (
        (2.0 + 3.0 * alpha) / (2.0 * PI * (4.0 + alpha)),
        (1.0 - alpha) / (4.0 + alpha),
    )
}

fn kumar_model(kappa: f64, sigma_n: f64, alpha: f64, moments: &str) -> Model {
    let text = format!(
        "[bonding]\nrule = \"factor\"\nvalue = {kappa}\n[scheme]\nkind = \"isotropic\"\n\
         normal = {sigma_n}\nshear = {}\n[geometry]\nconvention = \"kumar\"\nmoments = \"{moments}\"\n",
        alpha * sigma_n
    );
    Model::from_toml_str(&text, "kumar study model").unwrap()
}

struct Bonded {
    bonds: BondSet,
    stiffness: BondStiffness,
}

fn bond(p: &Packing, model: &Model) -> Bonded {
    let bonds = build_bonds(p, model.bonding).unwrap();
    let scheme = model.build_scheme(Some((p, &bonds))).unwrap();
    let stiffness = assign_stiffness(p, &bonds, scheme.as_ref(), &model.geometry).unwrap();
    Bonded { bonds, stiffness }
}

fn relaxed(p: &Packing, b: &Bonded) -> RelaxedResult {
    let opts = RelaxedOptions {
        tolerance: 1e-8,
        ..Default::default()
    };
    relaxed_tensor(p, &b.bonds, &b.stiffness, &opts).unwrap()
}

fn kumar_packing(route: PreparationRoute, n: usize, seed: u64) -> Packing {
    let o = RouteOptions {
        route,
        n_particles: n,
        seed,
        ..RouteOptions::default()
    };
    prepare(&o, &|_| {}).unwrap().0
}

/// Kumar 2016 Fig. 5 / Sec. 4: the relaxed Young's modulus lies below the mean field (and
/// below the Voigt sum of the same bonds, which is rigorous), and Poisson's ratio falls as
/// α = Σ_T/Σ_N grows.
#[test]
fn kumar_fig5_trend_relaxed_below_mean_field_poisson_falls_with_alpha() {
    let p = kumar_packing(PreparationRoute::WeaklyJammed, 800, 4);
    let sigma_n = 1e9;
    let mut last_nu = f64::INFINITY;
    for alpha in [0.1, 0.3, 1.0, 3.0] {
        let model = kumar_model(1.05, sigma_n, alpha, "kumar");
        let b = bond(&p, &model);
        let z = b.bonds.coordination(p.len());
        let r = relaxed(&p, &b);
        let m = voigt_average(&r.c);
        let voigt = voigt_average(&voigt_tensor(&b.bonds, &b.stiffness, p.volume()));
        let norm = z * p.solid_fraction() * sigma_n;
        let (e_mf, _) = kumar_mean_field(alpha);
        assert!(m.young < voigt.young, "α = {alpha}");
        assert!(
            m.young / norm < e_mf,
            "α = {alpha}: Ẽ {} ≥ {e_mf}",
            m.young / norm
        );
        assert!(
            m.poisson < last_nu,
            "α = {alpha}: ν {} not below {last_nu}",
            m.poisson
        );
        last_nu = m.poisson;
    }
    // Kumar: auxetic (ν < 0) for α well above 1.
    assert!(last_nu < 0.0, "ν at α = 3: {last_nu}");
}

/// Kumar 2016 Fig. 5/6: Ẽ = E/(Z_b D Σ_N) and ν of the relaxed tensor for each route, κ
/// and α, beside the paper's fits (Eqs. 12–13, Tables 2–3) and the mean field.
#[test]
#[ignore]
fn kumar_fig5_table() {
    let _alone = crate::common::alone();
    let n: usize = std::env::var("STUDY_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000);
    let sigma_n = 1e9;
    println!("route | κ | Z_b | α | Ẽ relaxed | Ẽ Kumar fit | Ẽ mean field | ν relaxed | ν Kumar fit | ν mean field | Ẽ voigt (bonds)");
    for (r, route) in [
        PreparationRoute::Unjammed,
        PreparationRoute::WeaklyJammed,
        PreparationRoute::Jammed,
    ]
    .iter()
    .enumerate()
    {
        let t = Instant::now();
        let p = kumar_packing(*route, n, 1);
        eprintln!(
            "{} packing: {:.1} s",
            route.as_str(),
            t.elapsed().as_secs_f64()
        );
        for kappa in [1.0, 1.05] {
            for alpha in [0.05, 0.2, 0.5, 1.0, 2.0, 5.0] {
                let model = kumar_model(kappa, sigma_n, alpha, "kumar");
                let b = bond(&p, &model);
                let z = b.bonds.coordination(p.len());
                let t = Instant::now();
                let res = relaxed(&p, &b);
                let m = voigt_average(&res.c);
                let v = voigt_average(&res.c_affine);
                let norm = z * p.solid_fraction() * sigma_n;
                let params = if alpha <= 1.0 {
                    &KUMAR_TABLE_2[r]
                } else {
                    &KUMAR_TABLE_3[r]
                };
                let (e_fit, nu_fit) = kumar_fit(params, kappa, alpha);
                let (e_mf, nu_mf) = kumar_mean_field(alpha);
                println!(
                    "{} | {kappa:.3} | {z:.3} | {alpha} | {:.4} | {e_fit:.4} | {e_mf:.4} | {:.4} | {nu_fit:.4} | {nu_mf:.4} | {:.4}",
                    route.as_str(),
                    m.young / norm,
                    m.poisson,
                    v.young / norm
                );
                eprintln!(
                    "  relaxed {:.2} s, {} CG iterations, removed {} particles",
                    t.elapsed().as_secs_f64(),
                    res.iterations,
                    res.null_space.removed_particles
                );
            }
        }
    }
}

pub(crate) fn standard_packing(n: usize, seed: u64) -> Packing {
    let o = GenerateOptions {
        n_particles: n,
        solid_fraction: 0.6,
        mean_radius: 1e-3,
        polydispersity: Polydispersity::Uniform {
            half_width: TRUSZKOWSKA_2018_HALF_WIDTH,
        },
        seed,
        ..GenerateOptions::default()
    };
    generate(&o, &|_| {}).unwrap()
}

fn mrv_model(moments: &str, rotation: Option<Mat3>) -> Model {
    let mut text = String::from(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\n\
         model = \"zener-above-1\"\na_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\n",
    );
    if let Some(q) = rotation {
        text += &format!(
            "rotation = [[{:.17e}, {:.17e}, {:.17e}], [{:.17e}, {:.17e}, {:.17e}], [{:.17e}, {:.17e}, {:.17e}]]\n",
            q[(0, 0)], q[(0, 1)], q[(0, 2)], q[(1, 0)], q[(1, 1)], q[(1, 2)], q[(2, 0)], q[(2, 1)], q[(2, 2)]
        );
    }
    text += &format!("[geometry]\nmoments = \"{moments}\"\n");
    Model::from_toml_str(&text, "mrv study model").unwrap()
}

fn gpa(c: &Stiffness6) -> String {
    let rows: Vec<String> = (0..6)
        .map(|i| {
            (0..6)
                .map(|j| format!("{:7.2}", c[(i, j)] / 1e9))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect();
    rows.join("\n")
}

/// Truszkowska 2018 Sec. 5.1 Fig. 5a: normalised C11, C12, C44 (relaxed) against particle
/// count; Fig. 5b: coordination against the gap cutoff. Sizes from STUDY_SIZES
/// (comma-separated; default 5000,10000,20000,30700,50000,80000).
#[test]
#[ignore]
fn truszkowska_mrv_size_and_gap() {
    let _alone = crate::common::alone();
    let sizes: Vec<usize> = std::env::var("STUDY_SIZES")
        .unwrap_or_else(|_| "5000,10000,20000,30700,50000,80000".into())
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let model = mrv_model("none", None);
    let mut rows = Vec::new();
    for &n in &sizes {
        let t0 = Instant::now();
        let p = standard_packing(n, 1);
        let t1 = Instant::now();
        let b = bond(&p, &model);
        let res = relaxed(&p, &b);
        let t2 = Instant::now();
        let c = CubicProjection::from_stiffness(&res.c);
        println!(
            "N = {n}: bonds {}, Z = {:.3}, C11 = {:.2}, C12 = {:.2}, C44 = {:.2} GPa \
             (±{:.2}, ±{:.2}, ±{:.2}; zero terms {:.2}), C12/C11 = {:.4}, C44/C11 = {:.4}; \
             pack {:.1} s, bond+relaxed {:.1} s ({} CG it.)",
            b.bonds.len(),
            b.bonds.coordination(n),
            c.c11 / 1e9,
            c.c12 / 1e9,
            c.c44 / 1e9,
            c.uncertainty.c11 / 1e9,
            c.uncertainty.c12 / 1e9,
            c.uncertainty.c44 / 1e9,
            c.uncertainty.zero_terms / 1e9,
            c.c12 / c.c11,
            c.c44 / c.c11,
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            res.iterations
        );
        rows.push((n, c));
        if n == 30_700 {
            let gaps = [1.7e-4, 0.01, 0.03, 0.05, 0.1, 0.17, 0.25, 0.4, 0.6, 0.8];
            let zs: Vec<String> = gaps
                .iter()
                .map(|&g| {
                    let z = build_bonds(&p, BondingRule::Gap(g))
                        .unwrap()
                        .coordination(n);
                    format!("gap {g} R̄: Z = {z:.3}")
                })
                .collect();
            println!("Fig. 5b (N = 30700): {}", zs.join("; "));
        }
    }
    let (_, last) = rows.last().unwrap();
    for (n, c) in &rows {
        println!(
            "normalised by N = {}: N = {n}: C11 {:.4}, C12 {:.4}, C44 {:.4}",
            rows.last().unwrap().0,
            c.c11 / last.c11,
            c.c12 / last.c12,
            c.c44 / last.c44
        );
    }
}

/// Truszkowska 2018 Eq. 31 as printed.
fn eq31() -> Mat3 {
    let r = Mat3::new(
        -0.3062, -0.9186, 0.2500, 0.8839, -0.1768, 0.4330, -0.3536, 0.3536, 0.8660,
    );
    anisobond::schemes::orthonormalize_rotation(r).unwrap()
}

/// Truszkowska 2018 Sec. 5.3–5.5: the standard assembly (30,700 particles, three seeds)
/// with the MRV parameters, without and with parallel-bond moments; and with the stiffness
/// functions rotated by R⁻¹ of Eq. 31 (paper Eqs. 32–34).
#[test]
#[ignore]
fn truszkowska_seeds_and_rotation() {
    let _alone = crate::common::alone();
    let n: usize = std::env::var("STUDY_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30_700);
    let r = eq31();
    let euler = anisobond::schemes::rotation_from_euler_zyz_deg(60.0, 30.0, 45.0);
    println!(
        "Eq. 31 (orthonormalised) vs euler_zyz_deg [60,30,45]: max |Δ| = {:.2e}",
        (r - euler).abs().max()
    );
    for seed in [1u64, 2, 3] {
        let p = standard_packing(n, seed);
        for moments in ["none", "parallel-bond"] {
            let model = mrv_model(moments, None);
            let b = bond(&p, &model);
            let t = Instant::now();
            let res = relaxed(&p, &b);
            let dt = t.elapsed().as_secs_f64();
            let c = CubicProjection::from_stiffness(&res.c);
            let v = CubicProjection::from_stiffness(&res.c_affine);
            println!(
                "seed {seed}, moments {moments}: bonds {}, Z {:.3}: relaxed C11 {:.2}, C12 {:.2}, \
                 C44 {:.2} GPa (±{:.2}/{:.2}/{:.2}, zero terms {:.2}); C12/C11 = {:.3}, \
                 C44/C11 = {:.3} (paper 0.40, 0.376); voigt C12/C11 = {:.3}, C44/C11 = {:.3}; \
                 {dt:.1} s, {} CG it.",
                b.bonds.len(),
                b.bonds.coordination(p.len()),
                c.c11 / 1e9,
                c.c12 / 1e9,
                c.c44 / 1e9,
                c.uncertainty.c11 / 1e9,
                c.uncertainty.c12 / 1e9,
                c.uncertainty.c44 / 1e9,
                c.uncertainty.zero_terms / 1e9,
                c.c12 / c.c11,
                c.c44 / c.c11,
                v.c12 / v.c11,
                v.c44 / v.c11,
                res.iterations
            );
            if seed == 1 {
                // Functions evaluated at Rᵀn: the tensor becomes rotate(C, R) (Eq. 32).
                let rotated = mrv_model(moments, Some(r.transpose()));
                let br = bond(&p, &rotated);
                let cr = relaxed(&p, &br).c;
                let predicted = rotate(&res.c, &r);
                let back = rotate(&cr, &r.transpose());
                let cb = CubicProjection::from_stiffness(&back);
                println!(
                    "  rotated by R⁻¹ (moments {moments}), relaxed (compare Eq. 33):\n{}\n  \
                     rotate(unrotated relaxed, R) (compare Eq. 32):\n{}\n  rotated back and \
                     projected (compare Eq. 34: 75.9, 30.8, 28.8 GPa): C11 {:.2}, C12 {:.2}, C44 \
                     {:.2} GPa (±{:.2}/{:.2}/{:.2}, zero terms {:.2}); C12/C11 = {:.3}, C44/C11 = {:.3}",
                    gpa(&cr),
                    gpa(&predicted),
                    cb.c11 / 1e9,
                    cb.c12 / 1e9,
                    cb.c44 / 1e9,
                    cb.uncertainty.c11 / 1e9,
                    cb.uncertainty.c12 / 1e9,
                    cb.uncertainty.c44 / 1e9,
                    cb.uncertainty.zero_terms / 1e9,
                    cb.c12 / cb.c11,
                    cb.c44 / cb.c11
                );
            }
        }
    }
}
