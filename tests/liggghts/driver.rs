//! The LIGGGHTS driver (`anisobond-liggghts`, pair_style anisobond) against independent
//! references: closed-form bond forces, the Voigt sum, the exact relaxed tensor, and itself
//! under MPI. Skipped with a reason only when LIGGGHTS/MPI/make are absent and CI is unset.

use crate::common::liggghts::*;
use anisobond::export::liggghts::{
    columns_from_cases, export_liggghts, read_stress_history, run_liggghts, tensor_from_cases,
    DeckOptions,
};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];

const ISO_MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 1.0e12\nshear = 4.0e11\n\
    [geometry]\nconvention = \"area\"\nmoments = \"parallel-bond\"\n";

#[test]
fn element_test_matches_relaxed_tensor() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let launch = driver_launch(None);
    let b = bonded(500, 7, ISO_MODEL);
    let dir = fresh_dir("element");
    let opts = DeckOptions {
        relax_steps: std::env::var("RELAX")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(10_000),
        damping: std::env::var("DAMP")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.02),
        ..DeckOptions::default()
    };
    let sum = export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).expect("export");
    let t0 = std::time::Instant::now();
    run_liggghts(&launch, &dir, "anisobond.in").expect("driver run");
    eprintln!("run took {:?}", t0.elapsed());
    let h = read_stress_history(&dir.join("stress_history.txt")).expect("history");
    let c = tensor_from_cases(&h, &sum.case_end_steps).expect("tensor");
    let relaxed =
        relaxed_tensor(&b.packing, &b.bonds, &b.k, &RelaxedOptions::default()).expect("relaxed");
    eprintln!(
        "driver:\n{c:.4e}\nrelaxed:\n{:.4e}\naffine:\n{:.4e}",
        relaxed.c, relaxed.c_affine
    );
    let d = rel_diff(&c, &relaxed.c);
    eprintln!("relative difference {d:.3e}");
    assert!(
        d < 5e-3,
        "driver tensor differs from the relaxed tensor by {d:.3e} (> 0.5 %)"
    );
}

/// Two particles along x: R = 1 mm, centre distance d0 = 2.1 mm (gap 0.1 mm, mid-gap arms
/// r = 1.05 mm), k_n = 1e6, k_s = 4e5 N/m, k_r = 0.3, k_tw = 0.2 N·m/rad.
const KN: f64 = 1.0e6;
const KS: f64 = 4.0e5;
const KR: f64 = 0.3;
const KTW: f64 = 0.2;
const ARM: f64 = 1.05e-3;
const DT: f64 = 1.0e-7;

fn two_particle_run(name: &str, table_length: f64, actions: &str) -> Result<Vec<[f64; 6]>, String> {
    two_particle_run_spin(name, table_length, [0.0; 3], actions)
}

/// Run the two-particle deck; particle 2 starts with spin `omega2` (rad/s).
fn two_particle_run_spin(
    name: &str,
    table_length: f64,
    omega2: [f64; 3],
    actions: &str,
) -> Result<Vec<[f64; 6]>, String> {
    let dir = fresh_dir(name);
    std::fs::write(
        dir.join("two.data"),
        format!("two particles\n\n2 atoms\n1 atom types\n\n0 0.01 xlo xhi\n0 0.01 ylo yhi\n0 0.01 zlo zhi\n\n\
         Atoms # granular\n\n1 1 0.002 2500 0.004 0.005 0.005\n2 1 0.002 2500 0.0061 0.005 0.005\n\n\
         Velocities\n\n1 0 0 0 0 0 0\n2 0 0 0 {} {} {}\n",
        omega2[0], omega2[1], omega2[2]
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("bonds.csv"),
        format!("i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz\n0,1,1,0,0,{table_length},0.001,{KN},{KS},{KR},{KTW},0,0,0\n"),
    )
    .unwrap();
    let deck = format!(
        "units si\natom_style granular\natom_modify map array\nboundary p p p\nnewton on\n\
         communicate single vel yes\nread_data two.data\npair_style anisobond table bonds.csv\n\
         pair_coeff * *\nneighbor 0.0002 bin\ntimestep {DT}\nfix integ all nve/sphere\n\
         group two id 2\n{actions}\n"
    );
    std::fs::write(dir.join("two.in"), deck).unwrap();
    run_liggghts(&driver_launch(None), &dir, "two.in").map_err(|e| e.to_string())?;
    // Last snapshot of dump.txt: id fx fy fz tqx tqy tqz, sorted by id.
    let text = std::fs::read_to_string(dir.join("dump.txt")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let last = lines
        .iter()
        .rposition(|l| l.starts_with("ITEM: ATOMS"))
        .unwrap();
    let mut rows: Vec<(u32, [f64; 6])> = lines[last + 1..]
        .iter()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            (v[0] as u32, [v[1], v[2], v[3], v[4], v[5], v[6]])
        })
        .collect();
    rows.sort_by_key(|r| r.0);
    Ok(rows.into_iter().map(|r| r.1).collect())
}

