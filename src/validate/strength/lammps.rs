//! LAMMPS' strength test, route (a) (BPM package): `in.strength` reads the free bar
//! (`boundary f f f`, `atom_style bpm/sphere`, `bond_style bpm/rotational break yes smooth
//! no` with one bond type per bond: its springs, its critical loads f_rc f_sc τ_tc τ_bc from
//! the model's `[strength]` as `export lammps` writes them, and its damping), holds the
//! bottom layer (`fix move linear 0 0 0`), moves the top one (`fix move linear`), starts the
//! free spheres in the linear velocity field and integrates them (`nve/bpm/sphere`). The top
//! layer's force is printed every step; bpm/rotational records each broken bond
//! (`store/local … id1 id2 time`, written by `dump local`) in the same run. The integrator
//! runs law (d), [`crate::dem::laws::LammpsBpmLaw`], with the same springs, damping and
//! limits.
//!
//! The plugin (`--bond-style anisobond`, cpp/lammps/): the same bar, springs and limits per
//! bond from `bonds.csv` and `bond-strengths.csv` (`bond_style anisobond table bonds.csv
//! damping ζ break yes strengths bond-strengths.csv record broken.txt`, one bond type,
//! `newton on on`), its broken bonds from its own `record` (sorted on process 0, the same on
//! any process count). The plugin's bond is YADE's incremental cohesive bond at the midpoint
//! with bpm/rotational's dashpots and criterion (bond_anisobond.h): to first order in the
//! rotations it is law (d), which the integrator runs with the same springs, damping and
//! limits as for route (a).
//!
//! In compression a broken bond's pair (and any pair that comes into touch) becomes a
//! frictional contact, as in `export lammps`' decks with breakage: `pair_style granular`,
//! `hooke` k_n with no damping, `linear_history` k_t capped at μ·F_n
//! ([`super::contact_law`]); the integrator runs its [`crate::dem::Contacts`] with the same
//! law (a broken bond's pair with the bond's own springs: the same for equal springs). In
//! tension there are no contacts (`pair_style zero`), as before.

use super::{
    compare, order_breaks, reference, runs_per_process, Launch, Loading, Start, StrengthDetails,
    StrengthRun, StrengthTest,
};
use crate::dem::laws::{BpmCoefficients, BpmNormalize, LammpsBpmLaw};
use crate::dem::LawKind;
use crate::export::lammps::{
    bond_damping, bond_limits, write_strength_table, LammpsBondStyle, LammpsBreakage,
};
use crate::validate::harness::{Problem, Progress, Report};
use crate::validate::specimen::{atom_lines, bond_lines_one_type_each, box_lines, num};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Sub-directory of the validation directory LAMMPS runs in (route (a)).
pub const DIR: &str = "lammps-strength";

/// Sub-directory of the plugin's run (`--bond-style anisobond`).
pub const PLUGIN_DIR: &str = "lammps-plugin-strength";

/// Steps between two dumps of the broken bonds (bpm/rotational's `store/local` period).
const DUMP_EVERY: u64 = 100;

