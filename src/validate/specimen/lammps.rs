//! LAMMPS' specimen test (BPM package): `in.specimen` reads the free specimen
//! (`boundary f f f`, `atom_style bpm/sphere`, `bond_style bpm/rotational` with one bond
//! type per bond, as `export lammps` route (a)), its end layers as atom types (2 bottom, 3
//! top, 4 and 5 the bottom's lateral supports), stores the bonds' reference state, moves
//! the top layer by `displace_atoms` (bpm/rotational is a total-form law: the bonds see
//! the displacement, not its path) and relaxes with the bonds' own damping and `fix viscous` in chunks until
//! the platen force settles. `bonded` platens: the layers are not integrated (all six DOFs
//! held: positions and orientations stay); `frictionless`: they are, with `fix setforce`
//! zeroing the axial force only (the supports' lateral forces too). The platen force is
//! `fix setforce`'s global vector: the force on the group before it is zeroed. The solve
//! uses bpm/rotational's midpoint contact point ([`LeverArm::HalfLength`]).

use super::{
    atom_lines, bond_lines_one_type_each, box_lines, num, platens_name, relax_in_chunks,
    remaining_change, specimen_mass, DeckPlan, DeckStart, EngineMeasurement, Launch, ScriptDeck,
    SpecimenTest,
};
use crate::bonds::{BondSet, BondStiffness};
use crate::homogenize::network::LeverArm;
use crate::packing::Packing;
use crate::specimen::{Platens, SpecimenReport};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// Default strain of LAMMPS' test: bpm/rotational takes its bond angles from acos, which
/// leaves √ε ≈ 1.5e-8 rad of rounding; at 1e-6 the stiffness came out 4.6e-4 off.
pub const STRAIN: f64 = 1e-5;

/// Sub-directory of the validation directory LAMMPS runs in.
pub const DIR: &str = "lammps-specimen";

/// Damping ratio ζ of every bond's normal, sliding, rolling and twisting damping.
pub const DAMPING_RATIO: f64 = 0.3;

/// Steps between two readings of the platen force.
pub const CHUNK_STEPS: u64 = 500;

/// Write `data.lmp` and `bond_coeffs.lmp`: atoms `id mol type diameter density x y z`
/// (type 1 free, 2 bottom layer, 3 top layer, 4 and 5 bottom supports), bond b of type
/// b + 1 with its own springs and damping (γ = 2ζ√(k m*) as `export lammps`).
fn write_inputs(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    types: &[u8],
    density: f64,
) -> Result<f64> {
    let n = packing.len();
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let margin = 2.0 * max_len;
    let mut s = format!(
        "LAMMPS data file written by anisobond {}: free specimen, {n} particles, {} bonds \
         (one bond type per bond)\n\n{n} atoms\n5 atom types\n{} bonds\n{} bond types\n\n",
        env!("CARGO_PKG_VERSION"),
        bonds.len(),
        bonds.len(),
        bonds.len()
    );
    s.push_str(&box_lines(packing, margin));
    s.push_str("\nAtoms # bpm/sphere\n\n");
    s.push_str(&atom_lines(packing, types, density, true));
    s.push_str("\nBonds\n\n");
    s.push_str(&bond_lines_one_type_each(bonds));
    crate::io::write_string_atomic(&dir.join("data.lmp"), &s)?;
    let mut c = String::from(
        "# bond_coeff TYPE k_r k_s k_t k_b f_rc f_sc tau_tc tau_bc gamma_n gamma_s gamma_r gamma_t\n\
         # k_r = anisobond k_n, k_s = k_s (N/m); k_t = k_tw, k_b = k_r (N·m/rad); limits 1e30;\n",
    );
    let _ = writeln!(
        c,
        "# damping ratio {DAMPING_RATIO} of each bond's own spring and reduced mass/inertia"
    );
    for b in 0..bonds.len() {
        let g = crate::export::lammps::bond_damping(packing, bonds, k, b, density, DAMPING_RATIO);
        let springs = crate::export::lammps::bond_coeff_springs(b + 1, k, b, num);
        let g = g.map(num);
        let _ = writeln!(c, "{springs} {} {} {} {}", g[0], g[1], g[2], g[3]);
    }
    crate::io::write_string_atomic(&dir.join("bond_coeffs.lmp"), &c)?;
    Ok(max_len)
}

