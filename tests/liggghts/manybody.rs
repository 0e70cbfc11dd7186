//! The many-body term (docs/manybody.md, "LIGGGHTS") in the driver's `pair_style anisobond`:
//! its forces and energy at a perturbed, strained state against the library's
//! `ManyBody::evaluate`, and a short dynamic run on two processes against one. Skipped with a
//! reason only when LIGGGHTS/MPI/make are absent and CI is unset.

use crate::common::liggghts::*;
use anisobond::bonds::BondSet;
use anisobond::export::liggghts::{
    read_manybody_table, run_liggghts, DeckOptions, ExportSummary, LiggghtsInputs,
};
use anisobond::manybody::{ManyBody, StrainMeasure};
use anisobond::model::Model;
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::Vec3;
use std::path::Path;

pub(super) const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];

/// Isotropic springs (the driver test's model) with a rotated cubic D beyond the Cauchy line.
fn model_toml(measure: &str) -> String {
    format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n\
         [scheme]\nkind = \"isotropic\"\nnormal = 1.0e12\nshear = 4.0e11\n\
         [geometry]\nconvention = \"area\"\nmoments = \"parallel-bond\"\n\
         [manybody]\nkind = \"cubic\"\nc11 = 5e9\nc12 = 3e9\nc44 = 1e9\n\
         euler_zyz_deg = [10.0, 20.0, 30.0]\nmeasure = \"{measure}\"\n"
    )
}

/// The bonded packing, its term (the library's, from the model file) and the export into `dir`.
fn setup(dir: &Path, n: usize, measure: &str) -> (Bonded, ManyBody, ExportSummary) {
    let toml = model_toml(measure);
    let b = degenerate_three(bonded(n, 11, &toml));
    let model = Model::from_toml_str(&toml, "<test model>").unwrap();
    let term = crate::common::manybody_term(&model, &b.packing, &b.bonds);
    assert!(
        !term.excluded().is_empty() && term.excluded().len() < n / 4,
        "the term should exclude a few particles: {} of {n}",
        term.excluded().len()
    );
    let s = export_with_term(dir, &b.packing, &b.bonds, &b.k, &term);
    (b, term, s)
}

/// The driver decks of `packing` (normal cases only) with the term, exported into `dir`.
pub(super) fn export_with_term(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &anisobond::bonds::BondStiffness,
    term: &ManyBody,
) -> ExportSummary {
    let opts = DeckOptions {
        shear: false,
        ..DeckOptions::default()
    };
    LiggghtsInputs {
        manybody: Some(term),
        ..LiggghtsInputs::new(packing, bonds, k, &opts)
    }
    .export(dir)
    .expect("export")
}

/// `b` with particles 0, 1 and 2 left two bonds each (their first in bond order), so the
/// term has degenerate particles to exclude as the library does.
fn degenerate_three(b: Bonded) -> Bonded {
    let mut seen = [0usize; 3];
    let keep: Vec<usize> = (0..b.bonds.len())
        .filter(|&k| {
            let mut ok = true;
            for p in [b.bonds.i[k], b.bonds.j[k]] {
                if (p as usize) < 3 {
                    ok &= seen[p as usize] < 2;
                }
            }
            if ok {
                for p in [b.bonds.i[k], b.bonds.j[k]] {
                    if (p as usize) < 3 {
                        seen[p as usize] += 1;
                    }
                }
            }
            ok
        })
        .collect();
    let mut bonds = BondSet::default();
    let mut k = b.k.clone();
    for &m in &keep {
        bonds.push(
            b.bonds.i[m],
            b.bonds.j[m],
            b.bonds.branch(m),
            b.bonds.image[m],
        );
    }
    for v in [&mut k.radius, &mut k.kn, &mut k.ks, &mut k.kr, &mut k.ktw] {
        *v = keep.iter().map(|&m| v[m]).collect();
    }
    Bonded {
        packing: b.packing,
        bonds,
        k,
    }
}

