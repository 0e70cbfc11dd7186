//! Issue 32 (item 5, LAMMPS): bonds that break. A bonded simple-cubic bar (3 × 3 × 8 spheres
//! of R = 1 mm, periodic along its axis z, free sides: `boundary f f p`), generated here as a
//! LAMMPS data file, with a plane of weakness across it (its 9 bonds take the joint's
//! tensile strength), exported from a model with a `[strength]` table and pulled in direct
//! tension by the real `lmp` (the box stretched at a constant rate, atoms remapped: every
//! axial bond carries the same force k_n·d·ε). The peak force across a section, −σ_zz·V/L_z,
//! before the first bond breaks equals bonds per section × f_rc of the joint bonds within one
//! load step (closed form: F* = 9·σ_j·π R², load step 9·k_n·d·Δε), and exactly the 9 joint
//! bonds break (LAMMPS' own bond count), for route (a) (`bond_style bpm/rotational break
//! yes`) and the plugin (`bond_style anisobond … break yes`, whose strengths survive a
//! restart), on one and two processes. Quantised types (`--types`, a fully periodic block)
//! break at their quantised limits within the reported quantisation error. Without a
//! `[strength]` table (or with `--no-break`) the decks are those of a model without one.

use super::export::export_cmd;
use super::plugin::{export_plugin, lammps, run_lmp, Lammps};
use crate::common::lammps::lmp;
use crate::common::{succeeds, tmp, write};
use std::path::{Path, PathBuf};

const R: f64 = 1e-3;
const NX: usize = 3;
const NY: usize = 3;
const NZ: usize = 8;
const KN: f64 = 2e6;

const ELASTIC: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n";

/// Intact bonds σ_t = 5 MPa; the plane z = 8 mm (between the 4th and 5th layers) is a joint
/// of σ_t = 2 MPa.
const STRENGTH: &str = "[strength]\n[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
    [[strength.planes]]\nnormal = [0, 0, 1]\nspacing = 1.0\noffset = 8.0e-3\n\
    tensile = 2e6\ncohesion = 4e6\n";

/// Cross-anisotropic about z (axial bonds 8 MPa, lateral 5 MPa) with the same joint: three
/// distinct sets of limits, for quantising into two types.
const CROSS_STRENGTH: &str = "[strength]\naxis = [0, 0, 1]\n\
    [strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
    [strength.along]\ntensile = 8e6\ncohesion = 1.2e7\n\
    [[strength.planes]]\nnormal = [0, 0, 1]\nspacing = 1.0\noffset = 8.0e-3\n\
    tensile = 2e6\ncohesion = 4e6\n";

/// f_rc of a bond of tensile strength `sigma`: σ·π R² (bond radius R, π̂ = π).
fn f_rc(sigma: f64) -> f64 {
    sigma * std::f64::consts::PI * R * R
}

/// The bar as a LAMMPS `atom_style bpm/sphere` data file (no Bonds: the model bonds it),
/// spheres at (i+1, j+1, k+½)·2R in a box 2R wider than the bar on each side (`free`) or
/// exactly one lattice period wide (periodic block).
fn bar(dir: &Path, free_sides: bool) -> PathBuf {
    let d = 2.0 * R;
    let (margin, shift) = if free_sides {
        (2.0 * d, d)
    } else {
        (0.0, 0.5 * d)
    };
    let mut s = format!(
        "bar for anisobond\n\n{} atoms\n1 atom types\n\n0 {} xlo xhi\n0 {} ylo yhi\n0 {} zlo zhi\n\nAtoms # bpm/sphere\n\n",
        NX * NY * NZ,
        NX as f64 * d + margin,
        NY as f64 * d + margin,
        NZ as f64 * d
    );
    let mut id = 0;
    for k in 0..NZ {
        for j in 0..NY {
            for i in 0..NX {
                id += 1;
                s.push_str(&format!(
                    "{id} 1 1 {} 2600 {} {} {}\n",
                    2.0 * R,
                    i as f64 * d + shift,
                    j as f64 * d + shift,
                    (k as f64 + 0.5) * d
                ));
            }
        }
    }
    write(dir, "bar.data", &s)
}

