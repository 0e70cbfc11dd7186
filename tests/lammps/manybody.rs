//! The many-body term in anisobond's LAMMPS plugin (`bond_style anisobond … manybody D11 …
//! D66`, issue 33, docs/manybody.md "LAMMPS"), run by the real `lmp`: at a strained and
//! randomly perturbed state the plugin's forces and energy with the term minus without it
//! are the library's `ManyBody::evaluate` (computed here from the same positions), and its
//! virial stress under a uniform strain is the closed form (Σ V_p/V)/J · F (D:E) Fᵀ; a damped
//! run on two processes gives the same positions and forces as on one; stock bpm/rotational
//! (route a) is refused for a model with `[manybody]`, naming the plugin route.

use super::export::{export_cmd, CROSS};
use super::plugin::{export_plugin, lammps, run_lmp, Lammps};
use crate::common::{fails, packing, succeeds, tmp, write};
use anisobond::{Mat3, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The cross-anisotropic model of the plugin tests (`export`'s [`CROSS`]) with a rotated
/// cubic many-body term of the springs' order (degenerate particles excluded: the model
/// file's default).
fn model() -> String {
    format!(
        "{CROSS}[manybody]\nkind = \"cubic\"\nc11 = 20e9\nc12 = 14e9\nc44 = 6e9\n\
         euler_zyz_deg = [10, 20, 30]\n"
    )
}

/// The strained box of the tests, H (upper triangular: LAMMPS' box vectors a = (lx, 0, 0),
/// b = (xy, ly, 0), c = (xz, yz, lz) are H times the reference cell's).
pub(super) fn strain() -> Mat3 {
    Mat3::new(1.002, 0.003, 0.001, 0.0, 0.999, -0.002, 0.0, 0.0, 1.001)
}

/// `change_box` to H times the reference cell `l` (bounds from 0, tilts), with `remap` or not.
fn change_box(h: &Mat3, l: Vec3, remap: bool) -> String {
    format!(
        "change_box all x final 0 {} y final 0 {} z final 0 {} xy final {} xz final {} yz final {}{}\n",
        h[(0, 0)] * l.x,
        h[(1, 1)] * l.y,
        h[(2, 2)] * l.z,
        h[(0, 1)] * l.y,
        h[(0, 2)] * l.z,
        h[(1, 2)] * l.z,
        if remap { " remap" } else { "" }
    )
}

/// A fixed seeded perturbation (splitmix64), each component uniform in ±`amplitude`.
pub(super) fn perturbation(n: usize, amplitude: f64) -> Vec<Vec3> {
    let mut state: u64 = 0x5eed_0033;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..n)
        .map(|_| Vec3::new(next(), next(), next()) * amplitude)
        .collect()
}

/// The positions H·X_p + δ_p as `set atom` lines (atom ids = index + 1), and the positions.
pub(super) fn perturbed_state(x: &[Vec3], h: &Mat3, delta: &[Vec3]) -> (String, Vec<Vec3>) {
    let mut s = String::new();
    let mut y = Vec::new();
    for (p, (xp, dp)) in x.iter().zip(delta).enumerate() {
        let v = h * xp + dp;
        s.push_str(&format!(
            "set atom {} x {} y {} z {}\n",
            p + 1,
            v.x,
            v.y,
            v.z
        ));
        y.push(v);
    }
    (s, y)
}

/// The deck: the export's settings, the plugin's bonds (with the term or without), the
/// reference (`run 0`), the uniform strain (`change_box … remap`, `run 0`, its virial stress
/// printed), then `tail`.
/// `term`: None without the term, Some(extra) with `${manybody}` and the keywords `extra`
/// (a later keyword overrides the export's).
pub(super) fn deck(term: Option<&str>, cell: Vec3, tail: &str) -> String {
    let manybody = match term {
        Some(extra) => format!(" ${{manybody}}{extra}"),
        None => String::new(),
    };
    format!(
        "include params.lmp\nplugin load ${{plugin}}\nunits si\nboundary p p p\n\
         atom_style bpm/sphere\nspecial_bonds lj 0 1 1 coul 1 1 1\nnewton on on\n\
         comm_modify vel yes cutoff ${{cut}}\nread_data ${{data}} nocoeff\n\
         change_box all triclinic\n\
         bond_style anisobond ${{springs}} damping ${{damping}}{manybody}\nbond_coeff *\n\
         pair_style zero ${{cut}}\npair_coeff * *\nneighbor ${{skin}} bin\n\
         neigh_modify every 1 delay 0 check yes\n\
         fix integrate all nve/bpm/sphere\ntimestep ${{dt}}\n\
         compute p all pressure NULL virial\nthermo_style custom step ebond\n\
         thermo_modify format float %.17g\nvariable e equal ebond\n\
         run 0\n{}run 0\n\
         print \"anisobond-stress $(-c_p[1]:%.17g) $(-c_p[2]:%.17g) $(-c_p[3]:%.17g) $(-c_p[6]:%.17g) $(-c_p[5]:%.17g) $(-c_p[4]:%.17g)\"\n\
         {tail}",
        change_box(&strain(), cell, true)
    )
}

/// The words after `key` on the last line of `text` that starts with it, as numbers.
pub(super) fn numbers(text: &str, key: &str) -> Vec<f64> {
    let line = text
        .lines()
        .rfind(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no `{key}` line in:\n{text}"));
    line.split_whitespace()
        .skip(1)
        .map(|w| w.parse().unwrap())
        .collect()
}

/// The rows of a `dump custom` file sorted by id: id → the other columns.
pub(super) fn dump_rows(path: &Path) -> BTreeMap<u64, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows = BTreeMap::new();
    let mut in_atoms = false;
    for line in text.lines() {
        if line.starts_with("ITEM:") {
            in_atoms = line.starts_with("ITEM: ATOMS");
            continue;
        }
        if in_atoms {
            let mut w = line.split_whitespace();
            let id: u64 = w.next().unwrap().parse().unwrap();
            rows.insert(id, w.map(|v| v.parse().unwrap()).collect());
        }
    }
    rows
}

/// Export the plugin deck of [`model`] on a packing of `n` particles into `dir/deck`.
fn exported(l: &Lammps, dir: &Path, n: usize) -> (PathBuf, PathBuf, PathBuf) {
    let pk = packing(dir, n);
    let model = write(dir, "model.toml", &model());
    let out = dir.join("deck");
    succeeds(&mut export_plugin(&pk, &model, &l.so, &out));
    (pk, model, out)
}

/// The plugin deck of [`model`] on 300 particles exported into `dir/deck` ([`exported`]),
/// with its `perturbed.lmp` ([`write_perturbed`]): the assembly, the deck's folder, the
/// reference cell and the perturbed positions.
fn perturbed_deck(
    l: &Lammps,
    dir: &Path,
) -> (anisobond::assembly::Assembly, PathBuf, Vec3, Vec<Vec3>) {
    let (pk, model, out) = exported(l, dir, 300);
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let cell = asm.packing.cell.unwrap().lengths;
    let y = write_perturbed(&out, &asm);
    (asm, out, cell, y)
}

/// Write `out/perturbed.lmp`, which sets `asm`'s particles at the [`strain`]ed state H·X + δ,
/// δ up to 1 % of the mean radius ([`perturbation`]); those positions.
pub(super) fn write_perturbed(out: &Path, asm: &anisobond::assembly::Assembly) -> Vec<Vec3> {
    let mean_r = asm.packing.radii.iter().sum::<f64>() / asm.packing.len() as f64;
    let delta = perturbation(asm.packing.len(), 0.01 * mean_r);
    let (set_lines, y) = perturbed_state(&asm.packing.positions, &strain(), &delta);
    std::fs::write(out.join("perturbed.lmp"), set_lines).unwrap();
    y
}

/// Run `input` in `dir` on `np` processes; its standard output (failure: panic with it).
pub(super) fn run(l: &Lammps, dir: &Path, input: &str, np: usize) -> String {
    let out = run_lmp(&l.lmp, dir, input, np);
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{input} on {np} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

#[test]
fn plugin_forces_energy_and_stress_are_the_librarys_many_body_term() {
    let Some(l) = lammps("plugin_many_body_forces") else {
        return;
    };
    let dir = tmp();
    let (pk, model, out) = exported(&l, dir.path(), 300);
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let spec = asm.model.manybody.clone().expect("the model's [manybody]");
    let term = spec.build(&asm.packing, &asm.bonds).unwrap();
    let cell = asm.packing.cell.unwrap().lengths;
    eprintln!(
        "{} particles, {} bonds, {} excluded (degenerate), volume fraction {:.6}",
        asm.packing.len(),
        asm.bonds.len(),
        term.excluded().len(),
        term.volume_fraction()
    );

    // params.lmp carries D's upper triangle exactly as the library's lab-frame matrix.
    let params = std::fs::read_to_string(out.join("params.lmp")).unwrap();
    let line = params
        .lines()
        .find(|l| l.starts_with("variable manybody index"))
        .expect("the manybody variable");
    let words: Vec<&str> = line.trim_end_matches('"').split_whitespace().collect();
    let at = words.iter().position(|w| *w == "\"manybody").unwrap();
    let d = term.tensor().unwrap();
    let mut k = at + 1;
    for a in 0..6 {
        for b in a..6 {
            assert_eq!(words[k].parse::<f64>().unwrap(), d[(a, b)], "D{a}{b}");
            k += 1;
        }
    }
    assert!(line.contains("manybody/degenerate exclude"), "{line}");
    let elastic = std::fs::read_to_string(out.join("in.elastic")).unwrap();
    assert!(
        elastic.contains("bond_style anisobond ${springs} damping ${damping} ${manybody}"),
        "{elastic}"
    );

    // The model's term, and the same with λ_min/λ_max of A_p at least 0.2 (keyword
    // `manybody/conditioning 0.2` after the export's), which excludes some particles.
    let strict = anisobond::manybody::ManyBodyOptions {
        conditioning: 0.2,
        ..spec.options()
    };
    let strict_term =
        anisobond::manybody::ManyBody::new(&asm.packing, &asm.bonds, &spec.tensor, &strict)
            .unwrap();
    assert!(!strict_term.excluded().is_empty());
    for (name, extra, term) in [
        ("default", "", &term),
        ("strict", " manybody/conditioning 0.2", &strict_term),
    ] {
        let sub = out.join(name);
        std::fs::create_dir(&sub).unwrap();
        for f in ["params.lmp", "data.lmp", "bonds.csv"] {
            std::fs::copy(out.join(f), sub.join(f)).unwrap();
        }
        compare_at_perturbed_state(&l, &sub, &asm, term, extra);
    }

    // `manybody/degenerate refuse`: the plugin refuses, naming an atom the library excludes.
    let sub = out.join("refuse");
    std::fs::create_dir(&sub).unwrap();
    for f in ["params.lmp", "data.lmp", "bonds.csv"] {
        std::fs::copy(out.join(f), sub.join(f)).unwrap();
    }
    let extra = " manybody/conditioning 0.2 manybody/degenerate refuse";
    std::fs::write(sub.join("refuse.lmp"), deck(Some(extra), cell, "")).unwrap();
    let o = run_lmp(&l.lmp, &sub, "refuse.lmp", 1);
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "refuse ran:\n{text}");
    let named = strict_term
        .excluded()
        .iter()
        .any(|&p| text.contains(&format!("many-body term: atom {} has", p + 1)));
    assert!(named, "no excluded atom named:\n{text}");
}

/// The plugin's forces and energy (with the term and keywords `extra`, minus without) at a
/// strained and perturbed state against `term` (the library's), and its virial stress under
/// the uniform strain against the closed form.
fn compare_at_perturbed_state(
    l: &Lammps,
    out: &Path,
    asm: &anisobond::assembly::Assembly,
    term: &anisobond::manybody::ManyBody,
    extra: &str,
) {
    let cell = asm.packing.cell.unwrap().lengths;
    let d = term.tensor().unwrap();
    // The perturbed state: H·X + δ, δ up to 1 % of the mean radius.
    let h = strain();
    let y = write_perturbed(out, asm);
    let tail = |name: &str| {
        format!(
            "include perturbed.lmp\ndump d all custom 1 {name}.dump id fx fy fz\n\
             dump_modify d sort id format float %.17g\nrun 0\n\
             print \"anisobond-ebond $(v_e:%.17g)\"\n"
        )
    };
    std::fs::write(out.join("on.lmp"), deck(Some(extra), cell, &tail("on"))).unwrap();
    std::fs::write(out.join("off.lmp"), deck(None, cell, &tail("off"))).unwrap();
    let log_on = run(l, out, "on.lmp", 1);
    let log_off = run(l, out, "off.lmp", 1);
    assert!(
        log_on.contains(&format!(
            "many-body reference of {} atoms, {} excluded",
            asm.packing.len(),
            term.excluded().len()
        )),
        "the plugin sets the term's reference, excluding what the library does:\n{log_on}"
    );

    // Forces and energy: LAMMPS (on − off) against the library at the same positions.
    let branch = term.branch_vectors(&y, &h).unwrap();
    let lib = term.evaluate(&branch).unwrap();
    let (on, off) = (
        dump_rows(&out.join("on.dump")),
        dump_rows(&out.join("off.dump")),
    );
    assert_eq!(on.len(), asm.packing.len());
    let f_max = lib.forces.iter().fold(0.0_f64, |m, f| m.max(f.amax()));
    let mut worst = 0.0_f64;
    for (p, f_lib) in lib.forces.iter().enumerate() {
        let (a, b) = (&on[&(p as u64 + 1)], &off[&(p as u64 + 1)]);
        for c in 0..3 {
            worst = worst.max(((a[c] - b[c]) - f_lib[c]).abs());
        }
    }
    let e_lammps = numbers(&log_on, "anisobond-ebond")[0] - numbers(&log_off, "anisobond-ebond")[0];
    let e_rel = (e_lammps - lib.energy).abs() / lib.energy.abs();
    eprintln!(
        "{} excluded: forces: max |f_on − f_off − f_lib| / max |f_lib| = {:.2e} (max |f_lib| {f_max:.3e} N); \
         energy: LAMMPS {e_lammps:.9e} J, library {:.9e} J, relative {e_rel:.2e}",
        term.excluded().len(),
        worst / f_max,
        lib.energy
    );
    assert!(f_max > 0.0 && lib.energy > 0.0);
    assert!(worst < 1e-10 * f_max, "forces: {:e}", worst / f_max);
    assert!(e_rel < 1e-10, "energy: {e_rel:e}");

    // The uniform strain (remap: every l_b = H L_b): the virial stress of the term is the
    // closed form (Σ V_p/V)/J · F S Fᵀ, S = D:E, E = ½(FᵀF − I), with the volume share
    // recomputed from the radii of the included particles.
    let s_on = numbers(&log_on, "anisobond-stress");
    let s_off = numbers(&log_off, "anisobond-stress");
    let e = (h.transpose() * h - Mat3::identity()) * 0.5;
    let ev = anisobond::tensor::Voigt6::new(
        e[(0, 0)],
        e[(1, 1)],
        e[(2, 2)],
        2.0 * e[(1, 2)],
        2.0 * e[(0, 2)],
        2.0 * e[(0, 1)],
    );
    let sv = d * ev;
    let s = Mat3::new(
        sv[0], sv[5], sv[4], sv[5], sv[1], sv[3], sv[4], sv[3], sv[2],
    );
    let r3 = |p: usize| asm.packing.radii[p].powi(3);
    let all: f64 = (0..asm.packing.len()).map(r3).sum();
    let excluded: f64 = term.excluded().iter().map(|&p| r3(p as usize)).sum();
    let share = (all - excluded) / all;
    let sigma = h * s * h.transpose() * (share / h.determinant());
    let want = [
        sigma[(0, 0)],
        sigma[(1, 1)],
        sigma[(2, 2)],
        sigma[(1, 2)],
        sigma[(0, 2)],
        sigma[(0, 1)],
    ];
    let scale = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let dev = (0..6).fold(0.0_f64, |m, c| {
        m.max(((s_on[c] - s_off[c]) - want[c]).abs())
    });
    eprintln!(
        "uniform strain: virial stress of the term {:?} Pa vs closed form {want:?}: max \
         deviation / max |σ| = {:.2e}",
        (0..6).map(|c| s_on[c] - s_off[c]).collect::<Vec<_>>(),
        dev / scale
    );
    assert!(dev < 1e-8 * scale, "stress: {:e}", dev / scale);
}

#[test]
fn plugin_many_body_run_on_two_processes_equals_one() {
    let Some(l) = lammps("plugin_many_body_np2") else {
        return;
    };
    let dir = tmp();
    let (asm, out, cell, y0) = perturbed_deck(&l, dir.path());
    let tail = |name: &str| {
        format!(
            "include perturbed.lmp\nrun 0\nwrite_dump all custom {name}-start.dump id fx fy fz \
             modify sort id format float %.17g\nrun 300\nwrite_dump all custom {name}.dump id xu \
             yu zu fx fy fz modify sort id format float %.17g\n"
        )
    };
    for (name, np, term) in [("np1", 1, true), ("np2", 2, true), ("off", 1, false)] {
        let term = term.then_some("");
        std::fs::write(
            out.join(format!("{name}.lmp")),
            deck(term, cell, &tail(name)),
        )
        .unwrap();
        run(&l, &out, &format!("{name}.lmp"), np);
    }
    // The force scale: the largest force at the start (the damped run ends near equilibrium,
    // where the net forces are small differences of the bonds' forces).
    let f_start = dump_rows(&out.join("np1-start.dump"))
        .values()
        .fold(0.0_f64, |m, r| r.iter().fold(m, |m, v| m.max(v.abs())));
    let (a, b, off) = (
        dump_rows(&out.join("np1.dump")),
        dump_rows(&out.join("np2.dump")),
        dump_rows(&out.join("off.dump")),
    );
    assert_eq!(a.len(), asm.packing.len());
    assert_eq!(b.len(), a.len());
    // Displacements from the start (positions relative to the largest displacement), forces
    // relative to the largest force.
    let (mut dx, mut u_max, mut df, mut f_max, mut term_effect) = (0.0_f64, 0.0_f64, 0.0, 0.0, 0.0);
    for (p, y) in y0.iter().enumerate() {
        let (ra, rb, ro) = (
            &a[&(p as u64 + 1)],
            &b[&(p as u64 + 1)],
            &off[&(p as u64 + 1)],
        );
        for c in 0..3 {
            u_max = f64::max(u_max, (ra[c] - y[c]).abs());
            dx = f64::max(dx, (ra[c] - rb[c]).abs());
            f_max = f64::max(f_max, ra[3 + c].abs());
            df = f64::max(df, (ra[3 + c] - rb[3 + c]).abs());
            term_effect = f64::max(term_effect, (ra[3 + c] - ro[3 + c]).abs());
        }
    }
    eprintln!(
        "300 damped steps with the term: np2 vs np1 max |Δx| / max |u| = {:.2e} (max |u| {u_max:.3e} \
         m), max |Δf| / max |f_start| = {:.2e} (max |f| {f_max:.3e} N at the end, {f_start:.3e} N at \
         the start); the term moves the final forces by {:.2e} of max |f|",
        dx / u_max,
        df / f_start,
        term_effect / f_max
    );
    assert!(u_max > 0.0 && f_max > 0.0);
    assert!(term_effect > 1e-3 * f_max, "the term changed nothing");
    assert!(dx < 1e-10 * u_max, "positions: {:e}", dx / u_max);
    assert!(df < 1e-10 * f_start, "forces: {:e}", df / f_start);
}

#[test]
fn route_a_and_breakage_with_the_many_body_term_are_refused_naming_the_way_out() {
    let dir = tmp();
    let pk = packing(dir.path(), 200);
    let model = write(dir.path(), "model.toml", &model());
    let out = dir.path().join("deck");
    // Stock bpm/rotational (the default route) cannot carry the term.
    let err = fails(&mut export_cmd(&pk, &model, &[], &out));
    assert!(
        err.contains("[manybody]") && err.contains("--bond-style anisobond"),
        "{err}"
    );
    assert!(!out.exists(), "a deck was left behind");
    let code = export_cmd(&pk, &model, &[], &out)
        .output()
        .unwrap()
        .status
        .code();
    assert_eq!(code, Some(1), "Error::Invalid's exit code");
    // With breaking bonds (a [strength] table) the plugin route is refused naming
    // --no-break (through the library: the CLI would first need a built plugin).
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let nb = asm.bonds.len();
    let strengths = anisobond::strength::BondStrengths {
        tensile: vec![1e6; nb],
        cohesion: vec![1e6; nb],
        friction: vec![0.5; nb],
        bending: vec![1e6; nb],
        twisting: vec![1e6; nb],
        joint: vec![anisobond::strength::NO_JOINT; nb],
        ..Default::default()
    };
    let o = anisobond::export::lammps::LammpsOptions {
        bond_style: anisobond::export::lammps::LammpsBondStyle::Anisobond {
            plugin: PathBuf::from("/nowhere/anisobond_lammps.so"),
        },
        breakage: Some(anisobond::export::lammps::LammpsBreakage {
            strengths,
            pi_hat: asm.model.geometry.pi_hat,
            smooth: false,
        }),
        manybody: asm.model.manybody.clone(),
        ..Default::default()
    };
    std::fs::create_dir(&out).unwrap();
    let err =
        anisobond::export::lammps::export_lammps(&out, &asm.packing, &asm.bonds, &asm.springs, &o)
            .unwrap_err();
    assert!(matches!(err, anisobond::Error::Invalid(_)), "{err}");
    assert!(err.to_string().contains("--no-break"), "{err}");
    assert!(crate::common::entries(&out).is_empty(), "files left behind");
}

/// A restart file keeps the term's reference (A_p⁻¹, V_p and every bond's L_b, per atom):
/// 200 damped steps, a restart file, 200 more on one process; the restart file continued on
/// two processes ends at the same state, and sets no new reference (one taken at the
/// restart's strained state would zero the term's strain there).
#[test]
fn plugin_many_body_reference_survives_a_restart_on_two_processes() {
    let Some(l) = lammps("plugin_many_body_restart") else {
        return;
    };
    let dir = tmp();
    let (_, out, cell, _) = perturbed_deck(&l, dir.path());
    let dump = |name: &str| {
        format!(
            "write_dump all custom {name}.dump id xu yu zu fx fy fz modify sort id format float \
             %.17g\n"
        )
    };
    let first = format!(
        "include perturbed.lmp\nrun 200\nwrite_restart state.restart\nrun 200\n{}",
        dump("straight")
    );
    std::fs::write(out.join("first.lmp"), deck(Some(""), cell, &first)).unwrap();
    let second = format!(
        "include params.lmp\nplugin load ${{plugin}}\nread_restart state.restart\n\
         comm_modify vel yes cutoff ${{cut}}\nneighbor ${{skin}} bin\n\
         fix integrate all nve/bpm/sphere\nrun 200\n{}",
        dump("restarted")
    );
    std::fs::write(out.join("second.lmp"), second).unwrap();
    run(&l, &out, "first.lmp", 1);
    let log = run(&l, &out, "second.lmp", 2);
    assert!(
        !log.contains("many-body reference of"),
        "a new reference after the restart:\n{log}"
    );
    let (a, b) = (
        dump_rows(&out.join("straight.dump")),
        dump_rows(&out.join("restarted.dump")),
    );
    assert_eq!(a.len(), b.len());
    let (mut dx, mut x_scale, mut df, mut f_max) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    for (id, ra) in &a {
        let rb = &b[id];
        for c in 0..3 {
            x_scale = x_scale.max(ra[c].abs());
            dx = dx.max((ra[c] - rb[c]).abs());
            f_max = f_max.max(ra[3 + c].abs());
            df = df.max((ra[3 + c] - rb[3 + c]).abs());
        }
    }
    eprintln!(
        "restart on 2 processes vs straight on 1: max |Δx| = {dx:.2e} m (positions up to \
         {x_scale:.3e} m), max |Δf| / max |f| = {:.2e} (max |f| {f_max:.3e} N)",
        df / f_max
    );
    assert!(f_max > 0.0);
    assert!(dx < 1e-12 * x_scale, "positions: {dx:e}");
    assert!(df < 1e-8 * f_max, "forces: {:e}", df / f_max);
}

/// On FCC (every particle's bond star centro-symmetric) the term adds exactly D to the
/// relaxed tensor (docs/manybody.md, "The closed form"): the element tests of the exported
/// plugin deck with the term minus those without it are D, on one process and on two.
#[test]
fn plugin_element_tests_on_fcc_add_d_exactly() {
    let Some(l) = lammps("plugin_many_body_fcc") else {
        return;
    };
    let dir = tmp();
    // 3³ FCC cells of touching spheres (R = 1 mm): 108 particles, 12 bonds each.
    let r = 1e-3;
    let a = 2.0 * std::f64::consts::SQRT_2 * r;
    let mut text = format!("# periodic {} {} {}\n", 3.0 * a, 3.0 * a, 3.0 * a);
    for (i, j, k) in (0..27).map(|c| (c / 9, (c / 3) % 3, c % 3)) {
        for b in [
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.5],
            [0.0, 0.5, 0.5],
        ] {
            let x = [i as f64 + b[0], j as f64 + b[1], k as f64 + b[2]].map(|v| v * a);
            text.push_str(&format!("{} {} {} {r}\n", x[0], x[1], x[2]));
        }
    }
    let pk = write(dir.path(), "fcc.txt", &text);
    let model = model().replace("value = 0.17", "value = 0.01");
    let with = write(dir.path(), "with.toml", &model);
    let without = write(
        dir.path(),
        "without.toml",
        &model[..model.find("[manybody]").unwrap()],
    );
    let asm = anisobond::assembly::Assembly::from_files(&pk, &with).unwrap();
    assert_eq!(asm.bonds.len(), 108 * 6, "12 bonds per particle");
    let d = asm.model.manybody.as_ref().unwrap().voigt().unwrap();
    let tensor = |model: &Path, name: &str, np: usize| {
        let out = dir.path().join(name);
        succeeds(&mut export_plugin(&pk, model, &l.so, &out));
        let _one = super::export::one_lammps_at_a_time();
        super::export::run_deck(&l.lmp, &out, np).c
    };
    let off = tensor(&without, "off", 1);
    let scale = (0..6).fold(0.0_f64, |m, i| m.max(off[i][i].abs()));
    for np in [1, 2] {
        let on = tensor(&with, &format!("on-np{np}"), np);
        let dev = (0..6).fold(0.0_f64, |m, i| {
            (0..6).fold(m, |m, j| m.max((on[i][j] - off[i][j] - d[(i, j)]).abs()))
        });
        eprintln!(
            "FCC, {np} process(es): max |C_on − C_off − D| = {dev:.3e} Pa, {:.2e} of max |C_on| \
             (max |D| {:.3e} Pa, max |C_off| {scale:.3e} Pa)",
            dev / (0..6).fold(0.0_f64, |m, i| m.max(on[i][i].abs())),
            d.amax()
        );
        assert!(dev < 1e-4 * d.amax(), "FCC np {np}: {dev:e} Pa");
    }
}

