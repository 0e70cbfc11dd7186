//! LIGGGHTS export: the data file, the bond table and two input decks for an element test
//! of a bonded periodic packing, plus readers for what the decks write.
//!
//! - `anisobond.in`: the driver deck (`anisobond-liggghts`, built by `make -C cpp`) with the
//!   full per-bond law: k_n, k_s, k_r, k_tw, incremental shear and moments
//!   (`pair_style anisobond table bonds.csv`).
//! - `harmonic.in` + `harmonic.data`: a deck for the stock `liggghts` with
//!   `bond_style harmonic`, one bond type per bond, K = k_n/2 (LIGGGHTS' harmonic energy is
//!   K(r − r0)²): normal springs only — no shear, bending or twisting stiffness.
//!
//! Both run six load cases in Voigt order (11, 22, 33, 23, 13, 12): `fix deform … remap x`
//! applies the strain increment over `deform_steps`, then the box is held for `relax_steps`
//! (damped). The stress σ = −p of `compute p all pressure thermo_temp virial` (tension
//! positive, Pa) and the box strain are written every `output_every` steps to
//! `stress_history.txt`; [`tensor_from_cases`] turns the case ends into the 6×6 tensor.
//! With `affine` the particles are not integrated: they follow the box (remap x), so the
//! result is the affine (Voigt) tensor.

pub(crate) use super::num;
use crate::bonds::{table, BondSet, BondStiffness};
use crate::manybody::{ManyBody, StrainMeasure};
use crate::packing::{Packing, PeriodicCell};
use crate::strength::criteria::YadeAdhesion;
use crate::tensor::Stiffness6;
use crate::{Error, Mat3, Result, Vec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
#[cfg(feature = "engines")]
use std::process::Command;

/// Options of the exported element test.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckOptions {
    /// Particle density (kg/m³).
    pub density: f64,
    /// Strain increment of each load case (engineering strain for shear).
    pub strain: f64,
    /// Steps over which each strain increment is applied.
    pub deform_steps: u64,
    /// Steps the box is held after each increment (relaxation).
    pub relax_steps: u64,
    /// Output interval of the stress history (steps).
    pub output_every: u64,
    /// Time step (s); `None`: [`stable_timestep`].
    pub timestep: Option<f64>,
    /// Viscous damping rate as a fraction of 1/dt: translational and rotational rates
    /// γ = `damping`/dt (force −γ·m·v, torque −γ·I·ω). 0 = undamped.
    pub damping: f64,
    /// Do not integrate: particles follow the box affinely (the Voigt tensor).
    pub affine: bool,
    /// Include the three shear load cases (needs a triclinic box). LIGGGHTS 3.8 (Debian)
    /// creates no ghost atoms for a triclinic box under MPI ("Bond atoms missing" with the
    /// stock deck, a missing bond partner with the driver): set `false` for runs on more
    /// than one process; only the normal cases (columns 1–3 of C) are then run.
    pub shear: bool,
}

impl Default for DeckOptions {
    fn default() -> Self {
        DeckOptions {
            density: 2500.0,
            strain: 1e-6,
            deform_steps: 500,
            relax_steps: 10_000,
            output_every: 100,
            timestep: None,
            damping: 0.02,
            affine: false,
            shear: true,
        }
    }
}

/// What [`export_liggghts`] wrote and chose.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSummary {
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Time step used (s).
    pub timestep: f64,
    /// Damping rate γ (1/s).
    pub damping_rate: f64,
    /// Last step of each load case of the driver deck (Voigt order; 6 cases, or 3 without
    /// shear). The harmonic deck runs the first three (normal) cases only.
    pub case_end_steps: Vec<u64>,
    /// The driver deck's load cases, Voigt indices (0–5: 11 22 33 23 13 12) in the order
    /// run: all six, the normal three without shear, and on a box of mixed periodicity those
    /// of its periodic axes ([`super::load_cases`]).
    pub cases: Vec<usize>,
    /// Longest bond (m): the ghost cutoff must exceed it.
    pub max_bond_length: f64,
}

/// The Voigt component names in order.
pub const VOIGT_NAMES: [&str; 6] = ["11", "22", "33", "23", "13", "12"];

/// A stable time step for the bonded packing: 0.3·min_i √(0.4·m_i / k_i) with
/// k_i = Σ_b (k_n + k_s + (k_r + k_tw)/R_i²) over the bonds of particle i — the
/// translational and rotational (I = 0.4mR²) single-particle frequencies bounded together.
pub fn stable_timestep(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
) -> Result<f64> {
    stable_timestep_with(packing, bonds, k, density, None)
}

/// [`stable_timestep`] with the many-body term `term` of these bonds (when given) added to
/// each particle's stiffness sum, as [`LiggghtsInputs::export`] chooses its step
/// (`manybody_stiffness`, docs/manybody.md "LIGGGHTS").
pub fn stable_timestep_with_manybody(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    term: Option<&ManyBody>,
) -> Result<f64> {
    let extra = term
        .map(|t| {
            manybody_table(packing, bonds, t).map(|t| manybody_stiffness(packing.len(), bonds, &t))
        })
        .transpose()?;
    stable_timestep_with(packing, bonds, k, density, extra.as_deref())
}

/// [`stable_timestep`] with `extra` (N/m, one per particle) added to each particle's k_i:
/// the many-body term's share ([`manybody_stiffness`]).
fn stable_timestep_with(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    extra: Option<&[f64]>,
) -> Result<f64> {
    let mut ksum = extra.map_or_else(|| vec![0.0; packing.len()], <[f64]>::to_vec);
    for b in 0..bonds.len() {
        for p in [bonds.i[b] as usize, bonds.j[b] as usize] {
            let r = packing.radii[p];
            ksum[p] += k.kn[b] + k.ks[b] + (k.kr[b] + k.ktw[b]) / (r * r);
        }
    }
    let mut dt = f64::INFINITY;
    for (p, &kp) in ksum.iter().enumerate() {
        if kp > 0.0 {
            let r = packing.radii[p];
            let m = density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
            dt = dt.min(0.3 * (0.4 * m / kp).sqrt());
        }
    }
    if !dt.is_finite() || dt <= 0.0 {
        return Err(Error::Invalid(
            "LIGGGHTS export: cannot choose a time step: no bond has a positive stiffness".into(),
        ));
    }
    Ok(dt)
}

fn check_options(o: &DeckOptions) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(format!("LIGGGHTS export: {m}")));
    if !o.density.is_finite() || o.density <= 0.0 {
        return bad(format!("density must be finite and > 0, got {}", o.density));
    }
    if !o.strain.is_finite() || o.strain == 0.0 || o.strain.abs() > 0.1 {
        return bad(format!(
            "strain must be non-zero with |strain| ≤ 0.1, got {}",
            o.strain
        ));
    }
    if o.deform_steps == 0 || o.output_every == 0 {
        return bad("deform_steps and output_every must be ≥ 1".into());
    }
    if let Some(dt) = o.timestep {
        if !dt.is_finite() || dt <= 0.0 {
            return bad(format!("timestep must be finite and > 0, got {dt}"));
        }
    }
    if !o.damping.is_finite() || !(0.0..1.0).contains(&o.damping) {
        return bad(format!(
            "damping (γ·dt) must be in [0, 1), got {}",
            o.damping
        ));
    }
    Ok(())
}