const DUMP: &str = "dump d all custom 1 dump.txt id fx fy fz tqx tqy tqz\ndump_modify d format \"%d %.17g %.17g %.17g %.17g %.17g %.17g\"";

fn assert_close(got: &[f64; 6], want: [f64; 6], scale: f64, tol: f64, what: &str) {
    for k in 0..6 {
        assert!(
            (got[k] - want[k]).abs() <= tol * scale,
            "{what}: component {k}: got {:?}, want {:?}",
            got,
            want
        );
    }
}

#[test]
fn two_particle_normal_and_shear_forces_equal_k_delta() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    // Displace particle 2 by δ = (1, 2, −3)·1e-8 m after the bond is created.
    let (dx, dy, dz) = (1e-8, 2e-8, -3e-8);
    let f = two_particle_run(
        "two_shear",
        2.1e-3,
        &format!("run 0\ndisplace_atoms two move {dx} {dy} {dz}\n{DUMP}\nrun 0"),
    )
    .unwrap();
    // Force on 1 = (k_n δx, k_s δy, k_s δz); torque on each = (r n) × F, n = x̂ (to O(δ/d)).
    let f1 = [
        KN * dx,
        KS * dy,
        KS * dz,
        0.0,
        -ARM * KS * dz,
        ARM * KS * dy,
    ];
    let f2 = [
        -KN * dx,
        -KS * dy,
        -KS * dz,
        0.0,
        -ARM * KS * dz,
        ARM * KS * dy,
    ];
    assert_close(&f[0], f1, KN * 3e-8, 1e-4, "particle 1");
    assert_close(&f[1], f2, KN * 3e-8, 1e-4, "particle 2");
}

#[test]
fn two_particle_bending_and_twisting_equal_k_theta_and_setup_does_not_advance() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let w = 3.0; // rad/s: rotation per step θ = w·dt
    let th = w * DT;
    // Bending: particle 2 spins about y. Relative rotation θ ŷ loads k_r; the contact point of
    // 2 moves by θ ŷ × (−r x̂) = r θ ẑ, loading k_s.
    //   force on 1 = k_s r θ ẑ; torque on 1 = (k_r − k_s r²) θ ŷ; on 2: −(k_r + k_s r²) θ ŷ.
    let want1 = [
        0.0,
        0.0,
        KS * ARM * th,
        0.0,
        (KR - KS * ARM * ARM) * th,
        0.0,
    ];
    let want2 = [
        0.0,
        0.0,
        -KS * ARM * th,
        0.0,
        -(KR + KS * ARM * ARM) * th,
        0.0,
    ];
    let scale = KR * th;
    let f = two_particle_run_spin(
        "two_bend",
        2.1e-3,
        [0.0, w, 0.0],
        &format!("run 1\n{DUMP}\nrun 0"),
    )
    .unwrap();
    assert_close(&f[0], want1, scale, 1e-9, "bending, particle 1");
    assert_close(&f[1], want2, scale, 1e-9, "bending, particle 2");
    // A second `run 0` (another setup force call) must give the same loads.
    let f = two_particle_run_spin(
        "two_bend_setup",
        2.1e-3,
        [0.0, w, 0.0],
        &format!("run 1\nrun 0\nrun 0\n{DUMP}\nrun 0"),
    )
    .unwrap();
    assert_close(
        &f[0],
        want1,
        scale,
        1e-9,
        "bending after extra setups, particle 1",
    );
    // Twisting: spin about the bond axis loads k_tw only.
    let f = two_particle_run_spin(
        "two_twist",
        2.1e-3,
        [w, 0.0, 0.0],
        &format!("run 1\n{DUMP}\nrun 0"),
    )
    .unwrap();
    assert_close(
        &f[0],
        [0.0, 0.0, 0.0, KTW * th, 0.0, 0.0],
        KTW * th,
        1e-9,
        "twist, particle 1",
    );
    assert_close(
        &f[1],
        [0.0, 0.0, 0.0, -KTW * th, 0.0, 0.0],
        KTW * th,
        1e-9,
        "twist, particle 2",
    );
}

#[test]
fn bond_table_that_does_not_fit_the_box_is_an_error_with_the_message() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let e = two_particle_run("two_wrong", 2.2e-3, &format!("{DUMP}\nrun 0")).unwrap_err();
    assert!(
        e.contains("bond table"),
        "message should name the mismatch: {e}"
    );
}