/// The atom types of the specimen: the solve's layers, and for frictionless platens the
/// bottom's supports (one sphere's lateral translations, the farthest bottom sphere from it
/// its lateral translation across the line joining them), as the YADE test holds them.
/// Returns the types and the held lateral axis of the far support.
pub(super) fn atom_types(packing: &Packing, p: &SpecimenReport, axis: usize) -> (Vec<u8>, usize) {
    let mut types: Vec<u8> = p.layer.iter().map(|&l| 1 + l).collect();
    let bottom: Vec<usize> = (0..types.len()).filter(|&k| p.layer[k] == 1).collect();
    let lateral = [(axis + 1) % 3, (axis + 2) % 3];
    let Some(&a) = bottom.first() else {
        return (types, lateral[0]);
    };
    let xa = packing.positions[a];
    let far = bottom
        .iter()
        .copied()
        .max_by(|&u, &v| {
            (packing.positions[u] - xa)
                .norm()
                .total_cmp(&(packing.positions[v] - xa).norm())
        })
        .unwrap_or(a);
    let d = packing.positions[far] - xa;
    let (l0, l1) = (lateral[0].min(lateral[1]), lateral[0].max(lateral[1]));
    let block = if d[l1].abs() >= d[l0].abs() { l0 } else { l1 };
    types[a] = 4;
    if far != a {
        types[far] = 5;
    }
    (types, block)
}

/// The deck's comment header: the test, how to run it, the atom types, how it loads and
/// relaxes.
fn deck_header(test: &SpecimenTest) -> String {
    let ax = test.axis;
    format!(
        "# anisobond → LAMMPS (BPM package) specimen test, {} platens along {}.\n\
         # Run:  lmp -in in.specimen   (or mpirun -np N lmp -in in.specimen)\n\
         # Atom types: 1 free, 2 bottom layer (held), 3 top layer (moved), 4 and 5 bottom supports.\n\
         # The top layer is displaced by `delta` towards the bottom at once after the bonds'\n\
         # reference state is stored (bpm/rotational: total form), then the bonds' own damping\n\
         # relaxes the specimen in chunks of `chunk_steps` until the platen force's estimated\n\
         # remaining relative change (geometric extrapolation of the last two changes) and\n\
         # |F_top - F_bottom| / F_top are below `settle`, or `max_chunks`. Writes lammps-platen.json.\n",
        platens_name(test.platens),
        ["x", "y", "z"][ax]
    )
}