/// Steps held after each strain increment: at least one (see [`load_cases`]) and enough
/// that every load case ends on an output step.
fn hold_steps(o: &DeckOptions) -> u64 {
    let period = (o.deform_steps + o.relax_steps.max(1)).div_ceil(o.output_every) * o.output_every;
    period - o.deform_steps
}

/// Common head of both decks: variables and the stress/strain history output.
fn history_block(s: &mut String, packing_lengths: [f64; 3], every: u64) {
    let [lx, ly, lz] = packing_lengths;
    let _ = writeln!(s, "compute p all pressure thermo_temp virial");
    let _ = writeln!(s, "variable step equal step");
    for (name, expr) in [
        ("e11", format!("lx/{}-1", num(lx))),
        ("e22", format!("ly/{}-1", num(ly))),
        ("e33", format!("lz/{}-1", num(lz))),
        ("e23", "yz/lz".to_string()),
        ("e13", "xz/lz".to_string()),
        ("e12", "xy/ly".to_string()),
    ] {
        let _ = writeln!(s, "variable {name} equal {expr}");
    }
    stress_variables(s);
    let _ = writeln!(
        s,
        "fix history all print {every} \"${{step}} ${{e11}} ${{e22}} ${{e33}} ${{e23}} ${{e13}} ${{e12}} ${{s11}} ${{s22}} ${{s33}} ${{s23}} ${{s13}} ${{s12}}\" file stress_history.txt screen no title \"# step e11 e22 e33 e23 e13 e12 s11 s22 s33 s23 s13 s12 (strain; stress Pa, tension positive)\""
    );
    let _ = writeln!(s, "thermo {every}");
    let _ = writeln!(
        s,
        "thermo_style custom step v_s11 v_s22 v_s33 v_s23 v_s13 v_s12"
    );
    let _ = writeln!(s, "thermo_modify norm no");
}

/// The load cases `cases` (Voigt indices, in order), each a deform phase and a hold phase.
fn load_cases(s: &mut String, lengths: [f64; 3], o: &DeckOptions, cases: &[usize]) {
    let [_, _, lz] = lengths;
    let e = o.strain;
    for &c in cases {
        let name = VOIGT_NAMES[c];
        let spec = match c {
            0 => format!("x scale {}", num(1.0 + e)),
            1 => format!("y scale {}", num(1.0 + e)),
            2 => format!("z scale {}", num(1.0 + e)),
            // Tilt deltas: γ_23 = Δyz/lz, γ_13 = Δxz/lz, γ_12 = Δxy/ly (lz, ly after the
            // normal cases).
            3 => format!("yz delta {}", num(e * lz * (1.0 + e))),
            4 => format!("xz delta {}", num(e * lz * (1.0 + e))),
            _ => format!("xy delta {}", num(e * lengths[1] * (1.0 + e))),
        };
        let _ = writeln!(
            s,
            "\n# load case {}: strain increment e{name} = {}",
            c + 1,
            num(e)
        );
        let _ = writeln!(s, "fix deform_case all deform 1 {spec} remap x");
        let _ = writeln!(s, "run {}", o.deform_steps);
        let _ = writeln!(s, "unfix deform_case");
        // At least one step held: fix deform applies its last box change at the end of the
        // last deform step, after that step's forces and output.
        let _ = writeln!(s, "run {}", hold_steps(o));
    }
}

/// The neighbour skin (5 % of the longest bond, m), the time step and the integrator of
/// both decks (not integrated with `relax` = 0: the particles follow the box affinely).
fn integration_lines(s: &mut String, max_bond_length: f64) {
    let _ = writeln!(
        s,
        "neighbor {} bin\nneigh_modify delay 0",
        num(0.05 * max_bond_length)
    );
    let _ = writeln!(s, "timestep ${{dt}}");
    let _ = writeln!(
        s,
        "if \"${{relax}} == 1\" then \"fix integrate all nve/sphere\""
    );
}

/// The element test of both decks: the history output, the reference state (`run 0`) and
/// the load cases `cases`.
fn element_test(s: &mut String, lengths: [f64; 3], o: &DeckOptions, cases: &[usize]) {
    history_block(s, lengths, o.output_every);
    let _ = writeln!(s, "run 0");
    load_cases(s, lengths, o, cases);
}

/// What both decks share, fixed before anything is written: the cell, the time step and
/// damping rate, the load cases and the neighbour skin.
struct Plan {
    /// The packing's cell (periodic along some or all axes).
    cell: PeriodicCell,
    /// Its edges Lx, Ly, Lz (m).
    lengths: [f64; 3],
    /// Longest bond (m).
    max_len: f64,
    /// Time step (s).
    dt: f64,
    /// Damping rate γ (1/s).
    gamma: f64,
    /// Steps of one load case.
    period: u64,
    /// The driver deck's load cases (Voigt indices).
    cases: Vec<usize>,
}

/// Check the inputs (options, periodic cell, bonds against the packing, the minimum image
/// along the periodic axes, a given time step) and fix the [`Plan`].
fn plan(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    o: &DeckOptions,
    extra: Option<&[f64]>,
) -> Result<Plan> {
    check_options(o)?;
    let cell = packing.cell.ok_or_else(|| {
        Error::Invalid(
            "LIGGGHTS export: the packing must be periodic (the decks use boundary p p p)".into(),
        )
    })?;
    if bonds.is_empty() {
        return Err(Error::Invalid("LIGGGHTS export: no bonds".into()));
    }
    if k.kn.len() != bonds.len() {
        return Err(Error::Invalid(format!(
            "LIGGGHTS export: {} bonds but {} spring rows",
            bonds.len(),
            k.kn.len()
        )));
    }
    if let Some(b) = (0..bonds.len()).find(|&b| bonds.j[b] as usize >= packing.len()) {
        return Err(Error::Invalid(format!(
            "LIGGGHTS export: bond {b} names particle {} but the packing has {}",
            bonds.j[b],
            packing.len()
        )));
    }
    let l = cell.lengths;
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let edge = super::min_periodic_length(&cell);
    if 2.0 * max_len >= edge {
        return Err(Error::Invalid(format!(
            "LIGGGHTS export: the longest bond ({max_len} m) must be shorter than half the smallest cell edge ({edge} m) for the minimum image"
        )));
    }
    if let Some(dt) = o.timestep {
        super::check_time_step(dt, packing, bonds, k, o.density, "--timestep")?;
    }
    let dt = match o.timestep {
        Some(dt) => dt,
        None => stable_timestep_with(packing, bonds, k, o.density, extra)?,
    };
    let cases = super::load_cases(&cell)
        .into_iter()
        .filter(|&c| o.shear || c < 3)
        .collect();
    Ok(Plan {
        cell,
        lengths: [l.x, l.y, l.z],
        max_len,
        dt,
        gamma: o.damping / dt,
        period: o.deform_steps + hold_steps(o),
        cases,
    })
}

