//! Truszkowska 2018 Table 3 (Sec. 6.3, Fig. 12a): eight parameter sets i–viii of the
//! zener-below-1 model that her DEM puts on one contour, C12/C11 = 0.20 and C44/C11 = 0.35,
//! with her strain heterogeneity and her deviation from the App. A analytic model.
//!
//! Table 3's a_k is k_s/k_n (its values 0.22–0.34; Table 1's k_n/k_s ≥ 1; Sec. 6.1: shear
//! "always softer" than normal), although Sec. 3 writes a_k = k_n/k_s. Her Table 3 header
//! reads Δ = (C/C11)_DEM − (C/C11)_Model, but her numbers are Model − DEM: with the DEM at
//! 0.20 / 0.35, 0.20 + Δ12 and 0.35 + Δ44 are the App. A integral (checked below against the
//! library's mean field and a brute-force integral written here).
//!
//! The always-run tests check that column and the relaxed tensor of a small standard assembly
//! against the paper's contour; `table_3_full` (ignored) prints the whole table:
//! `cargo test --release --test study -- --ignored --nocapture table3::table_3_full`
//! (STUDY_N particles, default 30,700 as the paper; TABLE3_SPHERES measurement spheres,
//! default 2000, 0 skips the gripped runs). BENCHMARKS.md's table comes from `python3 benches/regenerate.py --only
//! table3` (the same numbers through the command line); docs/truszkowska-table3.md explains it.

use anisobond::bonds::assign_stiffness;
use anisobond::bonds::build_bonds;
use anisobond::dem::LawKind;
use anisobond::dem::MeasureOptions;
use anisobond::dem::{gripped_tensor, GrippedOptions};
use anisobond::homogenize::{mean_field, DEFAULT_ORDER};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::tensor::{CubicProjection, Stiffness6};
use std::time::Instant;

/// One row of Truszkowska 2018 Table 3.
struct Set {
    name: &'static str,
    a_n: f64,
    a_s: f64,
    /// k_s/k_n of the magnitudes.
    a_k: f64,
    /// Normalised measurement-sphere noise, normal and shear strain (%).
    eps1: f64,
    eps4: f64,
    /// The printed deviation columns Δ12, Δ44.
    d12: f64,
    d44: f64,
}

/// A [`Set`] from a printed row: set, a_n, a_s, a_k, ε1, ε4, Δ12, Δ44.
macro_rules! set {
    ($name:expr, $a_n:expr, $a_s:expr, $a_k:expr, $eps1:expr, $eps4:expr, $d12:expr, $d44:expr) => {
        Set {
            name: $name,
            a_n: $a_n,
            a_s: $a_s,
            a_k: $a_k,
            eps1: $eps1,
            eps4: $eps4,
            d12: $d12,
            d44: $d44,
        }
    };
}

/// Truszkowska 2018 Table 3 as printed.
const TABLE_3: [Set; 8] = [
    set!("i", 1.30, 0.03, 0.33, 5.8, 5.0, -0.028, 0.017),
    set!("ii", 1.82, 0.12, 0.22, 5.7, 4.8, -0.013, 0.003),
    set!("iii", 2.83, 0.88, 0.24, 6.1, 4.3, -0.008, -0.015),
    set!("iv", 1.78, 3.61, 0.22, 5.4, 4.3, -0.014, 0.006),
    set!("v", 0.50, 0.03, 0.34, 5.8, 5.1, -0.025, 0.014),
    set!("vi", 0.34, 0.12, 0.23, 5.5, 5.0, -0.012, 0.006),
    set!("vii", 0.21, 0.88, 0.27, 5.8, 4.5, -0.007, -0.002),
    set!("viii", 0.38, 3.61, 0.22, 5.4, 4.5, -0.005, 0.009),
];

/// The contour of Fig. 12a all eight sets lie on (the paper's DEM).
const PAPER_DEM: (f64, f64) = (0.20, 0.35);

/// The set's model: zener-below-1 (normal stiffness from three spheroids along <100>, shear
/// from four along <111>; Eqs. 9–15), k_n = 1e13 Pa/m (Table 1), k_s = a_k·k_n, gap 0.17 R̄,
/// with `moments` ("parallel-bond": PFC's k_r = k_n R_b²/4, k_tw = k_s R_b²/2).
fn model(s: &Set, moments: &str) -> Model {
    let text = format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\n\
         model = \"zener-below-1\"\na_n = {}\na_s = {}\nnormal = 1.0e13\nshear = {:e}\n\
         [geometry]\nmoments = \"{moments}\"\n",
        s.a_n,
        s.a_s,
        s.a_k * 1.0e13
    );
    Model::from_toml_str(&text, "Truszkowska Table 3 set").unwrap()
}

/// (C12/C11, C44/C11, Zener) of a tensor's cubic projection.
fn ratios(c: &Stiffness6) -> (f64, f64, f64) {
    let p = CubicProjection::from_stiffness(c);
    (p.c12 / p.c11, p.c44 / p.c11, p.zener)
}