/// The tension run: the exported data, bonds and pair style (breakage.lmp), the box
/// stretched along z at a constant velocity giving the strain `de` per step (atoms
/// remapped), `steps` steps; per step `step F_section bonds` to tension.txt. With
/// `restart_at`, a restart file after that many steps and the rest in `continue.lmp`
/// (read_restart, on any number of processes), which writes `end.restart` at its end.
fn tension_decks(
    plugin: bool,
    boundary: &str,
    de: f64,
    steps: usize,
    restart_at: Option<usize>,
) -> (String, String) {
    let load = if plugin {
        "plugin load ${plugin}\n"
    } else {
        ""
    };
    let newton = if plugin { "on on" } else { "on off" };
    let head = format!(
        "include params.lmp\n{load}units si\ndimension 3\nboundary {boundary}\natom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\nnewton {newton}\ncomm_modify vel yes cutoff ${{cut}}\n\
         read_data ${{data}} nocoeff\ninclude breakage.lmp\n"
    );
    let run = "neighbor ${skin} bin\nneigh_modify every 1 delay 0 check yes\n\
         fix integrate all nve/bpm/sphere\ntimestep ${dt}\n\
         compute p all pressure NULL virial\nvariable fz equal -c_p[3]*vol/lz\n\
         variable st equal step\nvariable nb equal bonds\nthermo_style custom step v_fz bonds\n";
    let pull =
        format!("variable vz equal {de:e}*lz/dt\nfix pull all deform 1 z vel ${{vz}} remap x\n");
    let print = "fix out all print 1 \"${st} ${fz} ${nb}\" append tension.txt screen no\n";
    match restart_at {
        None => (
            format!("{head}{run}run 0\n{pull}{print}run {steps}\n"),
            String::new(),
        ),
        Some(first) => (
            format!("{head}{run}run 0\n{pull}{print}run {first}\nwrite_restart half.restart\n"),
            // Fixes are not kept by restart files: the same box velocity again (of the
            // initial box length, `lz0`, substituted by the caller).
            format!(
                "include params.lmp\n{load}read_restart half.restart\ncomm_modify vel yes cutoff ${{cut}}\n\
                 {run}variable vz equal {de:e}*${{lz0}}/dt\nfix pull all deform 1 z vel ${{vz}} remap x\n{print}\
                 run {}\nwrite_restart end.restart\n",
                steps - first
            ),
        ),
    }
}

/// Rows `(step, force, bonds)` of tension.txt.
fn rows(dir: &Path) -> Vec<(u64, f64, u64)> {
    let text = std::fs::read_to_string(dir.join("tension.txt")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (
                w[0].parse().unwrap(),
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
            )
        })
        .collect()
}

/// The peak force before the first bond broke and the number of bonds broken.
fn peak_and_broken(rows: &[(u64, f64, u64)]) -> (f64, u64) {
    let initial = rows[0].2;
    let intact = rows.iter().take_while(|r| r.2 == initial);
    let peak = intact.map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
    let last = rows.last().unwrap().2;
    assert!(last < initial, "no bond broke: {initial} bonds at the end");
    (peak, initial - last)
}