/// A seeded xorshift in [−1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// The state x = S·x_ref + δ (S = diag(`stretch`), |δ_k| ≤ `amplitude`·R̄) in the cell
/// S·L, written as `strained.data` (positions wrapped into the cell); returns the unwrapped
/// positions and S.
pub(super) fn strained_state(
    dir: &Path,
    packing: &Packing,
    stretch: [f64; 3],
    amplitude: f64,
) -> (Vec<Vec3>, anisobond::Mat3) {
    let s = anisobond::Mat3::from_diagonal(&Vec3::new(stretch[0], stretch[1], stretch[2]));
    let cell = packing.cell.unwrap();
    let lengths = s * cell.lengths;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let rbar = packing.radii.iter().sum::<f64>() / packing.len() as f64;
    let x: Vec<Vec3> = packing
        .positions
        .iter()
        .map(|p| s * p + Vec3::new(rng.next(), rng.next(), rng.next()) * (amplitude * rbar))
        .collect();
    let wrapped: Vec<Vec3> = x
        .iter()
        .map(|p| Vec3::from_fn(|k, _| p[k].rem_euclid(lengths[k])))
        .collect();
    let strained = Packing::new(
        wrapped,
        packing.radii.clone(),
        Some(PeriodicCell::new(lengths).unwrap()),
    )
    .unwrap();
    anisobond::packing::write_liggghts_data(&dir.join("strained.data"), &strained, 2500.0).unwrap();
    (x, s)
}

/// A deck on `strained.data`: the pair style with (`manybody`) or without the term, the
/// springs' rest lengths taken there (so they carry no force at the first call), `body`
/// after the setup.
pub(super) fn deck(dir: &Path, name: &str, summary: &ExportSummary, manybody: bool, body: &str) {
    let text = format!(
        "units si\natom_style granular\natom_modify map array\nboundary p p p\nnewton on\n\
         communicate single vel yes\nread_data strained.data\n\
         pair_style anisobond table bonds.csv length_tolerance 0.5{}\npair_coeff * *\n\
         neighbor {} bin\nneigh_modify delay 0\ntimestep {}\n{body}",
        if manybody {
            " manybody manybody.txt"
        } else {
            ""
        },
        0.05 * summary.max_bond_length,
        summary.timestep
    );
    std::fs::write(dir.join(name), text).unwrap();
}

pub(super) fn run_driver(dir: &Path, deck: &str, np: usize) -> String {
    run_liggghts(&driver_launch((np > 1).then_some(np)), dir, deck)
        .unwrap_or_else(|e| panic!("{deck} (np {np}) failed: {e}"))
}

/// The last snapshot of a `dump custom` sorted by id: per atom its columns after the id.
pub(super) fn last_dump(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    atom_rows(&text[text.rfind("ITEM: ATOMS").unwrap()..], usize::MAX)
}

/// At most `n` rows after the `ITEM: ATOMS` line that starts `snapshot`: per atom its
/// columns after the id.
fn atom_rows(snapshot: &str, n: usize) -> Vec<Vec<f64>> {
    snapshot
        .lines()
        .skip(1)
        .take(n)
        .map(|l| {
            l.split_whitespace()
                .skip(1)
                .map(|w| w.parse().unwrap())
                .collect()
        })
        .collect()
}

/// The potential energy of the `thermo_style custom step c_epot` line of step 0.
pub(super) fn step0_energy(log: &str) -> f64 {
    let mut lines = log
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("Step"));
    lines.next();
    let w: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
    assert_eq!(w[0], "0");
    w[1].parse().unwrap()
}