/// Write the LIGGGHTS files for `packing` with `bonds` and springs `k` into `dir`
/// (created if needed): `packing.data`, `bonds.csv`, `anisobond.in`, `harmonic.data`,
/// `harmonic.in`, `run.sh`. The packing must be periodic, along every axis or some (a box
/// of mixed periodicity, LAMMPS `boundary p p f`: the decks' boundary is `m` along the free
/// axes and they run the load cases of the periodic axes only, [`super::load_cases`]); the
/// bonds must be those of this packing. Atom ids are the packing's own ([`Packing::ids`])
/// when it has them (all ≥ 1), else index + 1. [`LiggghtsInputs::export`] with no limits,
/// term or grains.
pub fn export_liggghts(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    o: &DeckOptions,
) -> Result<ExportSummary> {
    LiggghtsInputs::new(packing, bonds, k, o).export(dir)
}

/// What the LIGGGHTS export is given: the bonded packing and the deck options
/// ([`LiggghtsInputs::new`]), and the model's optional limits, many-body term and grains
/// (fields set by the caller; [`LiggghtsInputs::export`] writes the files).
#[derive(Clone, Copy, Debug)]
pub struct LiggghtsInputs<'a> {
    /// The packing, periodic along every axis or some.
    pub packing: &'a Packing,
    /// Its bonds.
    pub bonds: &'a BondSet,
    /// The bonds' springs.
    pub springs: &'a BondStiffness,
    /// The element test's options.
    pub options: &'a DeckOptions,
    /// Each bond's YADE CohFrict limits (one per bond, as [`super::yade::yade_adhesions`]
    /// gives them for a model with `[strength]`): `bonds.csv` then carries the
    /// [`super::yade::ADHESION_COLUMNS`], which `pair_style anisobond table` reads, so the
    /// driver deck's bonds break by YADE's criterion (docs/strength.md, "LIGGGHTS"). The stock
    /// harmonic deck stays unbreakable. A count other than one per bond is refused.
    pub limits: Option<&'a [YadeAdhesion]>,
    /// The model's many-body term (the term of these bonds on this packing,
    /// [`crate::manybody::ManyBodySpec::build`]): written to `manybody.txt`
    /// ([`write_manybody_table`]) and read by the driver deck's pair style (`manybody
    /// manybody.txt`), so the driver runs the library's [`ManyBody`] forces; the stock
    /// harmonic deck does not carry it (its header says so). The chosen time step counts the
    /// term's stiffness too (`manybody_stiffness`). With `limits` it is refused
    /// ([`Error::Model`]): a broken bond would change the fits of its particles.
    pub manybody: Option<&'a ManyBody>,
    /// A polycrystal's grain id of each particle (`Assembly::grains`): the molecule ID of the
    /// stock deck's `harmonic.data`, grain + 1 (LAMMPS' 0 = no molecule), which `dump custom
    /// … mol` writes (docs/polycrystal.md). The driver deck's `atom_style granular` has no
    /// molecule column.
    pub grains: Option<&'a [u32]>,
}

impl<'a> LiggghtsInputs<'a> {
    /// `packing` with `bonds`, springs `k` and the options `o`; no limits, term or grains.
    pub fn new(
        packing: &'a Packing,
        bonds: &'a BondSet,
        k: &'a BondStiffness,
        o: &'a DeckOptions,
    ) -> Self {
        LiggghtsInputs {
            packing,
            bonds,
            springs: k,
            options: o,
            limits: None,
            manybody: None,
            grains: None,
        }
    }

    /// Write the files of [`export_liggghts`] into `dir`, with the limits, the term's
    /// `manybody.txt` and the grains' molecule IDs where given (see the fields).
    pub fn export(&self, dir: &Path) -> Result<ExportSummary> {
        let LiggghtsInputs {
            packing,
            bonds,
            springs: k,
            options: o,
            limits,
            manybody,
            grains,
        } = *self;
        super::check_grain_count(grains, packing.len(), "export liggghts")?;
        if manybody.is_some() && limits.is_some() {
            return Err(Error::Model(
                "export liggghts: a model with both [strength] and [manybody]: the LIGGGHTS pair \
                 style keeps each particle's many-body fit of its bonds as bonded, so breakable bonds \
                 with the term are not supported; remove one of the two tables"
                    .into(),
            ));
        }
        let table = manybody
            .map(|t| manybody_table(packing, bonds, t))
            .transpose()?;
        if let Some(l) = limits {
            if l.len() != bonds.len() {
                return Err(Error::Invalid(format!(
                    "export liggghts: {} bond limits for {} bonds",
                    l.len(),
                    bonds.len()
                )));
            }
        }
        let extra = table
            .as_ref()
            .map(|t| manybody_stiffness(packing.len(), bonds, t));
        let plan = plan(packing, bonds, k, o, extra.as_deref())?;
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let mut files = write_data_and_table(dir, packing, bonds, k, o.density, limits)?;
        if let Some(t) = &table {
            let path = dir.join("manybody.txt");
            write_manybody_table(&path, t)?;
            files.push(path);
        }
        files.push(write_driver_deck(dir, self, &plan)?);
        files.extend(write_harmonic_deck(dir, self, &plan)?);
        let run = dir.join("run.sh");
        let shear = plan.cases.iter().any(|&c| c >= 3);
        crate::io::write_string_atomic(&run, &run_script(shear))?;
        super::make_executable(&run)?;
        files.push(run);
        Ok(ExportSummary {
            files,
            timestep: plan.dt,
            damping_rate: plan.gamma,
            case_end_steps: (1..=plan.cases.len() as u64)
                .map(|c| c * plan.period)
                .collect(),
            cases: plan.cases,
            max_bond_length: plan.max_len,
        })
    }
}

/// `packing.data` and `bonds.csv`: the packing's own atom ids (a data file's, a dump's) are
/// kept in the data file and as `id_i,id_j` of the bond table, by which the driver finds
/// each bond.
fn write_data_and_table(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    limits: Option<&[YadeAdhesion]>,
) -> Result<Vec<PathBuf>> {
    let data = dir.join("packing.data");
    let ids = super::engine_ids(packing);
    match ids {
        Some(_) => crate::packing::io::write_liggghts_data_with_ids(&data, packing, density)?,
        None => crate::packing::io::write_liggghts_data(&data, packing, density)?,
    }
    let table_path = dir.join("bonds.csv");
    match limits {
        Some(l) => super::yade::write_bond_table_with_adhesions(&table_path, bonds, k, ids, l)?,
        None => table::write_bond_table_with_ids(&table_path, bonds, k, ids)?,
    }
    Ok(vec![data, table_path])
}