/// Run LAMMPS' strength test of `problem`'s free bar with `style` (route (a) or the plugin)
/// on each process count and the integrator's with law (d), and compare.
pub fn run(
    launch: &Launch,
    problem: &Problem,
    test: &StrengthTest,
    style: &LammpsBondStyle,
    progress: Progress,
) -> Result<Report<StrengthDetails>> {
    let plugin = match style {
        LammpsBondStyle::BpmRotational => None,
        LammpsBondStyle::Anisobond { plugin } => Some(plugin.as_path()),
    };
    let (packing, bonds, k) = (problem.packing, problem.bonds, problem.springs);
    let sub = if plugin.is_some() { PLUGIN_DIR } else { DIR };
    let start = Start::of("lammps", LawKind::LammpsBpm, sub, problem, launch, test)?;
    let (criteria, loading, dir) = (start.criteria, start.loading, start.dir);
    let breakage = LammpsBreakage {
        strengths: start.strengths,
        pi_hat: start.model.geometry.pi_hat,
        smooth: false,
    };
    let limits = bond_limits(k, &breakage)?;
    let dt = loading.time_step;
    let damping: Vec<[f64; 4]> = (0..bonds.len())
        .map(|b| bond_damping(packing, bonds, k, b, launch.density, test.damping_ratio))
        .collect();
    let types = loading.atom_types(packing.len());
    match plugin {
        None => write_inputs(&dir, problem, &types, launch.density, &limits, &damping)?,
        Some(_) => write_plugin_inputs(&dir, problem, &types, launch.density, &limits)?,
    }
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let steps = test.steps.div_ceil(DUMP_EVERY) * DUMP_EVERY;
    let test = StrengthTest { steps, ..*test };
    crate::io::write_string_atomic(
        &dir.join("in.strength"),
        &deck(&test, &loading, 1.6 * max_len, plugin)?,
    )?;
    let mut timings = Vec::new();
    let coeffs = bpm_coefficients(k, &damping);
    let law = Box::new(LammpsBpmLaw::new(coeffs, BpmNormalize::Absolute)?);
    let reference = reference(problem, law, criteria, launch.density, 0.0, &loading, &test)?;
    reference.record(&mut timings, progress);
    let who = if plugin.is_some() {
        "LAMMPS (bond_style anisobond)"
    } else {
        "LAMMPS"
    };
    let measured = runs_per_process(launch, "lammps", who, &mut timings, progress, |np| {
        for f in ["force.txt", "broken.txt"] {
            let _ = std::fs::remove_file(dir.join(f));
        }
        let seconds = crate::validate::specimen::lammps::run_lmp_input(
            &dir,
            &launch.program,
            np,
            "in.strength",
            "strength",
        )?;
        read_run(&dir, problem, np, &test, plugin.is_some(), seconds)
    })?;
    let engine = if plugin.is_some() {
        "lammps-plugin"
    } else {
        "lammps"
    };
    compare(
        engine,
        "lammps-bpm",
        &test,
        problem,
        reference,
        measured,
        dt,
        timings,
    )
}

/// `data.lmp` of the strength test in `dir`: the header (`title`; `bond_types` bond types),
/// the box, the atoms (`id mol type diameter density x y z`) and `bond_lines`.
fn write_data(
    dir: &Path,
    problem: &Problem,
    types: &[u8],
    density: f64,
    title: &str,
    bond_types: usize,
    bond_lines: &str,
) -> Result<()> {
    let (packing, bonds) = (problem.packing, problem.bonds);
    let (n, nb) = (packing.len(), bonds.len());
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let mut s = format!(
        "LAMMPS data file written by anisobond {}: {title}\n\n{n} atoms\n3 atom types\n\
         {nb} bonds\n{bond_types} bond types\n\n",
        env!("CARGO_PKG_VERSION"),
    );
    s.push_str(&box_lines(packing, 2.0 * max_len));
    s.push_str("\nAtoms # bpm/sphere\n\n");
    s.push_str(&atom_lines(packing, types, density, true));
    s.push_str("\nBonds\n\n");
    s.push_str(bond_lines);
    crate::io::write_string_atomic(&dir.join("data.lmp"), &s)
}

/// `data.lmp` (atoms `id mol type diameter density x y z`, bond b of type b + 1) and
/// `bond_coeffs.lmp` (`k_r k_s k_t k_b f_rc f_sc tau_tc tau_bc gamma_n gamma_s gamma_r
/// gamma_t` of each bond).
fn write_inputs(
    dir: &Path,
    problem: &Problem,
    types: &[u8],
    density: f64,
    limits: &[[f64; 4]],
    damping: &[[f64; 4]],
) -> Result<()> {
    let (n, nb, k) = (problem.packing.len(), problem.bonds.len(), problem.springs);
    let title = format!("strength test, {n} particles, {nb} bonds (one bond type per bond)");
    let bond_lines = bond_lines_one_type_each(problem.bonds);
    write_data(dir, problem, types, density, &title, nb, &bond_lines)?;
    crate::io::write_string_atomic(
        &dir.join("bond_coeffs.lmp"),
        &bond_coeff_lines(k, limits, damping),
    )
}