/// The library's mean field (App. A) of a set: ratios only, so the prefactor is 1.
fn library_mean_field(s: &Set) -> (f64, f64, f64) {
    let scheme = model(s, "none").build_scheme(None).unwrap();
    ratios(&mean_field(scheme.as_ref(), 1.0, DEFAULT_ORDER))
}

/// Eq. 9–15 written out: a^(2/3)/sqrt(c² + (1 − c²)a²), c = n·d, enveloped (max) over `axes`.
fn envelope(n: [f64; 3], axes: &[[f64; 3]], a: f64) -> f64 {
    axes.iter()
        .map(|d| {
            let c = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            a.powf(2.0 / 3.0) / (c * c + (1.0 - c * c) * a * a).sqrt()
        })
        .fold(f64::MIN, f64::max)
}

/// App. A Eqs. 43–44 by brute force, independent of the library: the midpoint rule in cos θ
/// and φ of ⟨(k_n − k_s) n1⁴ + k_s n1²⟩ (C11), ⟨(k_n − k_s) n1²n2²⟩ (C12) and
/// ⟨(k_n − k_s) n2²n3² + k_s (n2² + n3²)/4⟩ (C44), on `m` × 2`m` points.
fn brute_force_mean_field(s: &Set, m: usize) -> (f64, f64) {
    let t = 1.0 / 3.0_f64.sqrt();
    let axes100 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let axes111 = [[t, t, t], [-t, t, t], [t, -t, t], [t, t, -t]];
    let (mut c11, mut c12, mut c44) = (0.0, 0.0, 0.0);
    for i in 0..m {
        let z = -1.0 + (i as f64 + 0.5) * 2.0 / m as f64;
        let st = (1.0 - z * z).sqrt();
        for j in 0..2 * m {
            let phi = (j as f64 + 0.5) * std::f64::consts::PI / m as f64;
            let n = [st * phi.cos(), st * phi.sin(), z];
            let kn = envelope(n, &axes100, s.a_n);
            let ks = s.a_k * envelope(n, &axes111, s.a_s);
            let (x2, y2, z2) = (n[0] * n[0], n[1] * n[1], n[2] * n[2]);
            c11 += (kn - ks) * x2 * x2 + ks * x2;
            c12 += (kn - ks) * x2 * y2;
            c44 += (kn - ks) * y2 * z2 + ks * (y2 + z2) / 4.0;
        }
    }
    (c12 / c11, c44 / c11)
}

/// Table 3's last two columns are the App. A model minus the DEM: the library's mean field
/// equals 0.20 + Δ12 within 0.004 and 0.35 + Δ44 within 0.002 in all eight sets (the
/// library's integral itself checked against a brute-force one to 5e-4), while the header's
/// reading, 0.20 − Δ12, misses the integral's C12/C11 by more than 0.01 in every set.
#[test]
fn table_3_analytic_column_is_the_mean_field_with_the_sign_reversed() {
    for s in &TABLE_3 {
        let (m12, m44, zener) = library_mean_field(s);
        let (b12, b44) = brute_force_mean_field(s, 600);
        assert!(
            (m12 - b12).abs() < 5e-4 && (m44 - b44).abs() < 5e-4,
            "set {}: library {m12:.5} / {m44:.5}, brute force {b12:.5} / {b44:.5}",
            s.name
        );
        assert!(zener < 1.0, "set {}: Zener {zener}", s.name);
        let (p12, p44) = (PAPER_DEM.0 + s.d12, PAPER_DEM.1 + s.d44);
        assert!(
            (m12 - p12).abs() <= 0.004 && (m44 - p44).abs() <= 0.002,
            "set {}: mean field {m12:.4} / {m44:.4}, paper's model (0.20 + Δ12, 0.35 + Δ44) {p12:.3} / {p44:.3}",
            s.name
        );
        let headed = PAPER_DEM.0 - s.d12;
        assert!(
            (m12 - headed).abs() > 0.01,
            "set {}: mean field C12/C11 {m12:.4} near the header's reading {headed:.3}",
            s.name
        );
    }
}

/// The standard assembly of Truszkowska 2018 Sec. 4.1 (void fraction 0.40, ΔR = R̄/6).
fn standard(n: usize, seed: u64) -> Packing {
    crate::papers::standard_packing(n, seed)
}

/// Relaxed tensor (C12/C11, C44/C11, Zener) of a set on a packing, with `moments`.
fn relaxed_ratios(p: &Packing, s: &Set, moments: &str) -> (f64, f64, f64, f64) {
    let m = model(s, moments);
    let bonds = build_bonds(p, m.bonding).unwrap();
    let scheme = m.build_scheme(Some((p, &bonds))).unwrap();
    let k = assign_stiffness(p, &bonds, scheme.as_ref(), &m.geometry).unwrap();
    let r = relaxed_tensor(p, &bonds, &k, &RelaxedOptions::default()).unwrap();
    let (a, b, z) = ratios(&r.c);
    (a, b, z, bonds.coordination(p.len()))
}