/// The header comment of a box of mixed periodicity (nothing for a periodic cell): its
/// boundary as read and as written, and the load cases run.
fn mixed_box_comment(plan: &Plan) -> String {
    if !plan.cell.is_mixed() {
        return String::new();
    }
    let names: Vec<&str> = plan.cases.iter().map(|&c| VOIGT_NAMES[c]).collect();
    format!(
        "# Box of mixed periodicity (boundary {} as read; written `{}`: shrink-wrapped with the box as minimum\n\
         #   along the free axes, so no atom is lost): load cases {} only (strains of the periodic axes; the free\n\
         #   faces are free surfaces). Stress = virial / box volume, the box as read along the free axes.\n",
        plan.cell.boundary(),
        super::deck_boundary(&plan.cell),
        names.join(" ")
    )
}

/// `anisobond.in`: the driver deck (`pair_style anisobond table bonds.csv`).
fn write_driver_deck(dir: &Path, i: &LiggghtsInputs, plan: &Plan) -> Result<PathBuf> {
    let LiggghtsInputs {
        packing,
        bonds,
        options: o,
        ..
    } = *i;
    let (breakable, manybody) = (i.limits.is_some(), i.manybody.is_some());
    let period = plan.period;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# anisobond → LIGGGHTS driver deck: {} particles, {} bonds with per-bond k_n, k_s, k_r, k_tw.",
        packing.len(),
        bonds.len()
    );
    if o.shear {
        let _ = writeln!(s, "# Run:  anisobond-liggghts -in anisobond.in   (one process only: the shear cases tilt a triclinic box,");
        let _ = writeln!(s, "#   for which LIGGGHTS 3.8 makes no ghost atoms under MPI; the driver refuses -np > 1. Export with");
        let _ = writeln!(s, "#   --no-shear for the three normal cases under mpirun, or take the shear cases to LAMMPS.)");
        let _ = writeln!(s, "# Element test: six load cases (Voigt 11 22 33 23 13 12), each a strain increment of {} over {} steps, then {} steps held;", num(o.strain), o.deform_steps, o.relax_steps);
    } else {
        let _ = writeln!(s, "# Run:  anisobond-liggghts -in anisobond.in   (or: mpirun -np N anisobond-liggghts -in anisobond.in)");
        let _ = writeln!(s, "# Element test: three normal load cases (Voigt 11 22 33; exported with --no-shear), each a strain increment of {} over {} steps, then {} steps held;", num(o.strain), o.deform_steps, o.relax_steps);
    }
    s.push_str(&mixed_box_comment(plan));
    let _ = writeln!(s, "# case k ends at step k*{period}. Output: stress_history.txt (stress σ = −p, Pa, tension positive).");
    let _ = writeln!(s, "# Bond law: YADE cohesive law in incremental form with mid-gap contact points (cpp/liggghts/pair_anisobond.h).");
    if breakable {
        let _ = writeln!(s, "# Breakage: bonds.csv gives each bond YADE's normal_adhesion, shear_adhesion, tan_friction (the model's");
        let _ = writeln!(s, "#   [strength]); the pair style breaks bonds by YADE's CohFrict criterion and writes each break");
        let _ = writeln!(
            s,
            "#   (step id_i id_j tension|shear) to breaks.txt (docs/strength.md, \"LIGGGHTS\")."
        );
    }
    if manybody {
        let _ = writeln!(s, "# Many-body term (docs/manybody.md): manybody.txt gives D, each particle's volume share and each");
        let _ = writeln!(s, "#   bond's fit coefficients; the pair style adds the forces of U = Σ_p ½ V_p E_p:D:E_p.");
    }
    let _ = writeln!(
        s,
        "# {}",
        if o.affine {
            "Affine: particles are not integrated; they follow the box (Voigt tensor)."
        } else {
            "Damping: viscous, force −γ·m·v and torque −γ·I·ω on every particle (not in the stress)."
        }
    );
    let _ = writeln!(s, "variable relax index {}", u8::from(!o.affine));
    let _ = writeln!(s, "variable damp index {}", num(plan.gamma));
    let _ = writeln!(s, "variable dt index {}", num(plan.dt));
    let boundary = super::deck_boundary(&plan.cell);
    let _ = writeln!(s, "units si\natom_style granular\natom_modify map array\nboundary {boundary}\nnewton on\ncommunicate single vel yes");
    let box_line = if o.shear {
        "change_box all triclinic\n"
    } else {
        ""
    };
    let _ = write!(s, "read_data packing.data\n{box_line}");
    let _ = writeln!(
        s,
        "pair_style anisobond table bonds.csv damping ${{damp}} ${{damp}}{}{}\npair_coeff * *",
        if breakable { " breaks breaks.txt" } else { "" },
        if manybody {
            " manybody manybody.txt"
        } else {
            ""
        }
    );
    integration_lines(&mut s, plan.max_len);
    element_test(&mut s, plan.lengths, o, &plan.cases);
    let deck = dir.join("anisobond.in");
    crate::io::write_string_atomic(&deck, &s)?;
    Ok(deck)
}

