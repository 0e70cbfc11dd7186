//! A polycrystal's many-body term in anisobond's LAMMPS plugin (issue 34 with issue 33's
//! term; docs/polycrystal.md "Engines", docs/manybody.md "LAMMPS"): `export lammps
//! --bond-style anisobond` of a `[grains]` + `[manybody]` model writes each grain's D to
//! `manybody-grains.txt` (equal to rotate(D, gᵀ) computed here by an explicit fourth-order
//! rotation) and the deck's `manybody/grains`; run by the real `lmp`, the plugin's forces and
//! energy are the library's per-grain `ManyBody::evaluate`, two processes equal one within
//! 1e-10, a restart on two processes continues the run, and `validate lammps` (np 1 and 2)
//! meets the relaxed tensor with the per-grain term. Stock bpm/rotational is refused.

use super::manybody::{
    deck, dump_rows, numbers, relaxed_with_term, run, strain, validate_plugin_np2, write_perturbed,
};
use super::plugin::{export_plugin, lammps};
use crate::common::reference::{cubic4, rotate4};
use crate::common::{fails, manybody_term, packing, succeeds, tmp, write};
use anisobond::assembly::Assembly;
use anisobond::tensor::Stiffness6;
use anisobond::Mat3;
use std::path::{Path, PathBuf};

/// Copper-like cubic D (C12 > C44, Zener 2C44/(C11 − C12) = 5), of the springs' order.
const D: (f64, f64, f64) = (1.2e10, 1.0e10, 0.5e10);

/// Cubic springs in the lab frame (no rotation: each grain turns them), five grains of a
/// random texture, and the cubic term D in the crystal frame (it turns with each grain).
fn model() -> String {
    format!(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\n\
         model = \"zener-above-1\"\na_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\n\
         [geometry]\nmoments = \"parallel-bond\"\n[grains]\ncount = 5\nseed = 2\n\
         [manybody]\nkind = \"cubic\"\nc11 = {:e}\nc12 = {:e}\nc44 = {:e}\n",
        D.0, D.1, D.2
    )
}

/// The textbook cubic [`D`] turned by Q (D'_ijkl = Q_ia Q_jb Q_kc Q_ld D_abcd, the tests'
/// explicit rotation `common::reference::rotate4`): independent of the library's rotation.
fn rotated_cubic(q: &Mat3) -> Stiffness6 {
    rotate4(cubic4(D.0, D.1, D.2), q)
}

/// The lines `g D11 … D66` of `manybody-grains.txt`, parsed here: D by grain id.
fn grain_file(path: &Path) -> Vec<(usize, Stiffness6)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            assert_eq!(w.len(), 22, "{l}");
            let mut d = Stiffness6::zeros();
            let mut k = 1;
            for a in 0..6 {
                for b in a..6 {
                    d[(a, b)] = w[k];
                    d[(b, a)] = w[k];
                    k += 1;
                }
            }
            (w[0] as usize, d)
        })
        .collect()
}

