//! The bar of the engines' strength validations (`validate ENGINE --strength`, issue 32):
//! an n × n × n simple-cubic block of touching spheres of R = 1 mm, free (no cell), gap
//! bonded (3n²(n − 1) bonds), isotropic springs (k_n = 2e6 N/m, k_s = 7e5 N/m), Weibull
//! tensile strengths (mean 5 MPa, modulus 5, seeded) so that bonds break one by one.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::validate::strength::{StrengthDetails, StrengthRun, StrengthTest};
use anisobond::validate::{validate_strength, Problem, Report};
use anisobond::Vec3;

/// Sphere radius (m).
pub const R: f64 = 1e-3;

/// The model: springs and the `[strength]` table.
pub const MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n\
    [strength]\n[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
    [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 7\n";

/// The bonded n × n × n bar.
pub fn cubic_bar(n: usize) -> Assembly {
    let mut pos = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let count = pos.len();
    let packing = Packing::new(pos, vec![R; count], None).unwrap();
    let model = Model::from_toml_str(MODEL, "<strength test>").unwrap();
    let asm = Assembly::new(packing, model).unwrap();
    assert_eq!(asm.bonds.len(), 3 * n * n * (n - 1));
    asm
}

/// The model of the compression (UCS) prism: the bar's springs; tensile strength 5 MPa,
/// cohesion 2 MPa, friction 0.5, the same Weibull scatter — shear-weak, so that bonds
/// inclined to the axis break in shear under compression.
pub const UCS_MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n\
    [strength]\n[strength.bond]\ntensile = 5e6\ncohesion = 2e6\nfriction = 0.5\n\
    [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 7\n";

/// The compression (UCS) specimen of the engines' strength validations: a simple-cubic
/// lattice of touching 1 mm spheres turned by 30° about x, then 20° about y, cut to the prism
/// 16R × 16R × 32R (centres inside; spheres with fewer than two lattice neighbours left are
/// dropped, repeatedly): 1,027 spheres, 2,635 bonds ([`UCS_MODEL`]). In pure axial
/// compression an upright simple-cubic bar breaks no bond (its bonds are only compressed);
/// the turned lattice's bonds are sheared and break.
pub fn ucs_prism() -> Assembly {
    use std::collections::BTreeMap;
    let (a, b) = (30f64.to_radians(), 20f64.to_radians());
    let (w, h) = (16.0 * R, 32.0 * R);
    let turn = |v: [f64; 3]| {
        let (x, y, z) = (v[0], v[1], v[2]);
        let (y, z) = (y * a.cos() - z * a.sin(), y * a.sin() + z * a.cos());
        let (x, z) = (x * b.cos() + z * b.sin(), -x * b.sin() + z * b.cos());
        Vec3::new(x, y, z)
    };
    let n = ((w + h) / (2.0 * R)) as i64 + 3;
    let mut pts: BTreeMap<[i64; 3], Vec3> = BTreeMap::new();
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let p = turn([i as f64, j as f64, k as f64].map(|c| 2.0 * R * c));
                let inside = |c: f64, hi: f64| (0.0..=hi).contains(&c);
                if inside(p.x, w) && inside(p.y, w) && inside(p.z, h) {
                    pts.insert([i, j, k], p);
                }
            }
        }
    }
    loop {
        let drop: Vec<[i64; 3]> = pts
            .keys()
            .filter(|q| {
                let mut near = 0;
                for s in 0..3 {
                    for d in [-1, 1] {
                        let mut o = **q;
                        o[s] += d;
                        near += pts.contains_key(&o) as usize;
                    }
                }
                near < 2
            })
            .copied()
            .collect();
        if drop.is_empty() {
            break;
        }
        for q in drop {
            pts.remove(&q);
        }
    }
    let mut pos: Vec<Vec3> = pts.into_values().collect();
    pos.sort_by(|p, q| {
        p.z.total_cmp(&q.z)
            .then(p.y.total_cmp(&q.y))
            .then(p.x.total_cmp(&q.x))
    });
    let count = pos.len();
    let packing = Packing::new(pos, vec![R; count], None).unwrap();
    let model = Model::from_toml_str(UCS_MODEL, "<UCS test>").unwrap();
    Assembly::new(packing, model).unwrap()
}

/// `validate_strength` of `asm` by `engine` in `dir`, its progress and summary printed
/// under `test`.
pub fn run_strength<E: anisobond::validate::Engine>(
    test: &str,
    engine: &E,
    dir: &std::path::Path,
    asm: &Assembly,
    t: &StrengthTest,
) -> Report<StrengthDetails> {
    let r = validate_strength(engine, &Problem::of(dir, asm), t, &|m: &str| {
        eprintln!("{test}: {m}")
    })
    .expect("the strength test ran");
    eprintln!("{}", anisobond::validate::checks_summary(&r));
    r
}

/// A UCS run that failed: at least ten bonds broke before its first peak's end, the first
/// peak is compressive and lies well before the run's end (the load fell by the peak drop).
pub fn check_ucs_run(run: &StrengthRun, t: &StrengthTest) {
    assert!(
        run.breaks.len() >= 10,
        "{}: only {} bonds broke",
        run.program,
        run.breaks.len()
    );
    assert!(
        run.peak_force > 0.0,
        "{}: peak {}",
        run.program,
        run.peak_force
    );
    assert!(
        run.peak_step < t.steps * 9 / 10,
        "{}: the first peak at step {} of {}: the prism did not fail",
        run.program,
        run.peak_step,
        t.steps
    );
}