/// The deck: read, group, store the reference state, displace, hold, relax in chunks.
fn deck(
    test: &SpecimenTest,
    delta: f64,
    dt: f64,
    viscous: f64,
    cut: f64,
    far_block: usize,
    max_chunks: u64,
) -> String {
    let ax = test.axis;
    let component = |values: [&str; 3]| values.join(" ");
    let along = |v: &str, other: &str| {
        let mut c = [other; 3];
        c[ax] = v;
        component(c)
    };
    let displacement = along("$(-v_delta)", "0");
    let (integrated, layer_force) = match test.platens {
        Platens::Bonded => ("mobile", component(["0.0"; 3])),
        Platens::Frictionless => ("all", along("0.0", "NULL")),
    };
    let mut support_a = ["0.0"; 3];
    support_a[ax] = "NULL";
    let mut support_far = ["NULL"; 3];
    support_far[far_block] = "0.0";
    let index = ax + 1;
    let mut s = deck_header(test);
    let _ = write!(
        s,
        "variable dt index {}\nvariable delta index {}\nvariable settle index {}\n\
         variable viscous index {}\n\
         variable chunk_steps index {CHUNK_STEPS}\nvariable max_chunks index {max_chunks}\n\
         units si\ndimension 3\nboundary f f f\natom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\nnewton on off\n\
         comm_modify vel yes cutoff {}\nread_data data.lmp\n\
         bond_style bpm/rotational break no smooth no\ninclude bond_coeffs.lmp\n\
         pair_style zero {}\npair_coeff * *\nneighbor {} bin\n\
         neigh_modify every 1 delay 0 check yes\n\
         group bottom type 2 4 5\ngroup top type 3\ngroup support_a type 4\n\
         group support_far type 5\ngroup layers union bottom top\n\
         group mobile subtract all layers\n\
         timestep ${{dt}}\n\
         fix integrate {integrated} nve/bpm/sphere\n\
         run 0\n\
         displace_atoms top move {displacement} units box\n\
         fix ftop top setforce {layer_force}\n\
         fix fbottom bottom setforce {layer_force}\n",
        num(dt),
        num(delta),
        num(test.settle),
        num(viscous),
        num(cut),
        num(cut),
        num(0.1 * cut)
    );
    if test.platens == Platens::Frictionless {
        let _ = write!(
            s,
            "fix fsupport_a support_a setforce {}\nfix fsupport_far support_far setforce {}\n",
            component(support_a),
            component(support_far)
        );
    }
    let _ = writeln!(s, "fix damp {integrated} viscous ${{viscous}}");
    let _ = write!(
        s,
        "variable ft equal f_ftop[{index}]\nvariable fb equal -f_fbottom[{index}]\n"
    );
    relax_in_chunks(&mut s, "$(v_ft:%.17g)", "$(v_fb:%.17g)");
    s.push_str(
        "print \"\"\"{\"force_top\": ${f3}, \"force_bottom\": ${b3}, \"f1\": ${f1}, \"f2\": ${f2}, \"steps\": $(step), \"dt\": ${dt}, \"delta\": ${delta}}\"\"\" file lammps-platen.json\n",
    );
    s
}

/// Run `lmp -in in.specimen` in `dir` on `np` processes (the `mpirun` beside `lmp`, else on
/// PATH); returns the wall time (s).
fn run_lmp(dir: &Path, lmp: &Path, np: usize) -> Result<f64> {
    run_lmp_input(dir, lmp, np, "in.specimen", "specimen")
}

/// LAMMPS' version from the first line (`LAMMPS (…)`) of the log `log-np{np}.lammps` that
/// [`run_lmp_input`] keeps in `dir`, else `unknown`.
pub(crate) fn log_version(dir: &Path, np: usize) -> String {
    let log =
        crate::io::read_to_string(&dir.join(format!("log-np{np}.lammps"))).unwrap_or_default();
    log.lines()
        .next()
        .and_then(|l| l.strip_prefix("LAMMPS ("))
        .and_then(|l| l.split(')').next())
        .unwrap_or("unknown")
        .to_string()
}

/// Run `lmp -in INPUT` in `dir` on `np` processes (log `log-npN.lammps`); a failure is
/// [`Error::EngineFailed`] naming `test` and LAMMPS' ERROR lines. Returns the wall time (s).
pub(crate) fn run_lmp_input(
    dir: &Path,
    lmp: &Path,
    np: usize,
    input: &str,
    test: &str,
) -> Result<f64> {
    let bin = lmp.parent().unwrap_or(Path::new("."));
    let mut cmd = if np > 1 {
        let beside = bin.join("mpirun");
        let mut c = Command::new(if beside.is_file() {
            beside
        } else {
            "mpirun".into()
        });
        c.args(["-np", &np.to_string()]).arg(lmp);
        c
    } else {
        Command::new(lmp)
    };
    let lib = bin.parent().unwrap_or(Path::new(".")).join("lib");
    let ld = match std::env::var_os("LD_LIBRARY_PATH") {
        Some(v) if !v.is_empty() => {
            let mut s = lib.into_os_string();
            s.push(":");
            s.push(v);
            s
        }
        _ => lib.into_os_string(),
    };
    let log = format!("log-np{np}.lammps");
    let t0 = std::time::Instant::now();
    let out = cmd
        .args(["-in", input, "-log", &log, "-screen", "none"])
        .env("LD_LIBRARY_PATH", ld)
        .current_dir(dir)
        .output()
        .map_err(|e| Error::engine("LAMMPS", format!("cannot start {}: {e}", lmp.display())))?;
    if !out.status.success() {
        let text = crate::io::read_to_string(&dir.join(&log)).unwrap_or_default();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let said: Vec<&str> = text
            .lines()
            .chain(stderr.lines())
            .filter(|l| l.contains("ERROR"))
            .map(|l| l.trim())
            .collect::<Vec<_>>();
        return Err(Error::engine(
            "LAMMPS",
            format!(
                "the {test} test on {np} process(es) failed ({}): {}",
                out.status,
                if said.is_empty() {
                    "no ERROR line (see the log)".to_string()
                } else {
                    said.join(" | ")
                }
            ),
        ));
    }
    Ok(t0.elapsed().as_secs_f64())
}