/// The export of the library (no plugin needed: the path is only written into the deck):
/// every grain's D in `manybody-grains.txt` is rotate(D, gᵀ) of its orientation g (explicit
/// rotation, 1e-12 of max |D|), read back by `read_grain_tensors` to the same bits as the
/// term's; data.lmp's molecule IDs are grain + 1; params.lmp gives `manybody/grains`; stock
/// bpm/rotational is refused naming the plugin route, and without orientations the
/// export is refused.
#[test]
fn exported_grain_tensors_are_d_turned_into_each_grain() {
    use anisobond::export::lammps::{
        export_lammps, read_grain_tensors, LammpsBondStyle, LammpsOptions, GRAIN_TENSORS,
    };
    let dir = tmp();
    let pk = packing(dir.path(), 300);
    let model = write(dir.path(), "model.toml", &model());
    let asm = Assembly::from_files(&pk, &model).unwrap();
    let grains = asm.grains().expect("the model's grains").clone();
    assert_eq!(grains.len(), 5);
    let plugin = LammpsOptions {
        bond_style: LammpsBondStyle::Anisobond {
            plugin: PathBuf::from("/nowhere/anisobond_lammps.so"),
        },
        manybody: asm.model.manybody.clone(),
        grains: Some(grains.grain.clone()),
        grain_orientations: Some(grains.orientation.clone()),
        ..Default::default()
    };
    let out = dir.path().join("deck");
    std::fs::create_dir(&out).unwrap();
    let e = export_lammps(&out, &asm.packing, &asm.bonds, &asm.springs, &plugin).unwrap();
    assert!(e.files.contains(&out.join(GRAIN_TENSORS)), "{:?}", e.files);
    let written = grain_file(&out.join(GRAIN_TENSORS));
    assert_eq!(written.len(), grains.len());
    let scale = D.0.abs().max(D.1.abs()).max(D.2.abs());
    for (g, d) in &written {
        let want = rotated_cubic(&grains.orientation[*g].transpose());
        let dev = (d - want).amax();
        assert!(
            dev <= 1e-12 * scale,
            "grain {g}: {dev:e} Pa off rotate(D, gᵀ)"
        );
    }
    // The grains differ from each other (so a plugin using one D for all would be wrong).
    let spread = (written[0].1 - written[1].1).amax();
    assert!(
        spread > 0.05 * scale,
        "grains 0 and 1 have nearly one D: {spread:e}"
    );
    // The file's upper triangles read back to the term's bit for bit (the plugin takes D
    // symmetric from them; the library's rotation leaves the lower triangle within rounding).
    let term = asm.manybody().unwrap().unwrap();
    let back = read_grain_tensors(&out.join(GRAIN_TENSORS)).unwrap();
    assert_eq!(back.len(), term.tensors().len());
    for (g, (b, t)) in back.iter().zip(term.tensors()).enumerate() {
        for a in 0..6 {
            for c in a..6 {
                assert_eq!(
                    b[(a, c)].to_bits(),
                    t[(a, c)].to_bits(),
                    "grain {g} D{a}{c}"
                );
                assert_eq!(b[(c, a)], b[(a, c)]);
            }
        }
    }
    let params = std::fs::read_to_string(out.join("params.lmp")).unwrap();
    assert!(
        params.contains("variable manybody index \"manybody/grains manybody-grains.txt manybody/measure green-lagrange manybody/degenerate exclude"),
        "{params}"
    );
    let data = std::fs::read_to_string(out.join("data.lmp")).unwrap();
    let atoms = data.split("Atoms # bpm/sphere").nth(1).unwrap();
    let mol: Vec<u64> = atoms
        .lines()
        .filter(|l| !l.trim().is_empty())
        .take(asm.packing.len())
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    let want: Vec<u64> = grains.grain.iter().map(|&g| u64::from(g) + 1).collect();
    assert_eq!(mol, want);
    // Without orientations the per-grain D cannot be made.
    let out2 = dir.path().join("no-orientations");
    std::fs::create_dir(&out2).unwrap();
    let o = LammpsOptions {
        grain_orientations: None,
        ..plugin.clone()
    };
    let err = export_lammps(&out2, &asm.packing, &asm.bonds, &asm.springs, &o).unwrap_err();
    assert!(matches!(err, anisobond::Error::Invalid(_)), "{err}");
    // Stock bpm/rotational (route a), by the CLI: refused naming the plugin route.
    let out3 = dir.path().join("route-a");
    let msg = fails(&mut super::export::export_cmd(&pk, &model, &[], &out3));
    assert!(msg.contains("--bond-style anisobond"), "{msg}");
    assert!(!out3.exists());
}