/// On a 2,000-sphere standard assembly, the relaxed tensor with the paper's parallel-bond
/// moments lands near the paper's contour for all eight sets: C12/C11 in [0.20, 0.25]
/// (0.20 is the paper's; anisobond's lies 0.01–0.03 above it at 8,000 spheres) and C44/C11
/// within 0.02 of 0.35, Zener < 1. As in the paper's DEM, C12/C11 lies above the App. A model
/// (mean field) in every set.
#[test]
fn table_3_relaxed_sets_lie_near_the_papers_contour() {
    let p = standard(2000, 1);
    for s in &TABLE_3 {
        let (r12, r44, zener, z) = relaxed_ratios(&p, s, "parallel-bond");
        let (m12, _, _) = library_mean_field(s);
        assert!(
            (PAPER_DEM.0..=0.25).contains(&r12) && (r44 - PAPER_DEM.1).abs() <= 0.02 && zener < 1.0,
            "set {} (Z = {z:.2}): relaxed {r12:.4} / {r44:.4}, Zener {zener:.4}; paper 0.20 / 0.35",
            s.name
        );
        assert!(
            r12 > m12,
            "set {}: relaxed C12/C11 {r12:.4} not above the mean field {m12:.4}",
            s.name
        );
    }
}

fn env_usize(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Truszkowska 2018 Table 3 in full: per set, the relaxed tensor with parallel-bond moments
/// (and without), the mean field, the paper's model column read both ways, and the strain
/// heterogeneity of gripped element tests (law parallel-bond, spheres of 6 R̄, the command
/// line's defaults) beside the paper's.
#[test]
#[ignore]
fn table_3_full() {
    let _alone = crate::common::alone();
    let n = env_usize("STUDY_N", 30_700);
    let spheres = env_usize("TABLE3_SPHERES", 2000);
    let p = standard(n, 1);
    println!(
        "standard assembly: {n} particles (seed 1); paper's DEM for every set: C12/C11 = 0.20, \
         C44/C11 = 0.35 (Fig. 12a contour)"
    );
    println!(
        "| set | a_n | a_s | a_k = k_s/k_n | relaxed, parallel-bond moments: C12/C11 / C44/C11 / Zener \
         | relaxed, no moments | mean field C12/C11 / C44/C11 | paper's model, 0.20 + Δ12 / 0.35 + Δ44 \
         | as headed, 0.20 − Δ12 / 0.35 − Δ44 | relaxed − mean field | paper DEM − model, −Δ12 / −Δ44 \
         | heterogeneity normal / shear \
         (anisobond) | paper ε1 / ε4 | anisobond / paper |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for s in &TABLE_3 {
        let t = Instant::now();
        let (r12, r44, rz, _) = relaxed_ratios(&p, s, "parallel-bond");
        let (n12, n44, nz, _) = relaxed_ratios(&p, s, "none");
        let (m12, m44, _) = library_mean_field(s);
        let het = if spheres > 0 {
            let m = model(s, "parallel-bond");
            let bonds = build_bonds(&p, m.bonding).unwrap();
            let scheme = m.build_scheme(Some((&p, &bonds))).unwrap();
            let k = assign_stiffness(&p, &bonds, scheme.as_ref(), &m.geometry).unwrap();
            let opts = GrippedOptions {
                max_steps: 20_000,
                measure: MeasureOptions {
                    count: spheres,
                    radius: 6.0,
                    seed: 2018,
                },
                ..Default::default()
            };
            let g = gripped_tensor(&p, &bonds, &k, LawKind::ParallelBond, &opts, &|_| {}).unwrap();
            let (hn, hs) = (
                100.0 * g.heterogeneity.normal,
                100.0 * g.heterogeneity.shear,
            );
            (
                format!("{hn:.2} / {hs:.2} %"),
                format!("{:.2} / {:.2}", hn / s.eps1, hs / s.eps4),
            )
        } else {
            ("—".into(), "—".into())
        };
        println!(
            "| {} | {:.2} | {:.2} | {:.2} | {r12:.4} / {r44:.4} / {rz:.3} | {n12:.4} / {n44:.4} / {nz:.3} \
             | {m12:.4} / {m44:.4} | {:.3} / {:.3} | {:.3} / {:.3} | {:+.4} / {:+.4} | {:+.3} / {:+.3} | {} | {:.1} / {:.1} % | {} |",
            s.name,
            s.a_n,
            s.a_s,
            s.a_k,
            PAPER_DEM.0 + s.d12,
            PAPER_DEM.1 + s.d44,
            PAPER_DEM.0 - s.d12,
            PAPER_DEM.1 - s.d44,
            r12 - m12,
            r44 - m44,
            -s.d12,
            -s.d44,
            het.0,
            s.eps1,
            s.eps4,
            het.1
        );
        eprintln!("set {}: {:.1} s", s.name, t.elapsed().as_secs_f64());
    }
}