/// The plugin refuses a malformed `manybody` with the reason: too few entries of D, options
/// without the term, an unknown measure, the term with breaking bonds.
#[test]
fn plugin_refuses_many_body_misuse_with_the_reason() {
    let Some(l) = lammps("plugin_many_body_misuse") else {
        return;
    };
    let dir = tmp();
    let (pk, model, out) = exported(&l, dir.path(), 200);
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let cell = asm.packing.cell.unwrap().lengths;
    let plain = deck(None, cell, "");
    let style = "damping ${damping}\n";
    assert!(plain.contains(style));
    for (name, extra, expected) in [
        (
            "short",
            "manybody 1e9 2e9 3e9",
            "takes the 21 upper-triangle entries",
        ),
        (
            "options",
            "manybody/measure small",
            "are for `manybody D11 … D66`",
        ),
        (
            "measure",
            "${manybody} manybody/measure tiny",
            "expected green-lagrange or small",
        ),
        (
            "break",
            "${manybody} break yes",
            "`manybody` with `break yes`",
        ),
    ] {
        let file = format!("{name}.lmp");
        let text = plain.replace(style, &format!("damping ${{damping}} {extra}\n"));
        std::fs::write(out.join(&file), text).unwrap();
        let o = run_lmp(&l.lmp, &out, &file, 1);
        let text =
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name}: LAMMPS accepted it:\n{text}");
        assert!(
            text.contains(expected),
            "{name}: expected `{expected}` in:\n{text}"
        );
    }
}