/// The driver with the term on one process at the strained, perturbed state of
/// [`strained_state`] (S = diag(1.02, 0.985, 1.01), δ up to 2 % of R̄; the springs at rest
/// there), by the deck `forces.in` in `dir`: the forces per atom (by id), the potential
/// energy of step 0, and the unwrapped positions and S.
pub(super) fn driver_at_strained_state(
    dir: &Path,
    summary: &ExportSummary,
    packing: &Packing,
) -> (Vec<Vec<f64>>, f64, Vec<Vec3>, anisobond::Mat3) {
    let (x, h) = strained_state(dir, packing, [1.02, 0.985, 1.01], 0.02);
    deck(
        dir,
        "forces.in",
        summary,
        true,
        "compute epot all pe\nthermo_style custom step c_epot\nthermo_modify format float %.17g\n\
         dump d all custom 1 forces.dump id fx fy fz\n\
         dump_modify d sort id format \"%d %.17g %.17g %.17g\"\nrun 0\n",
    );
    let log = run_driver(dir, "forces.in", 1);
    (
        last_dump(&dir.join("forces.dump")),
        step0_energy(&log),
        x,
        h,
    )
}

/// (max |f_got − f_want|, max |f_want|) over the atoms and components (N), `got` rows
/// (fx, fy, fz) of a dump; as many rows as forces.
pub(super) fn force_error(got: &[Vec<f64>], want: &[Vec3]) -> (f64, f64) {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().map(|f| f.amax()).fold(0.0, f64::max);
    let err = got
        .iter()
        .zip(want)
        .map(|(g, w)| (Vec3::new(g[0], g[1], g[2]) - w).amax())
        .fold(0.0, f64::max);
    (err, scale)
}

/// The decks `body(name)` with the term on the state of `strained.data`, run as `np1` on
/// one process and `np2` on two.
pub(super) fn run_np1_np2(dir: &Path, summary: &ExportSummary, body: impl Fn(&str) -> String) {
    deck(dir, "np.in", summary, true, &body("np1"));
    run_driver(dir, "np.in", 1);
    deck(dir, "np.in", summary, true, &body("np2"));
    run_driver(dir, "np.in", 2);
}

/// The first snapshot of a `dump custom` of `n` atoms sorted by id: per atom its columns
/// after the id.
pub(super) fn first_dump(path: &Path, n: usize) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    atom_rows(&text[text.find("ITEM: ATOMS").unwrap()..], n)
}

/// The largest |a − b| over the rows and the columns `cols`.
pub(super) fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>], cols: std::ops::Range<usize>) -> f64 {
    let mut d: f64 = 0.0;
    for (ra, rb) in a.iter().zip(b) {
        for c in cols.clone() {
            d = d.max((ra[c] - rb[c]).abs());
        }
    }
    d
}

/// `validate liggghts` with the driver built here and `liggghts` on PATH, the integrator
/// held to 1e-5 (the other tolerances the defaults).
pub(super) fn validate_engine() -> anisobond::validate::liggghts::Liggghts {
    use anisobond::validate::liggghts::{Liggghts, Programs, ValidateOptions};
    Liggghts {
        programs: Programs {
            driver: driver(),
            liggghts: "liggghts".into(),
        },
        options: ValidateOptions {
            integrator_tolerance: 1e-5,
            ..ValidateOptions::default()
        },
    }
}

/// Forces and energy of the driver at a perturbed, strained state (springs at rest there)
/// equal the library's `ManyBody::evaluate` of the same positions, for both measures.
#[test]
fn forces_match_library_at_strained_state() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    for measure in ["green-lagrange", "small"] {
        let dir = fresh_dir(&format!("manybody_forces_{measure}"));
        let (b, term, s) = setup(&dir, 150, measure);
        assert_eq!(
            term.measure(),
            if measure == "small" {
                StrainMeasure::Small
            } else {
                StrainMeasure::GreenLagrange
            }
        );
        // The table read back is the one the driver reads.
        let table = read_manybody_table(&dir.join("manybody.txt")).unwrap();
        assert_eq!(table.bonds.len(), b.bonds.len());
        let (got, e, x, h) = driver_at_strained_state(&dir, &s, &b.packing);
        let want = term
            .evaluate(&term.branch_vectors(&x, &h).unwrap())
            .unwrap();
        let (err, scale) = force_error(&got, &want.forces);
        let e_err = (e - want.energy).abs() / want.energy.abs();
        eprintln!(
            "{measure}: largest force {scale:.3e} N, max |Δf| {err:.3e} N (relative {:.3e}); \
             energy {e:.6e} J vs {:.6e} J (relative {e_err:.3e})",
            err / scale,
            want.energy
        );
        assert!(
            scale > 0.0 && err <= 1e-10 * scale,
            "{measure}: driver forces differ from ManyBody::evaluate by {:.3e} relative",
            err / scale
        );
        assert!(
            e_err <= 1e-10,
            "{measure}: driver energy {e} vs library {} (relative {e_err:.3e})",
            want.energy
        );
    }
}