#[test]
fn affine_normal_strains_give_the_voigt_normal_block() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    // Particles follow the box (no integration). Only the normal block C_ab, a, b ≤ 3 is
    // compared: without moment equilibrium the Love stress Σ F⊗l is not symmetric, and the
    // LIGGGHTS virial keeps one triangle (xy = Σ l_x F_y), while normal stresses Σ F_i l_i
    // under normal strains are unambiguous. k_s enters them (C11 ∝ k_n n⁴ + k_s(n² − n⁴)).
    let b = bonded(300, 11, ISO_MODEL);
    let dir = fresh_dir("affine");
    let opts = DeckOptions {
        affine: true,
        deform_steps: 20,
        relax_steps: 0,
        output_every: 20,
        shear: false,
        ..DeckOptions::default()
    };
    let sum = export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
    run_liggghts(&driver_launch(None), &dir, "anisobond.in").unwrap();
    let h = read_stress_history(&dir.join("stress_history.txt")).unwrap();
    let cols = columns_from_cases(&h, &sum.case_end_steps).unwrap();
    let v = anisobond::homogenize::voigt_tensor(&b.bonds, &b.k, b.packing.volume());
    let mut k0 = b.k.clone();
    k0.ks.iter_mut().for_each(|x| *x = 0.0);
    let v0 = anisobond::homogenize::voigt_tensor(&b.bonds, &k0, b.packing.volume());
    let scale = v.abs().max();
    let (mut d, mut d0) = (0.0f64, 0.0f64);
    for (a, col) in cols.iter().enumerate() {
        for r in 0..3 {
            d = d.max((col[r] - v[(r, a)]).abs() / scale);
            d0 = d0.max((col[r] - v0[(r, a)]).abs() / scale);
        }
    }
    eprintln!("affine driver vs Voigt normal block: {d:.3e} (vs k_s = 0: {d0:.3e})");
    assert!(
        d < 1e-4,
        "affine driver vs Voigt normal block: {d:.3e}\n{cols:?}\n{v:.4e}"
    );
    assert!(d0 > 1e-2, "the shear springs must matter in this check");
}

#[test]
fn mpi_two_processes_reproduce_one_process() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let b = bonded(500, 5, ISO_MODEL);
    // Undamped dynamics: deformation waves run through the box and across the processor
    // boundary.
    // Normal cases only: LIGGGHTS 3.8 makes no ghosts for triclinic boxes under MPI.
    let opts = DeckOptions {
        damping: 0.0,
        deform_steps: 300,
        relax_steps: 200,
        output_every: 50,
        shear: false,
        ..DeckOptions::default()
    };
    let mut hist = Vec::new();
    for np in [1usize, 2] {
        let dir = fresh_dir(&format!("mpi{np}"));
        export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
        run_liggghts(&driver_launch(Some(np)), &dir, "anisobond.in").unwrap();
        hist.push(read_stress_history(&dir.join("stress_history.txt")).unwrap());
    }
    assert_eq!(hist[0].step, hist[1].step);
    assert!(hist[0].step.len() >= 30);
    let (worst, scale) = history_difference(&hist[0].stress, &hist[1].stress);
    eprintln!("np1 vs np2: max |Δσ| / max |σ| = {:.3e}", worst / scale);
    assert!(
        worst <= 1e-9 * scale,
        "np 1 vs np 2 differ by {:.3e} relative",
        worst / scale
    );
}

#[test]
fn bonds_computed_through_the_bridge_equal_the_bond_table() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    // `pair_style anisobond model MODEL PACKING` bonds and springs the packing through the
    // bridge; it must reproduce the run from the exported bond table exactly.
    let b = bonded(200, 13, ISO_MODEL);
    let opts = DeckOptions {
        affine: true,
        deform_steps: 10,
        relax_steps: 0,
        output_every: 10,
        shear: false,
        ..DeckOptions::default()
    };
    let mut hist = Vec::new();
    for via_model in [false, true] {
        let dir = fresh_dir(&format!("bridge_{via_model}"));
        export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
        if via_model {
            std::fs::write(dir.join("model.toml"), ISO_MODEL).unwrap();
            anisobond::packing::write_packing(&dir.join("packing.txt"), &b.packing).unwrap();
            let deck = std::fs::read_to_string(dir.join("anisobond.in")).unwrap();
            let deck = deck.replace("table bonds.csv", "model model.toml packing.txt");
            assert!(deck.contains("pair_style anisobond model"));
            std::fs::write(dir.join("anisobond.in"), deck).unwrap();
        }
        let launch = driver_launch(None);
        run_liggghts(&launch, &dir, "anisobond.in").unwrap();
        hist.push(read_stress_history(&dir.join("stress_history.txt")).unwrap());
    }
    assert!(!hist[0].stress.is_empty());
    assert_eq!(hist[0], hist[1]);
}