/// The polycrystal's plugin deck exported by the CLI into `dir/deck`, with `perturbed.lmp`:
/// the assembly, the deck's folder and the perturbed positions.
fn exported(l: &super::plugin::Lammps, dir: &Path) -> (Assembly, PathBuf, Vec<anisobond::Vec3>) {
    let pk = packing(dir, 300);
    let model = write(dir, "model.toml", &model());
    let out = dir.join("deck");
    let stdout = succeeds(&mut export_plugin(&pk, &model, &l.so, &out));
    assert!(out.join("manybody-grains.txt").is_file(), "{stdout}");
    let asm = Assembly::from_files(&pk, &model).unwrap();
    let y = write_perturbed(&out, &asm);
    (asm, out, y)
}

/// At a strained and perturbed state the plugin's forces and energy with the per-grain term
/// minus without it are the library's `ManyBody::evaluate` of the term with a D per grain
/// (1e-10), and differ clearly from the single crystal's term.
#[test]
fn plugin_forces_with_a_d_per_grain_are_the_librarys() {
    let Some(l) = lammps("plugin_grains_forces") else {
        return;
    };
    let dir = tmp();
    let (asm, out, y) = exported(&l, dir.path());
    let cell = asm.packing.cell.unwrap().lengths;
    let term = asm.manybody().unwrap().unwrap();
    assert_eq!(term.tensors().len(), 5);
    let tail = |name: &str| {
        format!(
            "include perturbed.lmp\ndump d all custom 1 {name}.dump id fx fy fz\n\
             dump_modify d sort id format float %.17g\nrun 0\n\
             print \"anisobond-ebond $(v_e:%.17g)\"\n"
        )
    };
    std::fs::write(out.join("on.lmp"), deck(Some(""), cell, &tail("on"))).unwrap();
    std::fs::write(out.join("off.lmp"), deck(None, cell, &tail("off"))).unwrap();
    let log_on = run(&l, &out, "on.lmp", 1);
    let log_off = run(&l, &out, "off.lmp", 1);
    assert!(
        log_on.contains("D per grain from manybody-grains.txt"),
        "{log_on}"
    );
    let h = strain();
    let lib = term
        .evaluate(&term.branch_vectors(&y, &h).unwrap())
        .unwrap();
    let single = manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let lib_single = single
        .evaluate(&single.branch_vectors(&y, &h).unwrap())
        .unwrap();
    let (on, off) = (
        dump_rows(&out.join("on.dump")),
        dump_rows(&out.join("off.dump")),
    );
    let f_max = lib.forces.iter().fold(0.0_f64, |m, f| m.max(f.amax()));
    let (mut worst, mut vs_single) = (0.0_f64, 0.0_f64);
    for (p, (f_lib, f_one)) in lib.forces.iter().zip(&lib_single.forces).enumerate() {
        let (a, b) = (&on[&(p as u64 + 1)], &off[&(p as u64 + 1)]);
        for c in 0..3 {
            worst = worst.max(((a[c] - b[c]) - f_lib[c]).abs());
            vs_single = vs_single.max((f_lib[c] - f_one[c]).abs());
        }
    }
    let e = numbers(&log_on, "anisobond-ebond")[0] - numbers(&log_off, "anisobond-ebond")[0];
    let e_rel = (e - lib.energy).abs() / lib.energy.abs();
    eprintln!(
        "per-grain term: max |f_on − f_off − f_lib| / max |f_lib| = {:.2e} (max {f_max:.3e} N); \
         energy {e:.9e} J vs {:.9e} J ({e_rel:.2e}); single crystal's forces differ by {:.2e}",
        worst / f_max,
        lib.energy,
        vs_single / f_max
    );
    assert!(f_max > 0.0 && lib.energy > 0.0);
    assert!(worst < 1e-10 * f_max, "forces: {:e}", worst / f_max);
    assert!(e_rel < 1e-10, "energy: {e_rel:e}");
    assert!(
        vs_single > 1e-2 * f_max,
        "the grains change nothing: {vs_single:e}"
    );
}