/// A short undamped run from a perturbed state: two processes give the same positions,
/// velocities and forces as one within 1e-10, and the term moves the atoms (a run without
/// it ends elsewhere).
#[test]
fn two_processes_match_one() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("manybody_np2");
    let (b, _term, s) = setup(&dir, 200, "green-lagrange");
    let _ = strained_state(&dir, &b.packing, [1.01, 1.0, 0.995], 0.01);
    let body = |name: &str| {
        format!(
            "fix integrate all nve/sphere\n\
             dump d all custom 400 {name}.dump id x y z vx vy vz fx fy fz\n\
             dump_modify d sort id format \"%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\"\n\
             run 400\n"
        )
    };
    run_np1_np2(&dir, &s, body);
    deck(&dir, "off.in", &s, false, &body("off"));
    run_driver(&dir, "off.in", 1);
    let (one, two, off) = (
        last_dump(&dir.join("np1.dump")),
        last_dump(&dir.join("np2.dump")),
        last_dump(&dir.join("off.dump")),
    );
    let text = std::fs::read_to_string(dir.join("np1.dump")).unwrap();
    assert!(text.contains("ITEM: TIMESTEP\n400\n"), "no step 400 dump");
    // Per column group (x, v, f): largest difference relative to the group's scale (for x:
    // the motion since the start).
    let first = first_dump(&dir.join("np1.dump"), one.len());
    let motion = max_diff(&one, &first, 0..3);
    let vscale = max_diff(&one, &vec![vec![0.0; 9]; one.len()], 3..6);
    let fscale = max_diff(&one, &vec![vec![0.0; 9]; one.len()], 6..9);
    let (dx, dv, df) = (
        max_diff(&one, &two, 0..3) / motion,
        max_diff(&one, &two, 3..6) / vscale,
        max_diff(&one, &two, 6..9) / fscale,
    );
    let term_effect = max_diff(&one, &off, 0..3) / motion;
    eprintln!(
        "np 2 vs np 1: x {dx:.3e} (of the motion {motion:.3e} m), v {dv:.3e}, f {df:.3e}; \
         without the term x differs by {term_effect:.3e}"
    );
    assert!(motion > 0.0 && vscale > 0.0 && fscale > 0.0);
    assert!(
        dx <= 1e-10 && dv <= 1e-10 && df <= 1e-10,
        "np 2 differs from np 1: x {dx:.3e}, v {dv:.3e}, f {df:.3e}"
    );
    assert!(
        term_effect > 1e-3,
        "the run without the term ends at the same positions ({term_effect:.3e}): the term did nothing"
    );
}