/// `validate lammps` on the plugin route with a `[manybody]` model: the element tests on one
/// and two processes against the relaxed tensor of the springs and the term together
/// (`relaxed_tensor_with_term`, midpoint lever arm), within the default 1e-4; that reference
/// differs from the springs' alone by far more than that.
#[test]
fn validate_lammps_with_the_many_body_term_meets_the_relaxed_tensor() {
    let Some(l) = lammps("validate_lammps_many_body") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 200);
    let model = write(dir.path(), "model.toml", &model());
    let out = dir.path().join("validate");
    validate_plugin_np2(&l, &pk, &model, &out);
    let deck = std::fs::read_to_string(out.join("in.elastic")).unwrap();
    assert!(deck.contains("${manybody}"), "the deck lacks the term");
    // The reference includes the term: against the springs' relaxed tensor alone the
    // difference is of the order of D.
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let pair = anisobond::homogenize::relaxed_tensor(
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        &midpoint_relaxed(),
    )
    .unwrap()
    .c;
    let term = crate::common::manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let with = relaxed_with_term(&asm, &term);
    let gap = (with - pair).amax() / with.amax();
    eprintln!("relaxed tensor with the term vs the springs' alone: {gap:.2e} of max |C|");
    assert!(gap > 1e-2, "{gap:e}");
}