/// 300 damped steps from the perturbed state: two processes end at the positions and forces
/// of one within 1e-10; a restart file written after 200 steps and read on two processes
/// continues to the same state (the grain file is read again, no new reference is taken).
#[test]
fn plugin_grains_two_processes_equal_one_and_restart() {
    let Some(l) = lammps("plugin_grains_np2_restart") else {
        return;
    };
    let dir = tmp();
    let (asm, out, y0) = exported(&l, dir.path());
    let cell = asm.packing.cell.unwrap().lengths;
    let dump = |name: &str| {
        format!(
            "write_dump all custom {name}.dump id xu yu zu fx fy fz modify sort id format float \
             %.17g\n"
        )
    };
    let tail = |name: &str| {
        format!(
            "include perturbed.lmp\nrun 0\n{}run 200\nwrite_restart {name}.restart\nrun 100\n{}",
            dump(&format!("{name}-start")),
            dump(name)
        )
    };
    for (name, np) in [("np1", 1), ("np2", 2)] {
        std::fs::write(
            out.join(format!("{name}.lmp")),
            deck(Some(""), cell, &tail(name)),
        )
        .unwrap();
        run(&l, &out, &format!("{name}.lmp"), np);
    }
    let second = format!(
        "include params.lmp\nplugin load ${{plugin}}\nread_restart np1.restart\n\
         comm_modify vel yes cutoff ${{cut}}\nneighbor ${{skin}} bin\n\
         fix integrate all nve/bpm/sphere\nrun 100\n{}",
        dump("restarted")
    );
    std::fs::write(out.join("second.lmp"), second).unwrap();
    let log = run(&l, &out, "second.lmp", 2);
    assert!(
        !log.contains("many-body reference of"),
        "a new reference after the restart:\n{log}"
    );
    let f_start = dump_rows(&out.join("np1-start.dump"))
        .values()
        .fold(0.0_f64, |m, r| r.iter().fold(m, |m, v| m.max(v.abs())));
    let one = dump_rows(&out.join("np1.dump"));
    let mut u_max = 0.0_f64;
    for (p, y) in y0.iter().enumerate() {
        let r = &one[&(p as u64 + 1)];
        for c in 0..3 {
            u_max = u_max.max((r[c] - y[c]).abs());
        }
    }
    assert!(u_max > 0.0 && f_start > 0.0);
    for (name, tol_x, tol_f) in [("np2", 1e-10, 1e-10), ("restarted", 1e-8, 1e-8)] {
        let other = dump_rows(&out.join(format!("{name}.dump")));
        assert_eq!(other.len(), one.len());
        let (mut dx, mut df) = (0.0_f64, 0.0_f64);
        for (id, ra) in &one {
            let rb = &other[id];
            for c in 0..3 {
                dx = dx.max((ra[c] - rb[c]).abs());
                df = df.max((ra[3 + c] - rb[3 + c]).abs());
            }
        }
        eprintln!(
            "{name} vs np1: max |Δx| / max |u| = {:.2e} (max |u| {u_max:.3e} m), max |Δf| / max \
             |f_start| = {:.2e}",
            dx / u_max,
            df / f_start
        );
        assert!(dx < tol_x * u_max, "{name} positions: {:e}", dx / u_max);
        assert!(df < tol_f * f_start, "{name} forces: {:e}", df / f_start);
    }
}