/// The table written by the export reads back to the same bits, and a malformed line is
/// refused naming the file and line.
#[test]
fn manybody_table_round_trip_and_refusal() {
    let dir = fresh_dir("manybody_table");
    let toml = model_toml("green-lagrange");
    let b = bonded(120, 5, &toml);
    let model = Model::from_toml_str(&toml, "<test model>").unwrap();
    let term = crate::common::manybody_term(&model, &b.packing, &b.bonds);
    let t = anisobond::export::liggghts::manybody_table(&b.packing, &b.bonds, &term).unwrap();
    // The coefficients reproduce the library's F_p: under a uniform gradient G every included
    // particle's Σ_b (G L_b) ⊗ a_b is G (recomputed here from the table).
    let g = anisobond::Mat3::new(1.01, 0.002, 0.0, -0.001, 0.99, 0.003, 0.0, 0.001, 1.005);
    let refs = term.reference_branches();
    let mut f = vec![anisobond::Mat3::zeros(); b.packing.len()];
    for (k, row) in t.bonds.iter().enumerate() {
        let l = g * refs[k];
        f[b.bonds.i[k] as usize] += l * row.coef_i.transpose();
        f[b.bonds.j[k] as usize] += l * row.coef_j.transpose();
    }
    let mut included = 0;
    for (p, fp) in f.iter().enumerate() {
        if t.volumes[p].1 > 0.0 {
            included += 1;
            assert!((fp - g).amax() < 1e-12, "particle {p}: {fp} vs {g}");
        } else {
            assert!(term.excluded().contains(&(p as u32)));
        }
    }
    assert_eq!(included + term.excluded().len(), b.packing.len());
    let path = dir.join("manybody.txt");
    anisobond::export::liggghts::write_manybody_table(&path, &t).unwrap();
    assert_eq!(read_manybody_table(&path).unwrap(), t);
    let text = std::fs::read_to_string(&path).unwrap();
    let broken = text.replacen("bonds ", "bonds x", 1);
    std::fs::write(&path, broken).unwrap();
    let err = read_manybody_table(&path).unwrap_err();
    assert!(matches!(err, anisobond::Error::Parse { .. }), "{err}");
}

/// `anisobond export liggghts` of a model with `[manybody]` writes the library's table of the
/// same assembly and puts it on the driver deck; with `[strength]` too it is refused, with
/// nothing written; `validate liggghts --specimen` refuses the model (the specimen deck and
/// reference lack the term; the element tests carry it, see the test below).
#[test]
fn cli_export_writes_the_term_and_refusals() {
    use crate::common::{bin, fails, holds_exactly, succeeds, write};
    let dir = fresh_dir("manybody_cli");
    let packing = crate::common::packing(&dir, 120);
    let toml = model_toml("green-lagrange");
    let model = write(&dir, "model.toml", &toml);
    let out = dir.join("out");
    let text = succeeds(
        bin()
            .args(["export", "liggghts"])
            .arg(&packing)
            .arg("--model")
            .arg(&model)
            .arg("--no-shear")
            .arg("-o")
            .arg(&out),
    );
    assert!(text.contains("many-body term: manybody.txt"), "{text}");
    let deck = std::fs::read_to_string(out.join("anisobond.in")).unwrap();
    assert!(
        deck.contains(
            "pair_style anisobond table bonds.csv damping ${damp} ${damp} manybody manybody.txt"
        ),
        "{deck}"
    );
    assert!(std::fs::read_to_string(out.join("harmonic.in"))
        .unwrap()
        .contains("Without the model's many-body term"));
    // The library's term of the same packing and model, independently of the CLI.
    let asm = anisobond::assembly::Assembly::from_packing_file(
        &packing,
        Model::from_toml_str(&toml, "<m>").unwrap(),
        &model,
    )
    .unwrap();
    let term = crate::common::manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let want =
        anisobond::export::liggghts::manybody_table(&asm.packing, &asm.bonds, &term).unwrap();
    assert_eq!(
        read_manybody_table(&out.join("manybody.txt")).unwrap(),
        want
    );

    // [strength] with [manybody]: refused, nothing written.
    let both = write(
        &dir,
        "both.toml",
        &format!(
            "{toml}[strength]\n[strength.bond]\ntensile = 1e7\ncohesion = 1e8\nfriction = 0.5\n"
        ),
    );
    let out2 = dir.join("out2");
    let err = fails(
        bin()
            .args(["export", "liggghts"])
            .arg(&packing)
            .arg("--model")
            .arg(&both)
            .arg("-o")
            .arg(&out2),
    );
    assert!(err.contains("[strength] and [manybody]"), "{err}");
    assert!(!out2.exists());

    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping the validate part: {r}");
        return;
    }
    let _ = driver();
    let out3 = dir.join("out3");
    let o = bin()
        .args(["validate", "liggghts", "--specimen"])
        .arg(&packing)
        .arg("--model")
        .arg(&model)
        .arg("-o")
        .arg(&out3)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("[manybody]"), "{err}");
    assert!(!out3.exists(), "validate left {}", out3.display());
    holds_exactly(&dir, &["both.toml", "model.toml", "out", "packing.txt"]);
}