fn run_ok(lmp: &Path, dir: &Path, input: &str, np: usize) {
    let out = run_lmp(lmp, dir, input, np);
    assert!(
        out.status.success(),
        "{input} on {np} processes failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The strain step for a break at the limit `f` between steps 400 and 401 (mid-step: a
/// break exactly at a step would be decided by rounding).
fn strain_step(f: f64) -> f64 {
    f / (KN * 2.0 * R) / 400.5
}

/// Check the run in `dir` against F* = 9·f (f the breaking bonds' f_rc): the peak within
/// one load step below F*, `broken` bonds broken. Returns the peak.
fn check_peak(dir: &Path, f: f64, de: f64, broken: u64, what: &str) -> f64 {
    let (peak, n) = peak_and_broken(&rows(dir));
    let section = (NX * NY) as f64;
    let exact = section * f;
    let step = section * KN * 2.0 * R * de;
    eprintln!(
        "{what}: peak {peak:.9e} N, closed form {exact:.9e} N (relative {:.2e}, load step {:.2e}); {n} bonds broke",
        (exact - peak) / exact,
        step / exact
    );
    assert!(
        peak < exact * (1.0 + 1e-12) && peak > exact - step * (1.0 + 1e-9),
        "{what}: peak {peak} vs {exact} (step {step})"
    );
    assert_eq!(n, broken, "{what}: bonds broken");
    peak
}

#[test]
fn route_a_bar_in_tension_peaks_at_bonds_per_section_times_f_rc() {
    let Some(lmp) = lmp("route_a_bar_in_tension") else {
        return;
    };
    let dir = tmp();
    let d = dir.path();
    let data = bar(d, true);
    let model = write(d, "model.toml", &format!("{ELASTIC}{STRENGTH}"));
    let out = d.join("deck");
    let said = succeeds(&mut export_cmd(
        &data,
        &model,
        &["--boundary", "f f p"],
        &out,
    ));
    assert!(said.contains("break yes, smooth no"), "{said}");
    // Every bond its own type: the 9 joint bonds f_rc = 2 MPa·πR², the others 5 MPa·πR².
    let coeffs = std::fs::read_to_string(out.join("bond_coeffs.lmp")).unwrap();
    let f: Vec<f64> = coeffs
        .lines()
        .filter(|l| l.starts_with("bond_coeff"))
        .map(|l| l.split_whitespace().nth(6).unwrap().parse().unwrap())
        .collect();
    assert_eq!(f.len(), 3 * NX * NY * NZ - (NX + NY) * NZ);
    let joint = f
        .iter()
        .filter(|&&v| (v - f_rc(2e6)).abs() < 1e-12 * v)
        .count();
    let intact = f
        .iter()
        .filter(|&&v| (v - f_rc(5e6)).abs() < 1e-12 * v)
        .count();
    assert_eq!((joint, intact), (NX * NY, f.len() - NX * NY));
    let deck = std::fs::read_to_string(out.join("in.elastic")).unwrap();
    assert!(deck.contains("include breakage.lmp") && !deck.contains("break no"));
    let breakage = std::fs::read_to_string(out.join("breakage.lmp")).unwrap();
    assert!(breakage.contains("bond_style bpm/rotational break yes smooth ${smooth}"));
    assert!(breakage.contains("pair_style granular"));

    let (de, peaks) = tension_on_one_and_two(&lmp, &out, false, "route (a)");

    check_contact_after_break(&lmp, &out, false, 1, de, peaks[0]);
}

/// The bar of `out` (the plugin's deck or route (a)'s) pulled at the strain step of
/// f_rc(2 MPa) on one process and on two, each peak checked ([`check_peak`], `what` naming
/// the route); the two peaks agree within 1e-9. The strain step and the peaks.
fn tension_on_one_and_two(lmp: &Path, out: &Path, plugin: bool, what: &str) -> (f64, Vec<f64>) {
    let de = strain_step(f_rc(2e6));
    let (deck, _) = tension_decks(plugin, "m m p", de, 500, None);
    std::fs::write(out.join("tension.lmp"), deck).unwrap();
    let mut peaks = Vec::new();
    for np in [1, 2] {
        let _ = std::fs::remove_file(out.join("tension.txt"));
        run_ok(lmp, out, "tension.lmp", np);
        peaks.push(check_peak(
            out,
            f_rc(2e6),
            de,
            (NX * NY) as u64,
            &format!("{what}, -np {np}"),
        ));
    }
    assert!((peaks[0] - peaks[1]).abs() <= 1e-9 * peaks[0], "{peaks:?}");
    (de, peaks)
}

/// After the break: held (the crack open, the halves relax: no tension across a broken
/// pair), then pushed back past the original length and held: the broken pairs touch again
/// (pair_style granular, k_c = the bonds' k_n) and the section carries the compression of 8
/// springs k_n in series per column, 9·k_n·d·e at box strain −e. `peak` is the tension run's;
/// run on `np` processes.
fn check_contact_after_break(lmp: &Path, out: &Path, plugin: bool, np: usize, de: f64, peak: f64) {
    let what = format!("{}, -np {np}", if plugin { "plugin" } else { "route (a)" });
    let (deck, _) = tension_decks(plugin, "m m p", de, 500, None);
    let contact = deck.replace(
        "run 500\n",
        "run 500\nunfix pull\nrun 3000\nprint \"anisobond-open $(v_fz:%.17g) $(bonds)\"\n\
         variable vc equal -${vz}*1.5\nfix push all deform 1 z vel ${vc} remap x\nrun 500\n\
         unfix push\nrun 3000\nprint \"anisobond-closed $(v_fz:%.17g) $(lz:%.17g) $(bonds)\"\n",
    );
    assert_ne!(contact, deck);
    std::fs::write(out.join("contact.lmp"), contact).unwrap();
    let _ = std::fs::remove_file(out.join("tension.txt"));
    let run = run_lmp(lmp, out, "contact.lmp", np);
    let text = String::from_utf8_lossy(&run.stdout).to_string();
    assert!(run.status.success(), "{text}");
    let line = |key: &str| -> Vec<f64> {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .unwrap_or_else(|| panic!("no {key}:\n{text}"))
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect()
    };
    let open = line("anisobond-open ");
    let closed = line("anisobond-closed ");
    let lz0 = NZ as f64 * 2.0 * R;
    let e = 1.0 - closed[1] / lz0;
    let expected = -((NX * NY) as f64) * KN * 2.0 * R * e;
    eprintln!(
        "{what}: after the break: held open {:.3e} N ({:.1e} of the peak); pushed to strain -{e:.3e}: {:.9e} N vs closed form {expected:.9e} N ({:.1e})",
        open[0],
        open[0].abs() / peak,
        closed[0],
        (closed[0] - expected).abs() / expected.abs()
    );
    assert!(
        e > 0.0,
        "the box was not pushed past its length: {closed:?}"
    );
    assert!(
        open[0].abs() < 1e-2 * peak,
        "tension across the crack: {open:?}"
    );
    assert!(
        (closed[0] - expected).abs() < 1e-6 * expected.abs(),
        "{closed:?} vs {expected}"
    );
    let intact = (3 * NX * NY * NZ - (NX + NY) * NZ - NX * NY) as f64;
    assert_eq!((open[1], closed[2]), (intact, intact));
}

#[test]
fn plugin_bar_in_tension_breaks_the_same_and_keeps_its_strengths_across_a_restart() {
    let Some(Lammps { lmp, so }) = lammps("plugin_bar_in_tension") else {
        return;
    };
    let dir = tmp();
    let d = dir.path();
    let data = bar(d, true);
    let model = write(d, "model.toml", &format!("{ELASTIC}{STRENGTH}"));
    let out = d.join("deck");
    succeeds(export_plugin(&data, &model, &so, &out).args(["--boundary", "f f p"]));
    let table = std::fs::read_to_string(out.join("bond-strengths.csv")).unwrap();
    assert_eq!(table.lines().count(), 1 + 3 * NX * NY * NZ - (NX + NY) * NZ);
    let breakage = std::fs::read_to_string(out.join("breakage.lmp")).unwrap();
    assert!(
        breakage.contains("break yes strengths bond-strengths.csv")
            && breakage.contains("pair_style granular"),
        "{breakage}"
    );

    let (de, peaks) = tension_on_one_and_two(&lmp, &out, true, "plugin");
    // The broken pairs become granular contacts, also when the partner is on the other
    // process (the plugin sends the broken pairs to every process).
    for np in [1, 2] {
        check_contact_after_break(&lmp, &out, true, np, de, peaks[0]);
    }

    // Halfway on one process, a restart file, the rest on two: the same peak and the same
    // 9 bonds broken (each bond's limits come back with its state); a restart written after
    // the break keeps the broken bonds broken.
    let lz0 = NZ as f64 * 2.0 * R;
    let (first, second) = tension_decks(true, "m m p", de, 500, Some(200));
    std::fs::write(out.join("first.lmp"), first).unwrap();
    std::fs::write(
        out.join("continue.lmp"),
        second.replace("${lz0}", &format!("{lz0:e}")),
    )
    .unwrap();
    let _ = std::fs::remove_file(out.join("tension.txt"));
    run_ok(&lmp, &out, "first.lmp", 1);
    run_ok(&lmp, &out, "continue.lmp", 2);
    let restarted = check_peak(
        &out,
        f_rc(2e6),
        de,
        (NX * NY) as u64,
        "plugin, restarted on -np 2",
    );
    assert!(
        (restarted - peaks[0]).abs() <= 1e-9 * peaks[0],
        "{restarted} vs {}",
        peaks[0]
    );
    std::fs::write(
        out.join("after.lmp"),
        "include params.lmp\nplugin load ${plugin}\nread_restart end.restart\n\
         comm_modify vel yes cutoff ${cut}\nfix integrate all nve/bpm/sphere\n\
         thermo_style custom step bonds\nrun 0\nprint \"anisobond-bonds $(bonds)\"\n",
    )
    .unwrap();
    let after = run_lmp(&lmp, &out, "after.lmp", 2);
    let text = String::from_utf8_lossy(&after.stdout).to_string();
    assert!(after.status.success(), "{text}");
    let intact = 3 * NX * NY * NZ - (NX + NY) * NZ - NX * NY;
    assert!(
        text.contains(&format!("anisobond-bonds {intact}")),
        "{text}"
    );
}

#[test]
fn quantised_types_break_at_their_limits_within_the_reported_error() {
    let Some(lmp) = lmp("quantised_types_break") else {
        return;
    };
    let dir = tmp();
    let d = dir.path();
    let data = bar(d, false);
    let model = write(d, "model.toml", &format!("{ELASTIC}{CROSS_STRENGTH}"));
    let out = d.join("deck");
    let said = succeeds(&mut export_cmd(
        &data,
        &model,
        &["--boundary", "p p p", "--types", "2"],
        &out,
    ));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bond-types.json")).unwrap())
            .unwrap();
    assert_eq!(report["exact"], false, "{report}");
    assert_eq!(report["distinct_springs"], 3, "{report}");
    let reported = report["limit_max_relative_error"]["f_rc"].as_f64().unwrap();
    assert!(
        said.contains("quantised jointly with the breaking limits"),
        "{said}"
    );

    // Each bond's quantised f_rc (its type's, from bond_coeffs.lmp and data.lmp) against its
    // exact one (axial 8 MPa, lateral 5 MPa, joint 2 MPa, by the bond's direction and place).
    let coeffs = std::fs::read_to_string(out.join("bond_coeffs.lmp")).unwrap();
    let type_f: Vec<f64> = coeffs
        .lines()
        .filter(|l| l.starts_with("bond_coeff"))
        .map(|l| l.split_whitespace().nth(6).unwrap().parse().unwrap())
        .collect();
    let text = std::fs::read_to_string(out.join("data.lmp")).unwrap();
    let z_of = |id: usize| ((id - 1) / (NX * NY)) as f64 * 2.0 * R + R;
    let bonds = text.split("\nBonds\n").nth(1).unwrap();
    let mut worst = 0.0f64;
    let mut axial_q = Vec::new();
    for line in bonds.lines().filter(|l| !l.trim().is_empty()) {
        let w: Vec<usize> = line
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let (ty, i, j) = (w[1], w[2], w[3]);
        let (zi, zj) = (z_of(i), z_of(j));
        let axial = zi != zj;
        let crosses =
            axial && (zi.min(zj) < 8e-3 && zi.max(zj) > 8e-3 && (zi - zj).abs() < 3.0 * R);
        let exact = f_rc(if crosses {
            2e6
        } else if axial {
            8e6
        } else {
            5e6
        });
        let q = type_f[ty - 1];
        worst = worst.max((q - exact).abs() / exact);
        if axial {
            axial_q.push(q);
        }
    }
    eprintln!("quantised f_rc: largest relative error {worst:.6e}, reported {reported:.6e}");
    assert!(
        (worst - reported).abs() <= 1e-12 * reported.max(1e-300),
        "{worst} vs {reported}"
    );

    // Every axial bond carries the same force: the weakest quantised f_rc breaks first, all
    // axial bonds of that limit at once; peak = bonds per section × that limit.
    let weakest = axial_q.iter().copied().fold(f64::INFINITY, f64::min);
    let at_weakest = axial_q.iter().filter(|&&q| q == weakest).count() as u64;
    let de = strain_step(weakest);
    let (deck, _) = tension_decks(false, "p p p", de, 440, None);
    std::fs::write(out.join("tension.lmp"), deck).unwrap();
    run_ok(&lmp, &out, "tension.lmp", 1);
    check_peak(&out, weakest, de, at_weakest, "route (a) quantised, -np 1");
}

#[test]
fn without_strength_or_with_no_break_the_decks_are_unchanged() {
    let dir = tmp();
    let d = dir.path();
    let data = bar(d, true);
    let plain = write(d, "plain.toml", ELASTIC);
    let strong = write(d, "strong.toml", &format!("{ELASTIC}{STRENGTH}"));
    let a = d.join("plain");
    let b = d.join("no-break");
    succeeds(&mut export_cmd(&data, &plain, &["--boundary", "f f p"], &a));
    succeeds(&mut export_cmd(
        &data,
        &strong,
        &["--boundary", "f f p", "--no-break"],
        &b,
    ));
    let names = crate::common::entries(&a);
    assert_eq!(names, crate::common::entries(&b));
    assert!(!names.iter().any(|n| n == "breakage.lmp"), "{names:?}");
    for n in &names {
        assert_eq!(
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
            "{n} differs"
        );
    }
    let deck = std::fs::read_to_string(a.join("in.elastic")).unwrap();
    assert!(deck.contains("bond_style bpm/rotational break no smooth no"));
    let coeffs = std::fs::read_to_string(a.join("bond_coeffs.lmp")).unwrap();
    assert!(coeffs
        .lines()
        .filter(|l| l.starts_with("bond_coeff"))
        .all(|l| l.contains(" 1e30 1e30 1e30 1e30 ")));
    // --smooth without a [strength] table is refused.
    let err = crate::common::fails(&mut export_cmd(
        &data,
        &plain,
        &["--boundary", "f f p", "--smooth"],
        &d.join("x"),
    ));
    assert!(err.contains("no [strength] table"), "{err}");
    assert!(!d.join("x").exists());
    // A zero strength would be a zero critical load, which bpm/rotational divides by.
    let zero = write(
        d,
        "zero.toml",
        &format!("{ELASTIC}[strength]\n[strength.bond]\ntensile = 0.0\ncohesion = 1e7\n"),
    );
    let err = crate::common::fails(&mut export_cmd(
        &data,
        &zero,
        &["--boundary", "f f p"],
        &d.join("y"),
    ));
    assert!(err.contains("f_rc = 0") && err.contains("bond 0"), "{err}");
    assert!(!d.join("y").exists());
}

/// `quantise_joint` (no LAMMPS): exact when the bonds have at most K distinct rows of springs
/// and limits; otherwise each type keeps Σ l²·k_n and Σ l²·k_s of its bonds (the affine
/// weights) and the sum of each limit (plain means), recomputed here by brute force; two
/// groups of limits far apart with the same springs split into exactly those groups; a limit
/// ≤ 0 is refused naming the bond.
#[test]
fn joint_quantisation_keeps_each_types_sums_and_splits_separated_limits() {
    use anisobond::bonds::{affine_weights, quantise_joint};
    use anisobond::bonds::{BondSet, BondStiffness};
    use anisobond::Vec3;
    let n = 40;
    let mut bonds = BondSet::default();
    for b in 0..n {
        let l = 1e-3 * (1.0 + 0.01 * (b % 7) as f64);
        bonds.push(b as u32, (b + 1) as u32, Vec3::new(0.0, 0.0, l), [0, 0, 0]);
    }
    let k = BondStiffness {
        radius: vec![1e-3; n],
        kn: (0..n).map(|b| 1e6 * (1.0 + 0.1 * (b % 5) as f64)).collect(),
        ks: (0..n).map(|b| 3e5 * (1.0 + 0.2 * (b % 3) as f64)).collect(),
        kr: vec![0.0; n],
        ktw: vec![0.0; n],
    };
    let limits: Vec<[f64; 4]> = (0..n)
        .map(|b| {
            let f = 10.0 * (1.0 + 0.05 * (b % 4) as f64);
            [f, 2.0 * f, 1e-3 * f, 2e-3 * f]
        })
        .collect();
    let w = affine_weights(&bonds);

    // Exact: K ≥ the distinct rows (lcm of 5, 3, 7 and 4 cycles over 40 bonds: all distinct).
    let (t, fl) = quantise_joint(&bonds, &k, &limits, n, &w).unwrap();
    assert!(t.exact);
    for (b, f) in limits.iter().enumerate() {
        let ty = t.type_of[b] as usize;
        assert_eq!(fl[ty], *f);
        assert_eq!(t.springs[ty], [k.kn[b], k.ks[b], k.kr[b], k.ktw[b]]);
    }

    // Quantised into 3: per type, Σ l² k_n, Σ l² k_s and Σ f_c unchanged.
    let (t, fl) = quantise_joint(&bonds, &k, &limits, 3, &w).unwrap();
    assert!(!t.exact && t.springs.len() <= 3);
    for (ty, (springs, type_limits)) in t.springs.iter().zip(&fl).enumerate() {
        let members: Vec<usize> = (0..n).filter(|&b| t.type_of[b] as usize == ty).collect();
        let l2 = |b: usize| bonds.length[b].powi(2);
        let sum = |f: &dyn Fn(usize) -> f64| members.iter().map(|&b| f(b)).sum::<f64>();
        let kn = sum(&|b| l2(b) * k.kn[b]);
        assert!((kn - sum(&|b| l2(b)) * springs[0]).abs() < 1e-12 * kn);
        let ks = sum(&|b| l2(b) * k.ks[b]);
        assert!((ks - sum(&|b| l2(b)) * springs[1]).abs() < 1e-12 * ks);
        for c in 0..4 {
            let f = sum(&|b| limits[b][c]);
            assert!((f - members.len() as f64 * type_limits[c]).abs() < 1e-12 * f);
        }
    }

    // Same springs, two groups of limits (1 and 100): two types, exactly the groups.
    let same = BondStiffness {
        radius: vec![1e-3; n],
        kn: vec![1e6; n],
        ks: vec![3e5; n],
        kr: vec![0.0; n],
        ktw: vec![0.0; n],
    };
    let split: Vec<[f64; 4]> = (0..n)
        .map(|b| {
            let f = if b % 2 == 0 { 1.0 } else { 100.0 } * (1.0 + 1e-3 * (b % 3) as f64);
            [f, f, f, f]
        })
        .collect();
    let (t, fl) = quantise_joint(&bonds, &same, &split, 2, &w).unwrap();
    for b in 0..n {
        let q = fl[t.type_of[b] as usize][0];
        assert!(
            (q - split[b][0]).abs() < 2e-3 * split[b][0],
            "bond {b}: {q}"
        );
    }
    assert_ne!(t.type_of[0], t.type_of[1]);

    let mut bad = limits.clone();
    bad[7][1] = 0.0;
    let e = quantise_joint(&bonds, &k, &bad, 3, &w).unwrap_err();
    assert!(matches!(e, anisobond::Error::Invalid(_)), "{e}");
    assert!(e.to_string().contains("bond 7"), "{e}");
}

/// The plugin's `break` keyword refused where it would mislead: `break yes` without a
/// strength table, a strength table or `record` with `break no`, and `break yes` beside a
/// pair style under special bonds that drop bonded pairs from the neighbour lists (a broken
/// pair would meet the pair style only at the next rebuild); `--smooth` writes
/// bpm/rotational's `smooth yes`.
#[test]
fn plugin_break_misuse_is_refused_with_the_reason() {
    let Some(Lammps { lmp, so }) = lammps("plugin_break_misuse") else {
        return;
    };
    let dir = tmp();
    let d = dir.path();
    let data = bar(d, true);
    let model = write(d, "model.toml", &format!("{ELASTIC}{STRENGTH}"));
    let out = d.join("deck");
    succeeds(export_plugin(&data, &model, &so, &out).args(["--boundary", "f f p"]));
    let breakage = std::fs::read_to_string(out.join("breakage.lmp")).unwrap();
    let style =
        "bond_style anisobond ${springs} damping ${damping} break yes strengths bond-strengths.csv";
    assert!(
        breakage.contains(style) && breakage.contains("pair_style granular"),
        "{breakage}"
    );
    for (name, text, expected, special) in [
        (
            "no-table",
            breakage.replace(style, "bond_style anisobond ${springs} break yes"),
            "needs `strengths",
            false,
        ),
        (
            "no-break",
            breakage.replace(
                style,
                "bond_style anisobond ${springs} break no strengths bond-strengths.csv",
            ),
            "is for `break yes`",
            false,
        ),
        (
            "record",
            breakage.replace(
                style,
                "bond_style anisobond ${springs} damping ${damping} record broken.txt",
            ),
            "is for `break yes` (it lists the broken bonds)",
            false,
        ),
        // Bonded pairs dropped from the neighbour lists (coul 0): a broken pair would meet
        // the pair style only at the next rebuild.
        (
            "special",
            breakage.clone(),
            "needs `special_bonds lj 0 1 1 coul 1 1 1`",
            true,
        ),
    ] {
        std::fs::write(out.join("breakage.lmp"), &text).unwrap();
        let (mut deck, _) = tension_decks(true, "m m p", 1e-6, 1, None);
        if special {
            deck = deck.replace(
                "special_bonds lj 0 1 1 coul 1 1 1",
                "special_bonds lj 0 1 1",
            );
        }
        let input = format!("{name}.lmp");
        std::fs::write(out.join(&input), deck).unwrap();
        let run = run_lmp(&lmp, &out, &input, 1);
        let said = String::from_utf8_lossy(&run.stdout).to_string()
            + &String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{name}: expected a refusal\n{said}");
        assert!(said.contains(expected), "{name}: {said}");
    }

    let smooth = d.join("smooth");
    let said = succeeds(&mut export_cmd(
        &data,
        &model,
        &["--boundary", "f f p", "--smooth"],
        &smooth,
    ));
    assert!(said.contains("break yes, smooth yes"), "{said}");
    let params = std::fs::read_to_string(smooth.join("params.lmp")).unwrap();
    assert!(params.contains("variable smooth index yes"), "{params}");
}