/// `harmonic.data` and `harmonic.in`: the stock deck (atom_style hybrid granular molecular,
/// one `bond_style harmonic` type per bond), the normal load cases of the periodic axes.
fn write_harmonic_deck(dir: &Path, i: &LiggghtsInputs, plan: &Plan) -> Result<Vec<PathBuf>> {
    let LiggghtsInputs {
        packing,
        bonds,
        springs: k,
        options: o,
        grains,
        ..
    } = *i;
    let manybody = i.manybody.is_some();
    let hdata = dir.join("harmonic.data");
    crate::io::write_atomic(&hdata, |w| {
        write_harmonic_data(w, packing, bonds, k, o.density, grains)
            .map_err(|e| Error::io(&hdata, e))
    })?;
    let mean_mass = packing
        .radii
        .iter()
        .map(|r| o.density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
        .sum::<f64>()
        / packing.len() as f64;
    let damping = plan.gamma * mean_mass;
    let mut h = String::new();
    let _ = writeln!(
        h,
        "# anisobond → stock LIGGGHTS deck (bond_style harmonic): {} particles, {} bonds.",
        packing.len(),
        bonds.len()
    );
    h.push_str(HARMONIC_LIMITS);
    if manybody {
        let _ = writeln!(
            h,
            "# Without the model's many-body term (manybody.txt): only anisobond.in carries it."
        );
    }
    h.push_str(&mixed_box_comment(plan));
    let _ = writeln!(
        h,
        "# Element test and output as anisobond.in: case k ends at step k*{}; stress_history.txt.",
        plan.period
    );
    let _ = writeln!(
        h,
        "# Damping: fix viscous with γ = {} kg/s (rate × mean mass).",
        num(damping)
    );
    let _ = writeln!(h, "variable relax index {}", u8::from(!o.affine));
    let _ = writeln!(h, "variable dt index {}", num(plan.dt));
    let boundary = super::deck_boundary(&plan.cell);
    harmonic_setup_with_boundary(&mut h, "harmonic.data", plan.max_len, &boundary);
    integration_lines(&mut h, plan.max_len);
    if plan.gamma > 0.0 {
        let _ = writeln!(
            h,
            "if \"${{relax}} == 1\" then \"fix damping all viscous {}\"",
            num(damping)
        );
    }
    let normal: Vec<usize> = plan.cases.iter().copied().filter(|&c| c < 3).collect();
    element_test(&mut h, plan.lengths, o, &normal);
    let hdeck = dir.join("harmonic.in");
    crate::io::write_string_atomic(&hdeck, &h)?;
    Ok(vec![hdata, hdeck])
}

/// `run.sh [NP] [--stock]`: the driver deck on NP processes (default 1), or with `--stock`
/// the stock harmonic deck; never a silent fallback from one to the other, and a shear deck
/// refused under MPI before LIGGGHTS starts.
fn run_script(shear: bool) -> String {
    let mut s = String::from(
        "#!/bin/sh\n\
         # Run the exported decks from this directory:  ./run.sh [NP] [--stock]\n\
         #   NP       MPI processes (default 1)\n\
         #   --stock  the stock LIGGGHTS deck harmonic.in instead of the driver deck: normal springs\n\
         #            only (k_s, k_r, k_tw ignored, softer than the model), normal cases only.\n\
         # The driver anisobond-liggghts is built by `make -C cpp driver` in the anisobond tree\n\
         # (into target/cpp/); put that folder on PATH.\n\
         set -e\n\
         cd \"$(dirname \"$0\")\"\n\
         np=1; stock=0\n\
         for a in \"$@\"; do\n\
         \x20 case \"$a\" in\n\
         \x20   --stock) stock=1 ;;\n\
         \x20   *[!0-9]*|'') echo \"run.sh: expected NP (a number of processes) or --stock, got '$a'\" >&2; exit 2 ;;\n\
         \x20   *) np=\"$a\" ;;\n\
         \x20 esac\n\
         done\n\
         if [ \"$np\" -gt 1 ]; then launch=\"mpirun -np $np\"; else launch=\"stdbuf -o0\"; fi\n\
         if [ \"$stock\" = 1 ]; then exec $launch liggghts -in harmonic.in; fi\n\
         if ! command -v anisobond-liggghts >/dev/null 2>&1; then\n\
         \x20 echo \"run.sh: anisobond-liggghts is not on PATH. Build it with 'make -C cpp driver' in the anisobond tree and add target/cpp to PATH, or run './run.sh --stock' for the stock harmonic deck (normal springs only: softer than the model).\" >&2\n\
         \x20 exit 1\n\
         fi\n",
    );
    if shear {
        s.push_str(
            "if [ \"$np\" -gt 1 ]; then\n\
             \x20 echo \"run.sh: this deck shears a triclinic box, for which LIGGGHTS 3.8 makes no ghost atoms under MPI: run it with NP = 1, export with --no-shear for the three normal cases under MPI, or take the shear cases to LAMMPS.\" >&2\n\
             \x20 exit 1\n\
             fi\n",
        );
    }
    s.push_str("exec $launch anisobond-liggghts -in anisobond.in\n");
    s
}

/// The atom id of particle `p`: the packing's own (a data file's, a dump's), else p + 1.
fn id_of(packing: &Packing, p: usize) -> u64 {
    super::engine_ids(packing).map_or(p as u64 + 1, |ids| ids[p])
}

/// The `harmonic.data` file: atoms (hybrid granular molecular: `id type x y z diameter
/// density molecule`; molecule = a polycrystal's grain + 1, else 1), one bond type per bond
/// with `K = k_n/2` and `r0` = bond length.
fn write_harmonic_data(
    w: &mut dyn std::io::Write,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    grains: Option<&[u32]>,
) -> std::io::Result<()> {
    let l = packing.cell.map(|c| c.lengths).unwrap_or_default();
    let mol = |p: usize| grains.map_or(1, |g| u64::from(g[p]) + 1);
    let what = if grains.is_some() {
        "; molecule = grain + 1"
    } else {
        ""
    };
    writeln!(w, "LIGGGHTS data file written by anisobond (atom_style hybrid granular molecular, bond_style harmonic{what})\n")?;
    writeln!(
        w,
        "{} atoms\n{} bonds\n1 atom types\n{} bond types\n",
        packing.len(),
        bonds.len(),
        bonds.len()
    )?;
    writeln!(
        w,
        "0 {} xlo xhi\n0 {} ylo yhi\n0 {} zlo zhi\n",
        num(l.x),
        num(l.y),
        num(l.z)
    )?;
    writeln!(w, "Bond Coeffs\n")?;
    for b in 0..bonds.len() {
        writeln!(
            w,
            "{} {} {}",
            b + 1,
            num(0.5 * k.kn[b]),
            num(bonds.length[b])
        )?;
    }
    writeln!(w, "\nAtoms\n")?;
    for (p, (x, r)) in packing.positions.iter().zip(&packing.radii).enumerate() {
        writeln!(
            w,
            "{} 1 {} {} {} {} {} {}",
            id_of(packing, p),
            num(x.x),
            num(x.y),
            num(x.z),
            num(2.0 * r),
            num(density),
            mol(p)
        )?;
    }
    writeln!(w, "\nBonds\n")?;
    for b in 0..bonds.len() {
        writeln!(
            w,
            "{} {} {} {}",
            b + 1,
            b + 1,
            id_of(packing, bonds.i[b] as usize),
            id_of(packing, bonds.j[b] as usize)
        )?;
    }
    Ok(())
}

pub use crate::history::StressHistory;

/// The header lines of the stock deck `harmonic.in` that say how to run it and what it
/// leaves out.
const HARMONIC_LIMITS: &str = "\
# Run:  stdbuf -o0 liggghts -in harmonic.in   (stdbuf keeps LIGGGHTS' ERROR message on abort)
# LIMITS: normal springs only. Each bond is its own bond type with K = k_n/2 (harmonic energy K(r−r0)²)
#   and r0 = its initial length. k_s, k_r, k_tw are IGNORED: this is the model with k_s = 0 and no moments,
#   which is softer than the anisobond model (and may be a mechanism where k_s carried load).
#   Use the driver deck anisobond.in (anisobond-liggghts) for the full per-bond law.
# LIMITS: normal load cases only (11, 22, 33; columns 1-3 of C): LIGGGHTS 3.8 builds no periodic ghost images
#   for a triclinic box, so bonds across the boundary would break under shear of the box.
";

/// The set-up of a stock `bond_style harmonic` deck reading `data_file`: granular +
/// molecular atoms, periodic box, and a ghost cut-off of 1.1 × the longest bond (m) so that
/// every bond's partner is present on each process.
#[cfg(feature = "engines")]
pub(crate) fn harmonic_setup(s: &mut String, data_file: &str, max_bond_length: f64) {
    harmonic_setup_with_boundary(s, data_file, max_bond_length, "p p p");
}

/// [`harmonic_setup`] with the `boundary` flags given (`p p m` for a box of mixed
/// periodicity, [`super::deck_boundary`]).
fn harmonic_setup_with_boundary(
    s: &mut String,
    data_file: &str,
    max_bond_length: f64,
    boundary: &str,
) {
    let _ = writeln!(s, "units si\natom_style hybrid granular molecular\natom_modify map array sort 0 0.0\nboundary {boundary}\nnewton on");
    let _ = writeln!(
        s,
        "communicate single vel yes cutoff {}",
        num(1.1 * max_bond_length)
    );
    let _ = writeln!(s, "bond_style harmonic\nread_data {data_file}");
}

/// The deck variables `s11 … s12`: the stress σ = −p (Pa, tension positive) in Voigt order
/// from `compute p all pressure` (whose order is xx yy zz xy xz yz).
pub fn stress_variables(s: &mut String) {
    for (name, idx) in [
        ("s11", 1),
        ("s22", 2),
        ("s33", 3),
        ("s23", 6),
        ("s13", 5),
        ("s12", 4),
    ] {
        let _ = writeln!(s, "variable {name} equal -c_p[{idx}]");
    }
}

/// Read `stress_history.txt` (`# …` comment lines, then `step e11 … e12 s11 … s12`); the
/// file has no time column, so `time` is left empty.
pub fn read_stress_history(path: &Path) -> Result<StressHistory> {
    let text = crate::io::read_to_string(path)?;
    let mut h = StressHistory::default();
    for (ln, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        if f.len() != 13 {
            return Err(Error::parse(
                path,
                ln + 1,
                format!(
                    "expected 13 columns (step, 6 strains, 6 stresses), found {}",
                    f.len()
                ),
            ));
        }
        let step = f[0]
            .parse::<f64>()
            .map_err(|_| Error::parse(path, ln + 1, format!("step `{}` is not a number", f[0])))?;
        let mut v = [0.0; 12];
        for (c, x) in f[1..].iter().enumerate() {
            v[c] = x.parse::<f64>().map_err(|_| {
                Error::parse(
                    path,
                    ln + 1,
                    format!("column {}: `{x}` is not a number", c + 2),
                )
            })?;
        }
        h.step.push(step as u64);
        h.strain.push([v[0], v[1], v[2], v[3], v[4], v[5]]);
        h.stress.push([v[6], v[7], v[8], v[9], v[10], v[11]]);
    }
    Ok(h)
}

/// The columns of the tensor (Pa) measured by the load cases run, in Voigt order:
/// column a = (σ(end_a) − σ(end_{a−1})) / (e_a(end_a) − e_a(end_{a−1})), with the
/// stress-free start as case 0.
pub fn columns_from_cases(h: &StressHistory, case_end_steps: &[u64]) -> Result<Vec<[f64; 6]>> {
    if case_end_steps.len() > 6 {
        return Err(Error::Invalid(format!(
            "at most 6 load cases, got {}",
            case_end_steps.len()
        )));
    }
    let row = |step: u64| -> Result<usize> {
        h.step.iter().position(|&s| s == step).ok_or_else(|| {
            Error::Invalid(format!("stress history has no line for step {step} (the end of a load case): did the run finish?"))
        })
    };
    let mut cols = Vec::with_capacity(case_end_steps.len());
    let mut prev_s = [0.0; 6];
    let mut prev_e = [0.0; 6];
    for (a, &step) in case_end_steps.iter().enumerate() {
        let r = row(step)?;
        let de = h.strain[r][a] - prev_e[a];
        if de == 0.0 {
            return Err(Error::Invalid(format!(
                "load case {} applied no strain",
                a + 1
            )));
        }
        let mut col = [0.0; 6];
        for b in 0..6 {
            col[b] = (h.stress[r][b] - prev_s[b]) / de;
        }
        cols.push(col);
        prev_s = h.stress[r];
        prev_e = h.strain[r];
    }
    Ok(cols)
}

/// The full 6×6 tensor (Pa) from the six load cases (see [`columns_from_cases`]).
pub fn tensor_from_cases(h: &StressHistory, case_end_steps: &[u64]) -> Result<Stiffness6> {
    if case_end_steps.len() != 6 {
        return Err(Error::Invalid(format!(
            "the 6×6 tensor needs the six load cases, the run had {} (export with shear cases)",
            case_end_steps.len()
        )));
    }
    let cols = columns_from_cases(h, case_end_steps)?;
    Ok(Stiffness6::from_fn(|b, a| cols[a][b]))
}

#[cfg(feature = "engines")]
/// How to launch LIGGGHTS.
#[derive(Clone, Debug, PartialEq)]
pub struct Launch {
    /// The program (`liggghts` or the driver `anisobond-liggghts`).
    pub program: PathBuf,
    /// `None`: serial, through `stdbuf -o0` when available (LIGGGHTS loses its ERROR message
    /// on abort otherwise); `Some(n)`: `mpirun --allow-run-as-root -np n`.
    pub mpi_processes: Option<usize>,
    /// Extra `-var NAME VALUE` pairs.
    pub vars: Vec<(String, String)>,
}

#[cfg(feature = "engines")]
/// Run `deck` (a file in `dir`) in `dir`; the screen output is returned, and on failure the
/// error carries LIGGGHTS' `ERROR` line.
pub fn run_liggghts(launch: &Launch, dir: &Path, deck: &str) -> Result<String> {
    let mut args: Vec<String> = Vec::new();
    let mut cmd = match launch.mpi_processes {
        Some(n) => {
            args.extend(["--allow-run-as-root".into(), "-np".into(), n.to_string()]);
            args.push(launch.program.display().to_string());
            Command::new("mpirun")
        }
        None if which("stdbuf") => {
            args.extend(["-o0".into(), launch.program.display().to_string()]);
            Command::new("stdbuf")
        }
        None => Command::new(&launch.program),
    };
    args.extend([
        "-in".into(),
        deck.into(),
        "-log".into(),
        "log.liggghts".into(),
    ]);
    for (k, v) in &launch.vars {
        args.extend(["-var".into(), k.clone(), v.clone()]);
    }
    let out = cmd.args(&args).current_dir(dir).output().map_err(|e| {
        Error::engine(
            "LIGGGHTS",
            format!("cannot start {}: {e}", launch.program.display()),
        )
    })?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let error_line = stdout
        .lines()
        .chain(stderr.lines())
        .find(|l| l.contains("ERROR"))
        .map(str::to_string);
    if !out.status.success() || error_line.is_some() {
        let msg = error_line.unwrap_or_else(|| {
            let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
            tail.into_iter().rev().collect::<Vec<_>>().join(" | ")
        });
        return Err(Error::engine(
            "LIGGGHTS",
            format!(
                "{} -in {deck} failed in {} ({}): {msg}",
                launch.program.display(),
                dir.display(),
                out.status
            ),
        ));
    }
    Ok(stdout)
}

#[cfg(feature = "engines")]
/// LIGGGHTS' version from its screen output `out` (its `LIGGGHTS (…)` line), else `unknown`.
pub fn liggghts_version(out: &str) -> String {
    out.lines()
        .find_map(|l| l.trim().strip_prefix("LIGGGHTS ("))
        .map(|l| l.trim_end_matches(')').to_string())
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(feature = "engines")]
/// True when `program` is found on PATH.
pub fn which(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(program).is_file()))
}