/// The model forms bring the model's term through the bridge: `model MODEL PACKING` and the
/// in-place `model MODEL`, bonded at the reference and then stretched affinely (change_box
/// … remap): their forces minus those of the same model without `[manybody]` equal the
/// library's `ManyBody::evaluate` of the stretched positions.
#[test]
fn model_forms_match_library_under_uniform_strain() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    use anisobond::assembly::Assembly;
    let dir = fresh_dir("manybody_model_forms");
    let packing_file = crate::common::packing(&dir, 150);
    let toml = model_toml("green-lagrange");
    let plain = toml[..toml.find("[manybody]").unwrap()].to_string();
    crate::common::write(&dir, "model.toml", &toml);
    crate::common::write(&dir, "plain.toml", &plain);
    let model = Model::from_toml_str(&toml, "<m>").unwrap();
    let asm = Assembly::from_packing_file(&packing_file, model, Path::new("model.toml")).unwrap();
    let term = crate::common::manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let s = export_with_term(&dir, &asm.packing, &asm.bonds, &asm.springs, &term);
    let stretch = [1.01, 0.995, 1.005];
    let h = anisobond::Mat3::from_diagonal(&Vec3::new(stretch[0], stretch[1], stretch[2]));
    let x: Vec<Vec3> = asm.packing.positions.iter().map(|p| h * p).collect();
    let want = term
        .evaluate(&term.branch_vectors(&x, &h).unwrap())
        .unwrap();
    let scale = want.forces.iter().map(|f| f.amax()).fold(0.0, f64::max);
    let forces = |name: &str, style: &str| {
        let text = format!(
            "units si\natom_style granular\natom_modify map array\nboundary p p p\nnewton on\n\
             communicate single vel yes\nread_data packing.data\n\
             pair_style anisobond {style}\npair_coeff * *\n\
             neighbor {} bin\nneigh_modify delay 0\ntimestep {}\nrun 0\n\
             change_box all x scale {} y scale {} z scale {} remap\n\
             dump d all custom 1 {name}.dump id fx fy fz\n\
             dump_modify d sort id format \"%d %.17g %.17g %.17g\"\nrun 0\n",
            0.05 * s.max_bond_length,
            s.timestep,
            stretch[0],
            stretch[1],
            stretch[2]
        );
        std::fs::write(dir.join(format!("{name}.in")), text).unwrap();
        run_driver(&dir, &format!("{name}.in"), 1);
        last_dump(&dir.join(format!("{name}.dump")))
    };
    for (form, with, without) in [
        (
            "packing",
            "model model.toml packing.txt",
            "model plain.toml packing.txt",
        ),
        ("in place", "model model.toml", "model plain.toml"),
    ] {
        let tag = form.replace(' ', "_");
        let on = forces(&format!("{tag}_on"), with);
        let off = forces(&format!("{tag}_off"), without);
        let err = on
            .iter()
            .zip(&off)
            .zip(&want.forces)
            .map(|((a, b), w)| (Vec3::new(a[0] - b[0], a[1] - b[1], a[2] - b[2]) - w).amax())
            .fold(0.0, f64::max);
        eprintln!(
            "{form}: largest term force {scale:.3e} N, max |Δf| {err:.3e} N (relative {:.3e})",
            err / scale
        );
        assert!(
            scale > 0.0 && err <= 1e-10 * scale,
            "{form}: driver term forces differ from ManyBody::evaluate by {:.3e} relative",
            err / scale
        );
    }
}