#[test]
fn missing_partner_under_mpi_is_an_error_not_a_silent_result() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    // LIGGGHTS 3.8 builds no ghost atoms for a triclinic box under MPI: the driver must stop
    // with its message instead of dropping the bonds that cross the processor boundary.
    let b = bonded(200, 17, ISO_MODEL);
    let dir = fresh_dir("mpi_triclinic");
    let opts = DeckOptions {
        affine: true,
        deform_steps: 10,
        relax_steps: 0,
        output_every: 10,
        ..DeckOptions::default()
    };
    export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
    let launch = driver_launch(Some(2));
    let started = std::time::Instant::now();
    let e = run_liggghts(&launch, &dir, "anisobond.in")
        .unwrap_err()
        .to_string();
    // Refused at once, with the real cause and the alternatives (not a lost partner later).
    assert!(
        e.contains("no ghost atoms for a triclinic box under MPI")
            && e.contains("--no-shear")
            && e.contains("LAMMPS"),
        "message: {e}"
    );
    let header = std::fs::read_to_string(dir.join("anisobond.in")).unwrap();
    assert!(header.contains("one process only"), "{header}");
    eprintln!("refused after {:.2} s", started.elapsed().as_secs_f64());
}

#[test]
fn run_sh_never_falls_back_silently_and_refuses_mpi_shear() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let b = bonded(200, 23, ISO_MODEL);
    let run = |dir: &std::path::Path, path: &str, args: &[&str]| {
        std::process::Command::new("sh")
            .arg(dir.join("run.sh"))
            .args(args)
            .env("PATH", path)
            .output()
            .unwrap()
    };
    let system = "/usr/local/bin:/usr/bin:/bin";
    let six = fresh_dir("run_sh_six");
    export_liggghts(&six, &b.packing, &b.bonds, &b.k, &DeckOptions::default()).unwrap();
    // No driver on PATH: an error naming how to build it, not the stock deck.
    let o = run(&six, system, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("make -C cpp driver"),
        "{err}"
    );
    assert!(!six.join("stress_history.txt").exists());
    // The six-case deck under MPI: refused before LIGGGHTS starts.
    let with_driver = format!("{}:{system}", driver().parent().unwrap().display());
    let o = run(&six, &with_driver, &["2"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("triclinic"), "{err}");
    // The normal-case deck says so in its header.
    let three = fresh_dir("run_sh_three");
    let opts = DeckOptions {
        shear: false,
        ..DeckOptions::default()
    };
    export_liggghts(&three, &b.packing, &b.bonds, &b.k, &opts).unwrap();
    let header = std::fs::read_to_string(three.join("anisobond.in")).unwrap();
    assert!(header.contains("three normal load cases") && !header.contains("six load cases"));
}

#[test]
fn restart_file_keeps_the_bonds_and_their_history() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    // Deform, let the packing vibrate, write a restart, go on; a second run from the restart
    // file must continue with the same stresses (bond state restored from the restart).
    let b = bonded(200, 19, ISO_MODEL);
    let dir = fresh_dir("restart");
    export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &DeckOptions::default()).unwrap();
    let common = "newton on\ncommunicate single vel yes\npair_style anisobond table bonds.csv\n\
        pair_coeff * *\nneighbor 0.0001 bin\nneigh_modify delay 0\ntimestep 2e-8\n\
        fix integrate all nve/sphere\ncompute p all pressure thermo_temp virial\n\
        variable step equal step\nvariable s11 equal -c_p[1]\nvariable s12 equal -c_p[4]\n";
    let a = format!(
        "units si\natom_style granular\natom_modify map array\nboundary p p p\n\
         read_data packing.data\n{common}fix d all deform 1 x scale 1.0001 remap x\nrun 100\nunfix d\n\
         run 100\nwrite_restart bonds.restart\n\
         fix out all print 50 \"${{step}} ${{s11}} ${{s12}}\" file a.txt screen no\nrun 200\n"
    );
    let bdeck = format!(
        "atom_modify map array\nread_restart bonds.restart\n{common}\
         fix out all print 50 \"${{step}} ${{s11}} ${{s12}}\" file b.txt screen no\nrun 200\n"
    );
    std::fs::write(dir.join("a.in"), a).unwrap();
    std::fs::write(dir.join("b.in"), bdeck).unwrap();
    let launch = driver_launch(None);
    run_liggghts(&launch, &dir, "a.in").unwrap();
    run_liggghts(&launch, &dir, "b.in").unwrap();
    let read = |f: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(dir.join(f))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let (ra, rb) = (read("a.txt"), read("b.txt"));
    assert_eq!(ra.len(), 4);
    assert_eq!(
        ra, rb,
        "run from the restart file differs from the continuous run"
    );
    assert!(ra[0][1].abs() > 0.0, "the packing must be loaded");
}