/// The many-body term (docs/manybody.md) as `pair_style anisobond … manybody FILE` reads it:
/// D (one, or one per grain of a polycrystal: [`ManyBody::tensors`]), the measure, each
/// particle's volume share V_p (0: excluded) and tensor, and each bond's fit coefficients
/// a = A_p⁻¹ L_b at its two ends, L_b oriented from the bond's first particle to its second
/// as in the bond table, so F_p = Σ_b l_b ⊗ a_b at either end.
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodyTable {
    /// The lab-frame Voigt matrices D (Pa): one, or one per grain (grain g's is entry g,
    /// rotate(D, gᵀ) as [`crate::manybody::ManyBodySpec::grain_tensors`] turns it).
    pub tensors: Vec<Stiffness6>,
    /// The strain measure.
    pub measure: StrainMeasure,
    /// (atom id, V_p in m³) of every particle, V_p = 0 for an excluded one.
    pub volumes: Vec<(u64, f64)>,
    /// The entry of `tensors` every particle loads (aligned with `volumes`; all 0 with one).
    pub tensor: Vec<u32>,
    /// One per bond, in the bond table's order.
    pub bonds: Vec<ManyBodyBond>,
}

/// One bond's fit coefficients in a [`ManyBodyTable`].
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodyBond {
    /// Atom ids of its first and second particle (as `id_i,id_j` of the bond table).
    pub ids: [u64; 2],
    /// A_i⁻¹ L_b at the first particle (zero when it is excluded), 1/m.
    pub coef_i: Vec3,
    /// A_j⁻¹ L_b at the second particle (zero when it is excluded), 1/m.
    pub coef_j: Vec3,
}