/// `validate lammps --np 2` of the polycrystal with the term (plugin route): every check
/// passes (LAMMPS against the relaxed tensor with the per-grain term within 1e-4, np 2
/// against np 1 within the default 5e-5, which the run meets with room: it is printed), and
/// that reference differs from the single crystal's term on the same packing by far more
/// than the tolerance.
#[test]
fn validate_lammps_on_a_polycrystal_with_the_term_passes() {
    let Some(l) = lammps("validate_lammps_grains") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 300);
    let model = write(dir.path(), "model.toml", &model());
    let out = dir.path().join("validate");
    let report = validate_plugin_np2(&l, &pk, &model, &out);
    assert!(out.join("manybody-grains.txt").is_file());
    let checks = report["checks"].as_array().unwrap();
    let value = |id: &str| {
        checks
            .iter()
            .find(|c| c["id"] == id)
            .unwrap_or_else(|| panic!("no check {id}: {checks:?}"))["value"]
            .as_f64()
            .unwrap()
    };
    eprintln!(
        "tensor-lammps-relaxed {:.2e}, tensor-np2-np1 {:.2e}",
        value("tensor-lammps-relaxed"),
        value("tensor-np2-np1")
    );
    // The reference with the per-grain term against the single crystal's term.
    let asm = Assembly::from_files(&pk, &model).unwrap();
    let poly = relaxed_with_term(&asm, &asm.manybody().unwrap().unwrap());
    let one = manybody_term(&asm.model, &asm.packing, &asm.bonds);
    let gap = (poly - relaxed_with_term(&asm, &one)).amax() / poly.amax();
    eprintln!("relaxed tensor with the per-grain term vs one D for all: {gap:.2e} of max |C|");
    assert!(gap > 1e-2, "{gap:e}");
}

/// The plugin refuses misuse of `manybody/grains`, each with its reason: an atom whose grain
/// the file does not give (naming the atom and its molecule ID), both `manybody D…` and
/// `manybody/grains`, a short line and a grain given twice (naming the file and line).
#[test]
fn plugin_refuses_grain_misuse_with_the_reason() {
    let Some(l) = lammps("plugin_grains_misuse") else {
        return;
    };
    let dir = tmp();
    let (asm, out, _) = exported(&l, dir.path());
    let cell = asm.packing.cell.unwrap().lengths;
    let text = std::fs::read_to_string(out.join("manybody-grains.txt")).unwrap();
    let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    // Grain 4 left out; a line cut short; grain 0 twice.
    let without_4: String = lines
        .iter()
        .filter(|l| !l.starts_with("4 "))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(out.join("no4.txt"), without_4).unwrap();
    let short = lines[0].rsplit_once(' ').unwrap().0;
    std::fs::write(out.join("short.txt"), format!("{short}\n")).unwrap();
    std::fs::write(
        out.join("twice.txt"),
        format!("{}\n{}\n", lines[0], lines[0]),
    )
    .unwrap();
    assert!(
        asm.grains().unwrap().grain.contains(&4),
        "grain 4 has particles"
    );
    let one_d = "manybody 1e9 0 0 0 0 0 1e9 0 0 0 0 1e9 0 0 0 1e9 0 0 1e9 0 1e9";
    for (name, extra, expected) in [
        (
            "missing",
            " manybody/grains no4.txt".to_string(),
            "whose D manybody/grains no4.txt does not give".to_string(),
        ),
        (
            "both",
            format!(" {one_d} manybody/grains manybody-grains.txt"),
            "both given".to_string(),
        ),
        (
            "short",
            " manybody/grains short.txt".to_string(),
            "manybody/grains short.txt line 1".to_string(),
        ),
        (
            "twice",
            " manybody/grains twice.txt".to_string(),
            "line 2: grain 0 given twice".to_string(),
        ),
    ] {
        let file = format!("{name}.lmp");
        std::fs::write(out.join(&file), deck(Some(extra.as_str()), cell, "")).unwrap();
        let o = super::plugin::run_lmp(&l.lmp, &out, &file, 1);
        let text =
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name}: LAMMPS accepted it:\n{text}");
        assert!(
            text.contains(&expected),
            "{name}: expected `{expected}` in:\n{text}"
        );
        if name == "missing" {
            // The first atom of grain 4 on this one process is named, or another of its atoms.
            assert!(text.contains("(grain 4)"), "{text}");
        }
    }
}