/// `anisobond validate lammps PK --model MODEL --np 2` on the plugin route (`lmp` and
/// `--bond-style anisobond --plugin` of `l`) into `out`, one LAMMPS at a time: its report,
/// after asserting that it passed (standard output printed).
pub(super) fn validate_plugin_np2(
    l: &Lammps,
    pk: &Path,
    model: &Path,
    out: &Path,
) -> serde_json::Value {
    let mut cmd = crate::common::bin();
    cmd.args(["validate", "lammps"])
        .arg(pk)
        .arg("--model")
        .arg(model)
        .args(["--np", "2", "--lmp"])
        .arg(&l.lmp)
        .args(["--bond-style", "anisobond", "--plugin"])
        .arg(&l.so)
        .arg("-o")
        .arg(out);
    let stdout = {
        let _one = super::export::one_lammps_at_a_time();
        succeeds(&mut cmd)
    };
    eprintln!("{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["passed"], true, "{stdout}");
    report
}

/// The relaxed solve of `validate lammps`' reference: bpm/rotational's midpoint lever arm,
/// tolerance 1e-10.
pub(super) fn midpoint_relaxed() -> anisobond::homogenize::RelaxedOptions {
    anisobond::homogenize::RelaxedOptions {
        lever_arm: anisobond::homogenize::LeverArm::HalfLength,
        tolerance: 1e-10,
        ..Default::default()
    }
}

/// The relaxed tensor of `asm`'s springs with `term` ([`midpoint_relaxed`]).
pub(super) fn relaxed_with_term(
    asm: &anisobond::assembly::Assembly,
    term: &anisobond::manybody::ManyBody,
) -> anisobond::tensor::Stiffness6 {
    anisobond::homogenize::relaxed_tensor_with_term(
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        Some(term),
        &midpoint_relaxed(),
    )
    .unwrap()
    .c
}