/// Law (d)'s coefficients of each bond: bpm/rotational's k_r k_s k_t k_b from the bond's
/// springs k_n k_s k_tw k_r, and its dashpots `damping` ([`bond_damping`]: γ_n γ_s γ_r γ_t).
pub fn bpm_coefficients(
    k: &crate::bonds::BondStiffness,
    damping: &[[f64; 4]],
) -> Vec<BpmCoefficients> {
    (0..k.len())
        .map(|b| BpmCoefficients {
            kr: k.kn[b],
            ks: k.ks[b],
            kt: k.ktw[b],
            kb: k.kr[b],
            gamma_n: damping[b][0],
            gamma_s: damping[b][1],
            gamma_r: damping[b][2],
            gamma_t: damping[b][3],
        })
        .collect()
}

/// `bond_coeffs.lmp` of bpm/rotational with one bond type per bond: a header comment, then
/// `bond_coeff TYPE k_r k_s k_t k_b f_rc f_sc tau_tc tau_bc gamma_n gamma_s gamma_r gamma_t`
/// of each bond from its springs `k`, its limits ([`bond_limits`]: f_rc f_sc τ_bc τ_tc) and
/// its damping ([`bond_damping`]).
pub fn bond_coeff_lines(
    k: &crate::bonds::BondStiffness,
    limits: &[[f64; 4]],
    damping: &[[f64; 4]],
) -> String {
    let mut c = String::from(
        "# bond_coeff TYPE k_r k_s k_t k_b f_rc f_sc tau_tc tau_bc gamma_n gamma_s gamma_r gamma_t\n",
    );
    for b in 0..k.len() {
        let (l, g) = (limits[b], damping[b]);
        let _ = writeln!(
            c,
            "bond_coeff {} {} {} {} {} {} {} {} {} {} {} {} {}",
            b + 1,
            num(k.kn[b]),
            num(k.ks[b]),
            num(k.ktw[b]),
            num(k.kr[b]),
            num(l[0]),
            num(l[1]),
            num(l[3]),
            num(l[2]),
            num(g[0]),
            num(g[1]),
            num(g[2]),
            num(g[3])
        );
    }
    c
}

/// The plugin's inputs: `data.lmp` (as [`write_inputs`]'s, every bond of type 1), `bonds.csv`
/// (each bond's springs, atom id = index + 1) and `bond-strengths.csv` (its limits).
fn write_plugin_inputs(
    dir: &Path,
    problem: &Problem,
    types: &[u8],
    density: f64,
    limits: &[[f64; 4]],
) -> Result<()> {
    let (n, nb) = (problem.packing.len(), problem.bonds.len());
    let (bonds, k) = (problem.bonds, problem.springs);
    let title = format!("strength test (bond_style anisobond), {n} particles, {nb} bonds");
    let mut bond_lines = String::new();
    for b in 0..nb {
        let _ = writeln!(
            bond_lines,
            "{} 1 {} {}",
            b + 1,
            bonds.i[b] + 1,
            bonds.j[b] + 1
        );
    }
    write_data(dir, problem, types, density, &title, 1, &bond_lines)?;
    crate::bonds::table::write_bond_table_with_ids(&dir.join("bonds.csv"), bonds, k, None)?;
    let ids: Vec<u64> = (1..=n as u64).collect();
    write_strength_table(dir, bonds, &ids, limits)?;
    Ok(())
}