/// The [`ManyBodyTable`] of `term`, the term of `bonds` on `packing`: A_p = Σ_b L_b ⊗ L_b
/// over p's bonds in bond order and its inverse as [`ManyBody::new`] forms them, so the
/// coefficients are the library's own; atom ids as the bond table writes them.
pub fn manybody_table(
    packing: &Packing,
    bonds: &BondSet,
    term: &ManyBody,
) -> Result<ManyBodyTable> {
    let n = packing.len();
    let refs = term.reference_branches();
    if term.len() != n || refs.len() != bonds.len() {
        return Err(Error::Invalid(format!(
            "many-body table: the term has {} particles and {} bonds, the packing {n} and {}",
            term.len(),
            refs.len(),
            bonds.len()
        )));
    }
    let mut excluded = vec![false; n];
    for &p in term.excluded() {
        excluded[p as usize] = true;
    }
    let mut a = vec![Mat3::zeros(); n];
    for (b, l) in refs.iter().enumerate() {
        a[bonds.i[b] as usize] += l * l.transpose();
        a[bonds.j[b] as usize] += l * l.transpose();
    }
    let mut inv = vec![Mat3::zeros(); n];
    for p in (0..n).filter(|&p| !excluded[p]) {
        inv[p] = a[p].try_inverse().ok_or_else(|| {
            Error::Degenerate(format!(
                "many-body table: particle {p} is in the term but Σ L⊗L of its bonds cannot be inverted"
            ))
        })?;
    }
    let ids = super::engine_ids(packing);
    let id = |p: usize| ids.map_or(p as u64 + 1, |ids| ids[p]);
    Ok(ManyBodyTable {
        tensors: term.tensors().to_vec(),
        measure: term.measure(),
        tensor: (0..n).map(|p| term.tensor_index(p) as u32).collect(),
        volumes: term
            .particle_volumes()
            .iter()
            .enumerate()
            .map(|(p, &v)| (id(p), v))
            .collect(),
        bonds: (0..bonds.len())
            .map(|b| {
                let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
                ManyBodyBond {
                    ids: [id(i), id(j)],
                    coef_i: inv[i] * refs[b],
                    coef_j: inv[j] * refs[b],
                }
            })
            .collect(),
    })
}

/// The many-body term's share of each particle's stiffness (N/m) for the time step, as
/// [`stable_timestep`] bounds the springs' by their sum: the diagonal Hessian blocks at the
/// reference, V_p B(c, c) per stencil node, bounded by Σ_p V_p ‖D_p‖ |c_r^p|² with ‖D_p‖ the
/// largest absolute row sum of p's D (its grain's) and c_r^p the coefficient of node r in F_p
/// (docs/manybody.md, "Derivatives"). `t` must be the table of `bonds` (same order).
fn manybody_stiffness(n: usize, bonds: &BondSet, t: &ManyBodyTable) -> Vec<f64> {
    let norms: Vec<f64> = t
        .tensors
        .iter()
        .map(|d| {
            (0..6)
                .map(|r| (0..6).map(|c| d[(r, c)].abs()).sum::<f64>())
                .fold(0.0, f64::max)
        })
        .collect();
    // V_p ‖D_p‖ of every particle (its own grain's D).
    let weight: Vec<f64> = (0..n)
        .map(|p| t.volumes[p].1 * norms[t.tensor[p] as usize])
        .collect();
    let mut own = vec![Vec3::zeros(); n];
    let mut k = vec![0.0; n];
    for (b, row) in t.bonds.iter().enumerate() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        own[i] -= row.coef_i;
        own[j] += row.coef_j;
        k[j] += weight[i] * row.coef_i.norm_squared();
        k[i] += weight[j] * row.coef_j.norm_squared();
    }
    for p in 0..n {
        k[p] += weight[p] * own[p].norm_squared();
    }
    k
}