/// `validate liggghts` of a model with `[manybody]` (issue 33): the driver decks carry the
/// term, the integrator and the relaxed reference too. Every check passes within the usual
/// tolerances (history 1e-6, tensors 5e-3, -np 2 vs -np 1 1e-6); the reference is the relaxed
/// tensor with the term recomputed here, which is far from the springs' alone, so a run of
/// the springs alone would fail `tensor-driver-relaxed`.
#[test]
fn validate_with_the_term_meets_the_relaxed_tensor_with_the_term() {
    use anisobond::homogenize::{relaxed_tensor, relaxed_tensor_with_term, RelaxedOptions};
    use anisobond::tensor::relative_difference;
    use anisobond::validate::liggghts::checks_table;
    use anisobond::validate::{validate, Problem, TestKind};
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let toml = model_toml("green-lagrange");
    let b = bonded(200, 7, &toml);
    let model = Model::from_toml_str(&toml, "<test model>").unwrap();
    let term = crate::common::manybody_term(&model, &b.packing, &b.bonds);
    let dir = fresh_dir("manybody_validate");
    let problem = Problem {
        dir: &dir,
        packing: &b.packing,
        bonds: &b.bonds,
        springs: &b.k,
        model: Some(&model),
        kind: TestKind::PeriodicElement,
    };
    let engine = validate_engine();
    let t0 = std::time::Instant::now();
    let r = validate(&engine, &problem, &|s| {
        eprintln!("[{:6.1} s] {s}", t0.elapsed().as_secs_f64())
    })
    .expect("validation runs");
    eprintln!("{}", checks_table(&r));
    let ids: Vec<&str> = r.checks.iter().map(|c| c.id.as_str()).collect();
    for want in [
        "history",
        "mpi-history",
        "tensor-driver-relaxed",
        "tensor-integrator-relaxed",
        "tensor-driver-integrator",
        "mpi-columns",
        "harmonic-skipped",
    ] {
        assert!(ids.contains(&want), "check {want} missing: {ids:?}");
    }
    assert!(
        !ids.contains(&"harmonic-history") && !ids.contains(&"harmonic-relaxed"),
        "the stock harmonic deck cannot carry the term: {ids:?}"
    );
    assert!(r.failures().is_empty(), "{}", checks_table(&r));
    // The reference, recomputed here: the relaxed tensor with the term, and the springs'
    // alone for contrast.
    let with_term = relaxed_tensor_with_term(
        &b.packing,
        &b.bonds,
        &b.k,
        Some(&term),
        &RelaxedOptions::default(),
    )
    .unwrap()
    .c;
    let springs = relaxed_tensor(&b.packing, &b.bonds, &b.k, &RelaxedOptions::default())
        .unwrap()
        .c;
    // max |ΔC| / max |C_b| of relative_difference(a, b).
    let same = relative_difference(&r.relaxed_tensor, &with_term);
    let away = relative_difference(&springs, &with_term);
    let driver_vs_springs = relative_difference(&r.driver_tensor, &springs);
    eprintln!(
        "report's relaxed vs recomputed {same:.2e}; springs alone vs with the term {away:.3}; \
         driver vs springs alone {driver_vs_springs:.3}; dt {:.3e} s",
        r.time_step
    );
    assert!(same < 1e-9, "{same}");
    assert!(
        away > 20.0 * 5e-3,
        "the term should change the tensor clearly: {away}"
    );
    assert!(driver_vs_springs > 20.0 * 5e-3, "{driver_vs_springs}");
    // The step is bounded with the term: not above the springs' own stable step.
    let springs_dt =
        anisobond::export::liggghts::stable_timestep(&b.packing, &b.bonds, &b.k, 2500.0).unwrap();
    assert!(r.time_step < springs_dt, "{} vs {springs_dt}", r.time_step);
}