/// Read `lammps-platen.json` of a run on `np` processes.
fn read_result(
    dir: &Path,
    np: usize,
    layers: &(Vec<usize>, Vec<usize>),
    seconds: f64,
) -> Result<EngineMeasurement> {
    let path = dir.join("lammps-platen.json");
    let text = crate::io::read_to_string(&path)?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::engine("LAMMPS", format!("{}: {e}", path.display())))?;
    let renamed = dir.join(format!("lammps-platen-np{np}.json"));
    std::fs::rename(&path, &renamed).map_err(|e| Error::io(&renamed, e))?;
    let num = |k: &str| {
        v[k].as_f64().ok_or_else(|| {
            Error::engine("LAMMPS", format!("{}: no number `{k}`", renamed.display()))
        })
    };
    let (f1, f2, f3) = (num("f1")?, num("f2")?, num("force_top")?);
    let remaining = remaining_change(f1, f2, f3);
    let version = log_version(dir, np);
    Ok(EngineMeasurement {
        version,
        processes: np,
        bottom: layers.0.clone(),
        top: layers.1.clone(),
        displacement: num("delta")?,
        force_top: f3,
        force_bottom: num("force_bottom")?,
        time_step: num("dt")?,
        steps: v["steps"]
            .as_u64()
            .ok_or_else(|| Error::engine("LAMMPS", format!("{}: no steps", renamed.display())))?,
        remaining,
        how: format!(
            "end layers as atom types; top displaced at once (displace_atoms), bonded: layers \
             not integrated, frictionless: fix setforce on the axial force; bonds' damping \
             ratio {DAMPING_RATIO} and fix viscous, chunks of {CHUNK_STEPS} steps"
        ),
        seconds,
        dir: dir.to_path_buf(),
    })
}

/// LAMMPS' specimen test (on one process, and on two with `two_processes`): the deck
/// `write_deck_files` writes, run by `run_lmp` and read by `read_result`.
pub(in crate::validate) const DECK: ScriptDeck = ScriptDeck {
    engine: "lammps",
    shown: "LAMMPS",
    strain: STRAIN,
    lever_arm: LeverArm::HalfLength,
    dir: DIR,
    deck_file: "in.specimen",
    write: write_deck_files,
    run_once: |start, launch, _, np| {
        let seconds = run_lmp(&start.dir, &launch.program, np)?;
        read_result(&start.dir, np, &start.layers, seconds)
    },
};

/// Write the test's `data.lmp` and `bond_coeffs.lmp` into its directory; returns the deck
/// `in.specimen` with the plan's time step and δ and the viscous damping.
fn write_deck_files(start: &DeckStart, launch: &Launch, plan: &DeckPlan) -> Result<String> {
    let DeckStart { test, asm, .. } = start;
    let (types, far_block) = &start.types;
    let packing = &asm.packing;
    let max_len = write_inputs(
        &start.dir,
        packing,
        &asm.bonds,
        &asm.springs,
        types,
        launch.density,
    )?;
    // Viscous damping of the free spheres' translations (fix viscous), chosen to damp the
    // specimen's slow modes: γ = m̄ × the plan's damping rate.
    let viscous = specimen_mass(packing, launch.density) / packing.len() as f64 * plan.damping_rate;
    Ok(deck(
        test,
        plan.delta,
        plan.dt,
        viscous,
        1.6 * max_len,
        *far_block,
        test.relax_chunks(CHUNK_STEPS),
    ))
}