/// Write `table` to `path` (shortest round-trip numbers: the same bits read back):
/// `measure M`, `d` and its 36 entries (row-major Voigt, Pa), `particles N` then N lines
/// `id V_p`, `bonds M` then M lines `id_i id_j a_i(3) a_j(3)`; `#` starts a comment. With a
/// tensor per grain (a polycrystal) `tensors G` and G lines `d …` (grain 0 first) replace the
/// one `d` line and every particle line ends with its tensor: `id V_p g` (docs/formats.md).
pub fn write_manybody_table(path: &Path, table: &ManyBodyTable) -> Result<()> {
    if table.tensor.len() != table.volumes.len()
        || table
            .tensor
            .iter()
            .any(|&g| g as usize >= table.tensors.len())
    {
        return Err(Error::Invalid(format!(
            "many-body table: {} tensor indices for {} particles, {} tensors",
            table.tensor.len(),
            table.volumes.len(),
            table.tensors.len()
        )));
    }
    let several = table.tensors.len() != 1;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# anisobond many-body term for pair_style anisobond … manybody FILE (docs/manybody.md):\n\
         # D (Voigt, Pa, lab frame, row-major), the strain measure, each particle's volume share V_p\n\
         # (m³; 0 = excluded: fewer than three non-coplanar bonds) and each bond's fit coefficients\n\
         # a = A_p⁻¹ L_b (1/m) at its first and second particle, in the bond table's order."
    );
    if several {
        let _ = writeln!(
            s,
            "# A polycrystal: one D per grain (rotate(D, gᵀ), grain 0 first); each particle line\n\
             # `id V_p g` names its grain's D."
        );
    }
    let _ = writeln!(
        s,
        "measure {}",
        match table.measure {
            StrainMeasure::GreenLagrange => "green-lagrange",
            StrainMeasure::Small => "small",
        }
    );
    if several {
        let _ = writeln!(s, "tensors {}", table.tensors.len());
    }
    for t in &table.tensors {
        let d: Vec<String> = (0..6)
            .flat_map(|r| (0..6).map(move |c| (r, c)))
            .map(|(r, c)| num(t[(r, c)]))
            .collect();
        let _ = writeln!(s, "d {}", d.join(" "));
    }
    let _ = writeln!(s, "particles {}", table.volumes.len());
    for ((id, v), g) in table.volumes.iter().zip(&table.tensor) {
        if several {
            let _ = writeln!(s, "{id} {} {g}", num(*v));
        } else {
            let _ = writeln!(s, "{id} {}", num(*v));
        }
    }
    let _ = writeln!(s, "bonds {}", table.bonds.len());
    for b in &table.bonds {
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {} {}",
            b.ids[0],
            b.ids[1],
            num(b.coef_i.x),
            num(b.coef_i.y),
            num(b.coef_i.z),
            num(b.coef_j.x),
            num(b.coef_j.y),
            num(b.coef_j.z)
        );
    }
    crate::io::write_string_atomic(path, &s)
}

/// Read a table written by [`write_manybody_table`]; a malformed line is refused naming
/// the file, the line and what was expected ([`Error::Parse`]).
pub fn read_manybody_table(path: &Path) -> Result<ManyBodyTable> {
    let text = crate::io::read_to_string(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(k, l)| (k + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let bad = |line: usize, m: String| Error::parse(path, line, m);
    let mut next = |what: &str| {
        lines
            .next()
            .ok_or_else(|| bad(0, format!("ends early: expected {what}")))
    };
    let number = |line: usize, w: &str, what: &str| -> Result<f64> {
        w.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                bad(
                    line,
                    format!("{what}: expected a finite number, found `{w}`"),
                )
            })
    };
    let keyed = |(line, l): (usize, &str), key: &str, count: usize| -> Result<Vec<String>> {
        let w: Vec<&str> = l.split_whitespace().collect();
        if w[0] != key || w.len() != count + 1 {
            return Err(bad(
                line,
                format!("expected `{key}` and {count} value(s), found `{l}`"),
            ));
        }
        Ok(w[1..].iter().map(|s| s.to_string()).collect())
    };
    let first = next("`measure green-lagrange|small`")?;
    let measure = match keyed(first, "measure", 1)?[0].as_str() {
        "green-lagrange" => StrainMeasure::GreenLagrange,
        "small" => StrainMeasure::Small,
        other => {
            return Err(bad(
                first.0,
                format!("measure `{other}`: expected green-lagrange or small"),
            ))
        }
    };
    let read_d = |dl: (usize, &str)| -> Result<Stiffness6> {
        let dv = keyed(dl, "d", 36)?;
        let mut d = Stiffness6::zeros();
        for (k, w) in dv.iter().enumerate() {
            d[(k / 6, k % 6)] = number(dl.0, w, "d")?;
        }
        Ok(d)
    };
    let count = |(line, l): (usize, &str), key: &str| -> Result<usize> {
        let w = keyed((line, l), key, 1)?;
        w[0].parse::<usize>()
            .map_err(|_| bad(line, format!("`{key}`: expected a count, found `{}`", w[0])))
    };
    // One `d` line, or `tensors G` and G of them (a polycrystal: particle lines name theirs).
    let dl = next("`d` and 36 numbers, or `tensors G`")?;
    let (tensors, several) = if dl.1.starts_with("tensors") {
        let g = count(dl, "tensors")?;
        if g == 0 {
            return Err(bad(dl.0, "`tensors 0`: expected at least one D".into()));
        }
        let mut t = Vec::with_capacity(g);
        for _ in 0..g {
            t.push(read_d(next("a `d` line and 36 numbers")?)?);
        }
        (t, true)
    } else {
        (vec![read_d(dl)?], false)
    };
    let id = |line: usize, w: &str| -> Result<u64> {
        w.parse::<u64>()
            .ok()
            .filter(|&v| v >= 1)
            .ok_or_else(|| bad(line, format!("expected an atom id ≥ 1, found `{w}`")))
    };
    let pl = next("`particles N`")?;
    let np = count(pl, "particles")?;
    let mut volumes = Vec::with_capacity(np);
    let mut tensor = Vec::with_capacity(np);
    let columns = if several { "`id V_p g`" } else { "`id V_p`" };
    for _ in 0..np {
        let (line, l) = next(&format!("a particle line {columns}"))?;
        let w: Vec<&str> = l.split_whitespace().collect();
        if w.len() != if several { 3 } else { 2 } {
            return Err(bad(line, format!("expected {columns}, found `{l}`")));
        }
        let v = number(line, w[1], "V_p")?;
        if v < 0.0 {
            return Err(bad(line, format!("V_p = {v}: expected ≥ 0 (m³)")));
        }
        volumes.push((id(line, w[0])?, v));
        let g = match w.get(2) {
            None => 0,
            Some(g) => g
                .parse::<u32>()
                .ok()
                .filter(|&g| (g as usize) < tensors.len())
                .ok_or_else(|| {
                    bad(
                        line,
                        format!(
                            "tensor `{g}`: expected one of the {} tensors, 0 to {}",
                            tensors.len(),
                            tensors.len() - 1
                        ),
                    )
                })?,
        };
        tensor.push(g);
    }
    let bl = next("`bonds M`")?;
    let nb = count(bl, "bonds")?;
    let mut bonds = Vec::with_capacity(nb);
    for _ in 0..nb {
        let (line, l) = next("a bond line `id_i id_j a_i(3) a_j(3)`")?;
        let w: Vec<&str> = l.split_whitespace().collect();
        if w.len() != 8 {
            return Err(bad(
                line,
                format!("expected `id_i id_j` and six coefficients, found `{l}`"),
            ));
        }
        let c = |k: usize| number(line, w[k], "coefficient");
        bonds.push(ManyBodyBond {
            ids: [id(line, w[0])?, id(line, w[1])?],
            coef_i: Vec3::new(c(2)?, c(3)?, c(4)?),
            coef_j: Vec3::new(c(5)?, c(6)?, c(7)?),
        });
    }
    if let Some((line, l)) = lines.next() {
        return Err(bad(
            line,
            format!("unexpected line after the {nb} bonds: `{l}`"),
        ));
    }
    Ok(ManyBodyTable {
        tensors,
        measure,
        volumes,
        tensor,
        bonds,
    })
}