/// The deck: read, hold and move the layers, start the velocity field, run, printing the
/// top layer's load (tensile or compressive: the test's sense) every step and the broken
/// bonds every [`DUMP_EVERY`] steps; `pair_style granular` for the loading's contacts,
/// else `pair_style zero`. With `plugin`: `bond_style anisobond` loaded from it (`newton on
/// on`, its own record of the broken bonds, broken pairs handed to the pair style) instead of
/// bpm/rotational.
fn deck(test: &StrengthTest, loading: &Loading, cut: f64, plugin: Option<&Path>) -> Result<String> {
    let ax = test.axis;
    let name = ["x", "y", "z"][ax];
    let along = |v: &str, other: &str| {
        let mut c = [other; 3];
        c[ax] = v;
        c.join(" ")
    };
    let v = num(loading.velocity);
    let pair = match &loading.contacts {
        Some(c) => format!(
            "# Broken bonds' pairs (and pairs that touch) are frictional contacts: Hooke normal spring,\n\
             # no damping, linear tangential spring with history capped at mu*F_n.\n\
             pair_style granular\n\
             pair_coeff * * hooke {} 0 tangential linear_history {} 0 {} damping velocity\n",
            num(c.normal_stiffness),
            num(c.shear_stiffness),
            num(c.friction)
        ),
        None => format!("pair_style zero {}\npair_coeff * *\n", num(cut)),
    };
    let (engine, load, newton, bond_style, dump) = match plugin {
        None => (
            "LAMMPS (BPM package)",
            String::new(),
            "on off",
            format!(
                "bond_style bpm/rotational break yes smooth no store/local brk {DUMP_EVERY} id1 \
                 id2 time\ninclude bond_coeffs.lmp\n"
            ),
            format!("dump brk all local {DUMP_EVERY} broken.txt f_brk[1] f_brk[2] f_brk[3]\n"),
        ),
        Some(so) => {
            let so = so.to_str().ok_or_else(|| {
                Error::Invalid(format!(
                    "validate lammps --strength: the plugin path {} is not UTF-8",
                    so.display()
                ))
            })?;
            if so
                .chars()
                .any(|c| c.is_whitespace() || c == '"' || c == '#')
            {
                return Err(Error::Invalid(format!(
                    "validate lammps --strength: the plugin path `{so}` has a space, quote or \
                     #, which a LAMMPS input line cannot carry"
                )));
            }
            (
                "LAMMPS (anisobond's plugin)",
                format!("plugin load {so}\n"),
                "on on",
                format!(
                    "bond_style anisobond table bonds.csv damping {} break yes strengths \
                     bond-strengths.csv record broken.txt\nbond_coeff *\n",
                    num(test.damping_ratio)
                ),
                String::new(),
            )
        }
    };
    Ok(format!(
        "# anisobond → {engine} strength test: {test_name} along {name}.\n\
         # Run:  lmp -in in.strength   (or mpirun -np N lmp -in in.strength)\n\
         # Atom types: 1 free, 2 bottom layer (held), 3 top layer (moved at v).\n\
         # Writes force.txt (step, top layer's {sense} force) and broken.txt (id1 id2\n\
         # timestep of each broken bond).\n\
         {load}units si\ndimension 3\nboundary f f f\natom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\nnewton {newton}\n\
         comm_modify vel yes cutoff {cut}\nread_data data.lmp\n\
         {bond_style}\
         {pair}neighbor {skin} bin\n\
         neigh_modify every 1 delay 0 check yes\n\
         group bottom type 2\ngroup top type 3\ngroup mobile type 1\n\
         timestep {dt}\n\
         variable vfield atom {v}*({name}-({lo}))/{gauge}\n\
         velocity mobile set {field} units box\n\
         velocity top set {vtop} units box\n\
         fix integrate mobile nve/bpm/sphere\n\
         fix pull top move linear {vtop}\n\
         fix hold bottom move linear 0 0 0\n\
         compute ftop top reduce sum f{name}\n\
         variable F equal {minus}c_ftop\n\
         thermo_style custom step v_F bonds\nthermo 1000\n\
         fix out all print 1 \"$(step) $(v_F:%.17g)\" file force.txt screen no\n\
         {dump}\
         run {steps}\n",
        cut = num(cut),
        skin = num(0.1 * cut),
        dt = num(loading.time_step),
        lo = num(loading.lowest),
        gauge = num(loading.gauge),
        field = along("v_vfield", "0"),
        vtop = along(&v, "0"),
        steps = test.steps,
        test_name = test.loading.describe(),
        sense = match test.loading {
            super::StrengthLoading::Tension => "tensile",
            super::StrengthLoading::Compression => "compressive",
        },
        minus = if loading.sign > 0.0 { "-" } else { "" },
    ))
}

/// Read `force.txt` and `broken.txt` of a run on `np` processes (kept as `*-npN.txt`):
/// `dump local`'s entries (route (a)) or, for the `plugin`, its record (`id_lo id_hi step`
/// lines after a `#` header).
fn read_run(
    dir: &Path,
    problem: &Problem,
    np: usize,
    test: &StrengthTest,
    plugin: bool,
    seconds: f64,
) -> Result<StrengthRun> {
    let fail = |m: String| Error::engine("LAMMPS", m);
    let keep = |f: &str| -> Result<(PathBuf, String)> {
        let path = dir.join(f);
        let text = crate::io::read_to_string(&path)?;
        let kept = dir.join(f.replace(".txt", &format!("-np{np}.txt")));
        std::fs::rename(&path, &kept).map_err(|e| Error::io(&kept, e))?;
        Ok((kept, text))
    };
    let (fpath, force) = keep("force.txt")?;
    let mut curve = Vec::new();
    for (n, line) in force.lines().enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        if w.is_empty() || w[0].starts_with('#') {
            continue;
        }
        let parsed = (w.len() == 2)
            .then(|| Some((w[0].parse::<u64>().ok()?, w[1].parse::<f64>().ok()?)))
            .flatten();
        let (step, f) = parsed.ok_or_else(|| {
            fail(format!(
                "{} line {}: expected `step force`, got `{line}`",
                fpath.display(),
                n + 1
            ))
        })?;
        curve.push((step, f));
    }
    if curve.is_empty() {
        return Err(fail(format!("{}: no force read", fpath.display())));
    }
    let (bpath, broken) = keep("broken.txt")?;
    let mut raw = Vec::new();
    let mut in_entries = plugin;
    for (n, line) in broken.lines().enumerate() {
        if plugin && (line.starts_with('#') || line.trim().is_empty()) {
            continue;
        }
        if !plugin && line.starts_with("ITEM:") {
            in_entries = line.starts_with("ITEM: ENTRIES");
            continue;
        }
        if !in_entries {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        let n_atoms = problem.packing.len() as f64;
        let id = |x: f64| (x >= 1.0 && x <= n_atoms && x.fract() == 0.0).then(|| x as usize - 1);
        let row = (v.len() == 3)
            .then(|| Some((id(v[0])?, id(v[1])?, v[2] as u64)))
            .flatten();
        raw.push(row.ok_or_else(|| {
            fail(format!(
                "{} line {}: expected `id1 id2 timestep` of a broken bond, got `{line}`",
                bpath.display(),
                n + 1
            ))
        })?);
    }
    let version = crate::validate::specimen::lammps::log_version(dir, np);
    let breaks = order_breaks("LAMMPS", problem.bonds, &raw)?;
    let (peak_force, peak_step) = super::peak_of(test, &curve, &breaks)
        .ok_or_else(|| fail(format!("{}: no force read", fpath.display())))?;
    if !peak_force.is_finite() {
        return Err(fail(format!(
            "{}: the peak force is not finite",
            fpath.display()
        )));
    }
    Ok(StrengthRun {
        program: if plugin {
            format!("LAMMPS ({version}) + bond_style anisobond")
        } else {
            format!("LAMMPS ({version})")
        },
        processes: np,
        peak_force,
        peak_step,
        breaks,
        seconds,
    })
}
