//! Export to YADE 2023.02a: a directory that runs as it is with `yade -n -x DIR/run.py`,
//! and readers for what that run writes (for validation against anisobond's own solvers).
//!
//! DIR receives `packing.txt` (SPEC packing), `bonds.csv` (SPEC bond table: the springs
//! YADE uses, bond by bond), `model.toml`, `anisobond_yade.py` (the reusable module of
//! `yade-scripts/`, embedded in the binary) and `run.py`. The run performs the six-path
//! element test in the periodic cell (velocity gradient; strain in one step, Cundall
//! damping, Truszkowska 2018 Eqs. 17–22 paths) and writes `yade-history.csv` (stress and
//! strain after every step) and `yade-tensor.json` (SPEC tensor report, method "yade").
//! The YADE traps the module handles are listed in its docstring and in
//! `yade-scripts/README.md`.
//!
//! A model with a `[strength]` table (docs/strength.md, "YADE") adds three columns to
//! `bonds.csv`, [`ADHESION_COLUMNS`]: each bond's CohFrictPhys `normalAdhesion`,
//! `shearAdhesion` (N) and `tangensOfFrictionAngle` from [`yade_adhesions`]; the module then
//! builds its bonds `fragile`, so YADE breaks them by its own criterion. Without the table
//! `bonds.csv` is the plain SPEC table and the bonds never break, as before.

use crate::assembly::Assembly;
use crate::bonds::{table, BondSet, BondStiffness};
use crate::grains::assign_strength_by_grain;
use crate::model::Model;
use crate::packing::{self, Packing};
use crate::strength::criteria::YadeAdhesion;
use crate::strength::StrengthSpec;
use crate::tensor::{Stiffness6, Voigt6};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
#[cfg(feature = "engines")]
use std::process::Command;

/// The Python module `yade-scripts/anisobond_yade.py`, embedded so the binary is
/// self-contained.
pub const YADE_MODULE: &str = include_str!("../../yade-scripts/anisobond_yade.py");

/// File names written into the export directory.
pub mod files {
    /// SPEC packing.
    pub const PACKING: &str = "packing.txt";
    /// SPEC bond table.
    pub const BONDS: &str = "bonds.csv";
    /// The model the bonds were made with.
    pub const MODEL: &str = "model.toml";
    /// The embedded Python module.
    pub const MODULE: &str = "anisobond_yade.py";
    /// The ready-to-run script.
    pub const RUN: &str = "run.py";
    /// Stress history written by the run.
    pub const HISTORY: &str = "yade-history.csv";
    /// Tensor report written by the run.
    pub const TENSOR: &str = "yade-tensor.json";
    /// A polycrystal's grain id of every particle (docs/formats.md "Grain files").
    pub const GRAINS: &str = "grains.txt";
}

/// Columns appended to the export's `bonds.csv` when the model has a `[strength]` table:
/// YADE's `normalAdhesion` a_n, `shearAdhesion` a_s (N) and `tangensOfFrictionAngle` tan φ
/// of each bond (`anisobond_yade.read_bond_table` reads them; readers that find columns by
/// name ignore them).
pub const ADHESION_COLUMNS: [&str; 3] = ["normal_adhesion", "shear_adhesion", "tan_friction"];

/// Every bond's YADE CohFrict limits by `model`'s `[strength]` table, `None` when it has
/// none: the bond's strength ([`assign_strength_by_grain`]: scheme, planes of weakness,
/// scatter, the grain-boundary factor) as
/// `Ip2_CohFrictMat_CohFrictMat_CohFrictPhys` turns cohesions into adhesions,
/// a_n = σ_t·r², a_s = c·r², r = min(R_i, R_j) ([`YadeAdhesion::of`]; YADE 2023.02a's moments
/// are elastic). A joint bond takes its joint's σ_t, c_w, μ_w, judged by YADE's own law along
/// the bond (YADE has no plane criterion; docs/strength.md, "YADE").
pub fn yade_adhesions(
    packing: &Packing,
    bonds: &BondSet,
    model: &Model,
) -> Result<Option<Vec<YadeAdhesion>>> {
    let Some(table) = &model.strength else {
        return Ok(None);
    };
    let spec = StrengthSpec::from_table(table)?;
    spec.refuse_cut_sections("YADE export")?;
    Ok(Some(adhesions_of(
        packing,
        bonds,
        &assign_strength_by_grain(packing, bonds, &spec, model.grains.as_ref(), None)?,
    )))
}

/// Every bond's YADE 2023.02a adhesions (`YadeAdhesion::of`, r = the smaller radius, moments
/// elastic) from its strength.
pub fn adhesions_of(
    packing: &Packing,
    bonds: &BondSet,
    strengths: &crate::strength::BondStrengths,
) -> Vec<YadeAdhesion> {
    let r = &packing.radii;
    strengths
        .map(|b, st| YadeAdhesion::of(&st, r[bonds.i[b] as usize], r[bonds.j[b] as usize], false))
}

/// The [`ADHESION_COLUMNS`] of a bond table file, one record per row (empty when the header
/// has none of them; all three or none): what `write_yade_export` wrote, read back for the
/// engines' plugins. A bad value is refused with the file and line.
pub fn read_adhesion_columns(path: &Path) -> Result<Vec<YadeAdhesion>> {
    let text = crate::io::read_to_string(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(Error::parse(
            path,
            1,
            "empty file: expected a bond table header",
        ));
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let idx: Vec<Option<usize>> = ADHESION_COLUMNS
        .iter()
        .map(|c| cols.iter().position(|h| h == c))
        .collect();
    if idx.iter().all(Option::is_none) {
        return Ok(Vec::new());
    }
    if idx.iter().any(Option::is_none) {
        return Err(Error::parse(
            path,
            1,
            format!(
                "the header has some of the adhesion columns `{}` but not all",
                ADHESION_COLUMNS.join(",")
            ),
        ));
    }
    let idx: Vec<usize> = idx.into_iter().flatten().collect();
    let mut out = Vec::new();
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(Error::parse(
                path,
                n + 1,
                format!("expected {} fields, found {}", cols.len(), fields.len()),
            ));
        }
        let mut v = [0.0; 3];
        for (k, &c) in idx.iter().enumerate() {
            v[k] = fields[c]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| {
                    Error::parse(
                        path,
                        n + 1,
                        format!(
                            "column `{}`: expected a finite number >= 0, found `{}`",
                            ADHESION_COLUMNS[k], fields[c]
                        ),
                    )
                })?;
        }
        out.push(YadeAdhesion {
            normal: v[0],
            shear: v[1],
            tan_friction: v[2],
            cohesion_disables_friction: false,
            moments: crate::strength::criteria::YadeMoments::Elastic,
        });
    }
    Ok(out)
}

/// The bond table text with the [`ADHESION_COLUMNS`] appended to every row (`adhesions`
/// aligned with the bonds), written atomically to `path`.
pub(crate) fn write_bond_table_with_adhesions(
    path: &Path,
    bonds: &BondSet,
    springs: &BondStiffness,
    ids: Option<&[u64]>,
    adhesions: &[YadeAdhesion],
) -> Result<()> {
    let mut plain = Vec::new();
    table::write_bond_table_ids_to(&mut plain, bonds, springs, ids)
        .map_err(|e| Error::io(path, e))?;
    let plain = String::from_utf8(plain).expect("the bond table writer writes ASCII");
    let mut out = String::with_capacity(plain.len() + 64 * adhesions.len() + 64);
    let mut lines = plain.lines();
    let header = lines.next().unwrap_or_default();
    let _ = writeln!(out, "{header},{}", ADHESION_COLUMNS.join(","));
    let mut buf = ryu::Buffer::new();
    for (row, a) in lines.zip(adhesions) {
        out.push_str(row);
        for v in [a.normal, a.shear, a.tan_friction] {
            out.push(',');
            out.push_str(buf.format(v));
        }
        out.push('\n');
    }
    crate::io::write_string_atomic(path, &out)
}

/// Voigt labels of the six strain paths, in order (11, 22, 33, 23, 13, 12).
pub const PATH_LABELS: [&str; 6] = ["11", "22", "33", "23", "13", "12"];

/// Settings of the element test that `run.py` performs (its defaults; each can be
/// overridden on the YADE command line, e.g. `yade -n -x run.py --damping 0`).
#[derive(Clone, Debug, PartialEq)]
pub struct YadeRunOptions {
    /// Strain of each path, applied in one step (engineering; uniaxial e_aa or shear γ_ab).
    pub strain: f64,
    /// Steps after the strain step (relaxation, or the undamped history length).
    pub steps: usize,
    /// Cundall non-viscous damping λ of YADE's NewtonIntegrator (0 = undamped).
    pub damping: f64,
    /// Particle density (kg/m³): masses (4/3)πR³ρ, inertias (2/5)mR².
    pub density: f64,
    /// Time step (s); `None`: `safety` × the Gershgorin bound of the critical step.
    pub time_step: Option<f64>,
    /// Fraction of the critical time step used when `time_step` is `None`.
    pub safety: f64,
    /// The paths to run (Voigt indices 0–5); all six give the 6×6 tensor.
    pub paths: Vec<usize>,
    /// Volume (m³) the stresses are per; `None`: YADE's cell. Set for a box of mixed
    /// periodicity to the box as read, as the LIGGGHTS and LAMMPS decks report it.
    pub stress_volume: Option<f64>,
}

impl Default for YadeRunOptions {
    /// Strain 1e-5 in one step, 200 steps, damping 0.4, density 2600 kg/m³, dt = 0.8 dt_c,
    /// all six paths.
    fn default() -> Self {
        YadeRunOptions {
            strain: 1e-5,
            steps: 200,
            damping: 0.4,
            density: 2600.0,
            time_step: None,
            safety: 0.8,
            paths: (0..6).collect(),
            stress_volume: None,
        }
    }
}

impl YadeRunOptions {
    /// Check every value; the error names the option and the admissible range.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("YADE run options: {m}")));
        if !self.strain.is_finite() || self.strain <= 0.0 || self.strain > 0.01 {
            return bad(format!("strain must be in (0, 0.01], got {}", self.strain));
        }
        if self.steps == 0 {
            return bad("steps must be at least 1".into());
        }
        if !self.damping.is_finite() || !(0.0..1.0).contains(&self.damping) {
            return bad(format!("damping must be in [0, 1), got {}", self.damping));
        }
        if !self.density.is_finite() || self.density <= 0.0 {
            return bad(format!(
                "density must be finite and > 0, got {}",
                self.density
            ));
        }
        if let Some(dt) = self.time_step {
            if !dt.is_finite() || dt <= 0.0 {
                return bad(format!("time step must be finite and > 0, got {dt}"));
            }
        }
        if !self.safety.is_finite() || self.safety <= 0.0 || self.safety > 1.0 {
            return bad(format!(
                "safety factor must be in (0, 1], got {}",
                self.safety
            ));
        }
        if self.paths.is_empty() || self.paths.iter().any(|&p| p > 5) {
            return bad(format!(
                "paths must be Voigt indices 0–5 (11, 22, 33, 23, 13, 12), got {:?}",
                self.paths
            ));
        }
        if let Some(v) = self.stress_volume.filter(|v| !(v.is_finite() && *v > 0.0)) {
            return bad(format!("stress volume must be finite and > 0 m³, got {v}"));
        }
        Ok(())
    }

    /// The options as `anisobond_yade.main` command-line arguments.
    pub fn to_args(&self) -> Vec<String> {
        let mut a = vec![
            "--strain".to_string(),
            format!("{:e}", self.strain),
            "--steps".into(),
            self.steps.to_string(),
            "--damping".into(),
            format!("{:?}", self.damping),
            "--density".into(),
            format!("{:?}", self.density),
            "--safety".into(),
            format!("{:?}", self.safety),
            "--paths".into(),
            self.paths
                .iter()
                .map(|&p| PATH_LABELS[p])
                .collect::<Vec<_>>()
                .join(","),
        ];
        if let Some(dt) = self.time_step {
            a.push("--dt".into());
            a.push(format!("{dt:e}"));
        }
        if let Some(v) = self.stress_volume {
            a.push("--stress-volume".into());
            a.push(format!("{v:e}"));
        }
        a
    }
}

/// Parse a comma-separated list of path labels (`11,22,33,23,13,12`) into Voigt indices.
pub fn parse_paths(text: &str) -> Result<Vec<usize>> {
    text.split(',')
        .map(str::trim)
        .filter(|w| !w.is_empty())
        .map(|w| {
            PATH_LABELS.iter().position(|l| *l == w).ok_or_else(|| {
                Error::Invalid(format!(
                    "unknown strain path `{w}`: expected labels among 11,22,33,23,13,12"
                ))
            })
        })
        .collect()
}

/// Paths of the files of an export directory.
#[derive(Clone, Debug, PartialEq)]
pub struct YadeExport {
    /// The directory.
    pub dir: PathBuf,
    /// `run.py`.
    pub run_script: PathBuf,
    /// Where the run writes its stress history.
    pub history: PathBuf,
    /// Where the run writes its tensor report.
    pub tensor: PathBuf,
    /// Number of particles.
    pub n_particles: usize,
    /// Number of bonds.
    pub n_bonds: usize,
    /// The strain paths `run.py` runs by default (Voigt indices): those asked for, or on a
    /// box of mixed periodicity those of them that strain periodic axes only.
    pub paths: Vec<usize>,
}

impl YadeExport {
    /// The paths of an export directory (whether or not it has been written).
    pub fn in_dir(dir: &Path) -> YadeExport {
        YadeExport {
            dir: dir.to_path_buf(),
            run_script: dir.join(files::RUN),
            history: dir.join(files::HISTORY),
            tensor: dir.join(files::TENSOR),
            n_particles: 0,
            n_bonds: 0,
            paths: Vec::new(),
        }
    }
}

/// Check that a bonded packing can be run in YADE's periodic cell: periodic, with bonds,
/// every bond's indices inside the packing and its springs finite and ≥ 0.
pub fn check_exportable(p: &Packing, b: &BondSet, k: &BondStiffness) -> Result<()> {
    if p.cell.is_none() {
        return Err(Error::Invalid(
            "YADE export: the packing is not periodic (no `# periodic Lx Ly Lz` header); the \
             element tests deform a periodic cell"
                .into(),
        ));
    }
    if b.is_empty() {
        return Err(Error::Invalid(
            "YADE export: the model bonds no pair of this packing (increase the bonding value)"
                .into(),
        ));
    }
    if k.len() != b.len() {
        return Err(Error::Invalid(format!(
            "YADE export: {} bonds but {} spring sets",
            b.len(),
            k.len()
        )));
    }
    for n in 0..b.len() {
        if b.j[n] as usize >= p.len() || b.i[n] >= b.j[n] {
            return Err(Error::Invalid(format!(
                "YADE export: bond {n} joins {}–{}, expected 0 ≤ i < j < {}",
                b.i[n],
                b.j[n],
                p.len()
            )));
        }
        for (name, v) in [
            ("kn", k.kn[n]),
            ("ks", k.ks[n]),
            ("kr", k.kr[n]),
            ("ktw", k.ktw[n]),
        ] {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::Invalid(format!(
                    "YADE export: bond {n}: {name} = {v} must be finite and ≥ 0"
                )));
            }
        }
    }
    Ok(())
}

/// The `run.py` text: imports the module next to it and runs `main` with the files of
/// the directory and `opts`; arguments given to `yade -n -x run.py …` override them. With
/// `with_model`, `main` also gets the directory's `model.toml` (its springs and its
/// `[manybody]` term, run by the anisobond Python package inside YADE).
pub fn run_script(
    opts: &YadeRunOptions,
    n_particles: usize,
    n_bonds: usize,
    with_model: bool,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Written by anisobond {}: YADE 2023.02a element tests of {n_particles} particles, \
         {n_bonds} bonds.",
        env!("CARGO_PKG_VERSION")
    );
    s.push_str(
        "# Run:  yade -n -x run.py            (all six paths: writes yade-history.csv and \
         yade-tensor.json here)\n\
         # Override any default on the command line, e.g. the undamped step-by-step history:\n\
         #       yade -n -x run.py --damping 0 --steps 1000 --paths 11 --dt 1e-7\n\
         # Options: --strain --steps --damping --density --dt --safety --paths --history \
         --tensor\n\
         import os\n\
         import sys\n\n\
         sys.dont_write_bytecode = True\n\
         HERE = os.path.dirname(os.path.abspath(sys.argv[0]))  # YADE sets no __file__\n\
         sys.path.insert(0, HERE)\n\
         import anisobond_yade  # noqa: E402\n\n\
         DEFAULTS = [\n",
    );
    let mut args = vec![
        (
            "--packing".to_string(),
            format!("os.path.join(HERE, {:?})", files::PACKING),
        ),
        (
            "--bonds".to_string(),
            format!("os.path.join(HERE, {:?})", files::BONDS),
        ),
        ("--out".to_string(), "HERE".to_string()),
    ];
    if with_model {
        args.push((
            "--model".to_string(),
            format!("os.path.join(HERE, {:?})", files::MODEL),
        ));
    }
    let rest = opts.to_args();
    for pair in rest.chunks(2) {
        args.push((pair[0].clone(), format!("{:?}", pair[1])));
    }
    for (k, v) in args {
        let _ = writeln!(s, "    {k:?}, {v},");
    }
    s.push_str(
        "]\n\n\
         anisobond_yade.main(DEFAULTS + sys.argv[1:])\n",
    );
    s
}

/// Write an export directory for a bonded packing (created if missing). Everything is
/// checked before the first file is written, and every file is written atomically, so a
/// bad input leaves no file behind and no file is ever half-written. `model` (if given) is
/// saved as `model.toml` for the record.
pub fn write_yade_export(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    model: Option<&Model>,
    opts: &YadeRunOptions,
) -> Result<YadeExport> {
    write_yade_export_grains(dir, packing, bonds, springs, model, opts, None)
}

/// [`write_yade_export`] of a polycrystal: `grains` (each particle's grain id,
/// `Assembly::grains`) are written to `grains.txt` (the grain-file format) and `run.py`
/// passes them to `anisobond_yade`, which gives each sphere its grain's copy of the material
/// (labelled `anisobond-grain-G`, every value equal, so no interaction changes) and colour
/// (docs/polycrystal.md, "Grain ids in the engines").
pub fn write_yade_export_grains(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    model: Option<&Model>,
    opts: &YadeRunOptions,
    grains: Option<&[u32]>,
) -> Result<YadeExport> {
    super::check_grain_count(grains, packing.len(), "YADE export")?;
    // The many-body term is built here once, so a packing it cannot carry (rattlers refused,
    // no periodic cell for the default volumes) is refused before anything is written.
    if let Some(m) = model {
        crate::manybody::refuse_polycrystal_term(m, "export yade")?;
    }
    if let Some(spec) = model.and_then(|m| m.manybody.as_ref()) {
        spec.build(packing, bonds)?;
    }
    // Strengths by the positions as given (planes of weakness), before a mixed box shifts them.
    let adhesions = match model {
        Some(m) => yade_adhesions(packing, bonds, m)?,
        None => None,
    };
    let mixed = mixed_box(packing, bonds)?;
    let (packing, opts) = match &mixed {
        Some(m) => (&m.packing, &m.opts(opts)?),
        None => (packing, opts),
    };
    check_exportable(packing, bonds, springs)?;
    opts.validate()?;
    if let Some(dt) = opts.time_step {
        super::check_time_step(dt, packing, bonds, springs, opts.density, "--dt")?;
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    packing::io::write_packing(&dir.join(files::PACKING), packing)?;
    // YADE's bodies are the packing's spheres in order; the user's own particle ids (a data
    // file's, a dump's) are kept as the table's `id_i,id_j`, to map results back.
    match &adhesions {
        Some(a) => write_bond_table_with_adhesions(
            &dir.join(files::BONDS),
            bonds,
            springs,
            packing.ids.as_deref(),
            a,
        )?,
        None => table::write_bond_table_with_ids(
            &dir.join(files::BONDS),
            bonds,
            springs,
            packing.ids.as_deref(),
        )?,
    }
    if let Some(m) = model {
        crate::io::write_string_atomic(&dir.join(files::MODEL), &m.to_toml_string())?;
    }
    crate::io::write_string_atomic(&dir.join(files::MODULE), YADE_MODULE)?;
    let many_body = model.and_then(|m| m.manybody.as_ref());
    let mut script = run_script(opts, packing.len(), bonds.len(), many_body.is_some());
    if let Some(g) = grains {
        let mut text = String::with_capacity(8 * g.len() + 128);
        text.push_str(
            "# grain id of each particle of packing.txt, in its order (anisobond polycrystal)\n",
        );
        for id in g {
            let _ = writeln!(text, "{id}");
        }
        crate::io::write_string_atomic(&dir.join(files::GRAINS), &text)?;
        let out = "    \"--out\", HERE,\n";
        let arg = format!(
            "    \"--grains\", os.path.join(HERE, {:?}),\n",
            files::GRAINS
        );
        script = script.replacen(out, &format!("{out}{arg}"), 1);
        let first = script.find('\n').map_or(0, |n| n + 1);
        script.insert_str(
            first,
            "# A polycrystal: grains.txt gives each sphere its grain; anisobond_yade gives it its grain's\n\
             #   copy of the material (label anisobond-grain-G, values equal) and colour.\n",
        );
    }
    if many_body.is_some() {
        let first = script.find('\n').map_or(0, |n| n + 1);
        script.insert_str(
            first,
            "# The model has a [manybody] term: YADE's bond laws are pairwise, so it runs as a\n\
             #   PyRunner engine of anisobond_yade (add_manybody) whose forces the anisobond Python\n\
             #   package computes every step: install the package for YADE's Python\n\
             #   (pip install --target DIR anisobond; PYTHONPATH=DIR yade -n -x run.py).\n",
        );
    }
    if adhesions.is_some() {
        let first = script.find('\n').map_or(0, |n| n + 1);
        script.insert_str(
            first,
            "# The model has a [strength] table: bonds.csv gives each bond YADE's normalAdhesion,\n\
             #   shearAdhesion (N) and tangensOfFrictionAngle; the bonds are fragile and break by\n\
             #   YADE's CohFrict criterion (docs/strength.md, \"YADE\").\n",
        );
    }
    if let Some(m) = &mixed {
        let first = script.find('\n').map_or(0, |n| n + 1);
        script.insert_str(first, &m.note());
    }
    crate::io::write_string_atomic(&dir.join(files::RUN), &script)?;
    let mut out = YadeExport::in_dir(dir);
    out.n_particles = packing.len();
    out.n_bonds = bonds.len();
    out.paths = opts.paths.clone();
    Ok(out)
}

/// A box of mixed periodicity as YADE runs it. YADE's cell is periodic along every axis, so
/// each free axis's edge is extended to the spheres' extent along it plus a gap of
/// 2 × (largest diameter + longest bond), the spheres shifted along it (only if one reaches
/// below 0) so that they lie inside: no bond has an image along a free axis and the scene
/// holds only the bonds (no collider), so nothing crosses the extended faces, which stay free
/// surfaces. `run.py` reports stresses per the box as read (`--stress-volume`), not per
/// the extended cell.
pub struct MixedBox {
    /// The packing in the extended, fully periodic cell (ids and bonds' images unchanged).
    pub packing: Packing,
    /// The box as read: its edges and periodic axes.
    pub read: packing::PeriodicCell,
}

/// [`MixedBox`] of a packing whose box is periodic along some axes only; None otherwise.
pub fn mixed_box(packing: &Packing, bonds: &BondSet) -> Result<Option<MixedBox>> {
    let Some(cell) = packing.cell.filter(|c| c.is_mixed()) else {
        return Ok(None);
    };
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let max_r = packing.radii.iter().copied().fold(0.0, f64::max);
    let gap = 2.0 * (2.0 * max_r + max_len);
    let mut out = packing.clone();
    let mut lengths = cell.lengths;
    for k in (0..3).filter(|&k| !cell.periodic[k]) {
        let (lo, hi) = packing.bounding_box();
        let shift = (-lo[k]).max(0.0);
        for x in out.positions.iter_mut() {
            x[k] += shift;
        }
        for x in out.given_positions.iter_mut().flatten() {
            x[k] += shift;
        }
        lengths[k] = cell.lengths[k].max(hi[k] + shift) + gap;
    }
    out.cell = Some(packing::PeriodicCell::new(lengths)?);
    Ok(Some(MixedBox {
        packing: out,
        read: cell,
    }))
}

impl MixedBox {
    /// The strain paths run: those of `opts` that strain periodic axes only
    /// ([`super::load_cases`] of the box as read); none left is refused.
    fn opts(&self, opts: &YadeRunOptions) -> Result<YadeRunOptions> {
        let allowed = super::load_cases(&self.read);
        let paths: Vec<usize> = opts
            .paths
            .iter()
            .copied()
            .filter(|p| allowed.contains(p))
            .collect();
        if paths.is_empty() {
            let labels = |p: &[usize]| p.iter().map(|&k| PATH_LABELS[k]).collect::<Vec<_>>();
            return Err(Error::Invalid(format!(
                "YADE export: the box is periodic along some axes only (boundary {}): the strain \
                 paths {} all strain a free axis; expected some of {}",
                self.read.boundary(),
                labels(&opts.paths).join(","),
                labels(&allowed).join(",")
            )));
        }
        Ok(YadeRunOptions {
            paths,
            stress_volume: Some(self.read.volume()),
            ..opts.clone()
        })
    }

    /// The comment lines of `run.py` that say what was done to the box.
    fn note(&self) -> String {
        let l = self.packing.cell.expect("extended cell").lengths;
        let (v, box_volume) = (l.x * l.y * l.z, self.read.volume());
        format!(
            "# Box of mixed periodicity (boundary {} as read): YADE's cell is periodic along every axis, so\n\
             #   the free axes' edges are extended ({} x {} x {} m) beyond the spheres by 2 x (largest diameter +\n\
             #   longest bond): no bond crosses them, the scene has no collider, the free faces stay free surfaces.\n\
             #   Only the paths of the periodic axes are run. Stresses and C are per the box as read ({} m^3,\n\
             #   --stress-volume), as LIGGGHTS and LAMMPS report them: YADE's Love stress (per its cell, {} m^3) x {}.\n",
            self.read.boundary(),
            super::num(l.x),
            super::num(l.y),
            super::num(l.z),
            super::num(box_volume),
            super::num(v),
            super::num(v / box_volume),
        )
    }
}

/// Read a packing file and a model file, bond the packing by the model's rule, assign the
/// springs of its scheme, and write the export directory (`anisobond export yade`).
/// Inputs are fully read and checked before anything is written.
pub fn export_yade(
    packing_path: &Path,
    model_path: &Path,
    dir: &Path,
    opts: &YadeRunOptions,
) -> Result<YadeExport> {
    opts.validate()?;
    let asm = Assembly::from_files(packing_path, model_path)?;
    if asm.packing.cell.is_none() {
        return Err(Error::Invalid(format!(
            "{}: the packing is not periodic (no `# periodic Lx Ly Lz` header); the YADE \
             element tests deform a periodic cell",
            packing_path.display()
        )));
    }
    write_assembly_export(dir, &asm, opts)
}

/// [`write_yade_export`] of an assembly: its packing, bonds and springs, its model saved for
/// the record, and a polycrystal's grains ([`write_yade_export_grains`]).
pub fn write_assembly_export(
    dir: &Path,
    asm: &Assembly,
    opts: &YadeRunOptions,
) -> Result<YadeExport> {
    write_yade_export_grains(
        dir,
        &asm.packing,
        &asm.bonds,
        &asm.springs,
        Some(&asm.model),
        opts,
        asm.grains().map(|g| g.grain.as_slice()),
    )
}

/// What every YADE validation needs before it writes anything: `yade` on PATH and a model
/// without a `[manybody]` term (YADE's bond laws are pairwise; its route for the term,
/// `anisobond_yade.add_manybody`, needs the anisobond Python package inside YADE, which
/// `validate yade` does not assume).
pub fn check_yade_runnable(model: Option<&Model>) -> Result<()> {
    if model.is_some_and(|m| m.manybody.is_some()) {
        return Err(Error::Invalid(
            "validate yade: the model has a [manybody] term, which YADE's bond laws cannot \
             carry; YADE runs it only as anisobond_yade.add_manybody (a PyRunner engine \
             computed by the anisobond Python package, see docs/manybody.md, \"YADE\"; `export \
             yade` writes a run.py that adds it). Validate the term with `validate lammps` \
             (plugin route) or `validate liggghts`"
                .into(),
        ));
    }
    if find_yade().is_none() {
        return Err(Error::Invalid(
            "validate yade: `yade` is not on PATH (install YADE 2023.02a, e.g. apt install yade)"
                .into(),
        ));
    }
    Ok(())
}

#[cfg(feature = "engines")]
/// The `yade` executable on PATH, if any.
pub fn find_yade() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("yade"))
        .find(|p| p.is_file())
}

#[cfg(feature = "engines")]
/// What a YADE run printed.
#[derive(Clone, Debug)]
pub struct YadeOutput {
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// Wall-clock time of the whole `yade` process (s), start-up included.
    pub wall_seconds: f64,
}

#[cfg(feature = "engines")]
/// Run `yade -n -x SCRIPT ARGS…` in the script's directory and wait for it. Error (with
/// YADE's output) when `yade` is missing or exits non-zero.
pub fn run_yade_script(script: &Path, args: &[String]) -> Result<YadeOutput> {
    let yade = find_yade().ok_or_else(|| {
        Error::Invalid(
            "`yade` is not on PATH (install YADE 2023.02a, e.g. apt install yade)".into(),
        )
    })?;
    let dir = match script.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = script
        .file_name()
        .ok_or_else(|| Error::Invalid(format!("{}: not a script file", script.display())))?;
    let start = std::time::Instant::now();
    let out = Command::new(yade)
        .arg("-n")
        .arg("-x")
        .arg(name)
        .args(args)
        .current_dir(&dir)
        .output()
        .map_err(|e| Error::io(script, e))?;
    let wall_seconds = start.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() {
        return Err(Error::engine(
            "YADE",
            format!(
                "yade -n -x {} failed ({}):\n{}\n{}",
                script.display(),
                out.status,
                tail(&stdout, 40),
                tail(&stderr, 40)
            ),
        ));
    }
    Ok(YadeOutput {
        stdout,
        stderr,
        wall_seconds,
    })
}

#[cfg(feature = "engines")]
fn tail(s: &str, lines: usize) -> String {
    let v: Vec<&str> = s.lines().collect();
    v[v.len().saturating_sub(lines)..].join("\n")
}

pub use crate::history::HistoryRow;

/// Read `yade-history.csv` (written by `anisobond_yade.write_history_csv`).
pub fn read_yade_history(path: &Path) -> Result<Vec<HistoryRow>> {
    let text = crate::io::read_to_string(path)?;
    let name = path.display().to_string();
    let mut rows = Vec::new();
    let mut header_seen = false;
    for (k, line) in text.lines().enumerate() {
        let line_no = k + 1;
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if !header_seen {
            if !t.starts_with("path,step,time_s,") {
                return Err(Error::parse(
                    &name,
                    line_no,
                    "expected the header `path,step,time_s,e11,…,s12_Pa`",
                ));
            }
            header_seen = true;
            continue;
        }
        let f: Vec<&str> = t.split(',').collect();
        if f.len() != 15 {
            return Err(Error::parse(
                &name,
                line_no,
                format!("expected 15 fields, found {}", f.len()),
            ));
        }
        let num = |s: &str| -> Result<f64> {
            s.parse::<f64>().map_err(|_| {
                Error::parse(&name, line_no, format!("expected a number, found `{s}`"))
            })
        };
        let path_index = PATH_LABELS
            .iter()
            .position(|l| *l == f[0])
            .ok_or_else(|| Error::parse(&name, line_no, format!("unknown path `{}`", f[0])))?;
        let step = f[1]
            .parse::<usize>()
            .map_err(|_| Error::parse(&name, line_no, format!("bad step `{}`", f[1])))?;
        let mut strain = Voigt6::zeros();
        let mut stress = Voigt6::zeros();
        for a in 0..6 {
            strain[a] = num(f[3 + a])?;
            stress[a] = num(f[9 + a])?;
        }
        rows.push(HistoryRow {
            path: path_index,
            step,
            time: num(f[2])?,
            strain,
            stress,
        });
    }
    if !header_seen {
        return Err(Error::parse(
            &name,
            0,
            "no header row: not a YADE history file",
        ));
    }
    Ok(rows)
}

/// The tensor and run settings of `yade-tensor.json`.
#[derive(Clone, Debug)]
pub struct YadeTensor {
    /// The 6×6 tensor C = S·E⁻¹ from the six paths (Pa).
    pub c: Stiffness6,
    /// Time step used (s).
    pub time_step: f64,
    /// Damping used.
    pub damping: f64,
    /// Steps per path.
    pub steps: usize,
    /// Wall time per path inside YADE (scene build + steps, s), in path order.
    pub path_seconds: Vec<(String, f64, f64)>,
    /// The whole JSON document.
    pub json: serde_json::Value,
}

/// The JSON a YADE script of the strength and specimen tests wrote at `path`, and the engine
/// failure naming a key it lacks (or holds no valid value under).
pub(crate) fn read_result_json(
    path: &Path,
) -> Result<(serde_json::Value, impl Fn(&str) -> Error + '_)> {
    let text = crate::io::read_to_string(path)?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::engine("YADE", format!("{}: {e}", path.display())))?;
    let bad = move |what: &str| {
        Error::engine(
            "YADE",
            format!("{}: no valid `{what}` in YADE's result", path.display()),
        )
    };
    Ok((v, bad))
}

/// Read `yade-tensor.json` (SPEC tensor report with `method = "yade"` and a `yade` block).
pub fn read_yade_tensor(path: &Path) -> Result<YadeTensor> {
    let text = crate::io::read_to_string(path)?;
    let name = path.display().to_string();
    let json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::parse(&name, e.line(), e.to_string()))?;
    let bad = |m: &str| Error::parse(&name, 0, m.to_string());
    let rows = json["C"]
        .as_array()
        .ok_or_else(|| bad("`C` is not a 6×6 array (were all six paths run?)"))?;
    let mut c = Stiffness6::zeros();
    if rows.len() != 6 {
        return Err(bad("`C` must have 6 rows"));
    }
    for (i, r) in rows.iter().enumerate() {
        let r = r
            .as_array()
            .filter(|r| r.len() == 6)
            .ok_or_else(|| bad("`C` rows must have 6 numbers"))?;
        for (j, v) in r.iter().enumerate() {
            c[(i, j)] = v
                .as_f64()
                .ok_or_else(|| bad("`C` entries must be numbers"))?;
        }
    }
    let y = &json["yade"];
    let f = |k: &str| {
        y[k].as_f64()
            .ok_or_else(|| bad(&format!("`yade.{k}` missing")))
    };
    let mut path_seconds = Vec::new();
    if let Some(m) = y["wall_time_s"].as_object() {
        for (k, v) in m {
            path_seconds.push((
                k.clone(),
                v["build_s"].as_f64().unwrap_or(f64::NAN),
                v["run_s"].as_f64().unwrap_or(f64::NAN),
            ));
        }
    }
    Ok(YadeTensor {
        c,
        time_step: f("dt_s")?,
        damping: f("damping")?,
        steps: f("steps")? as usize,
        path_seconds,
        json: json.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_parse_by_label_and_reject_unknown() {
        assert_eq!(
            parse_paths("11,22,33,23,13,12").unwrap(),
            vec![0, 1, 2, 3, 4, 5]
        );
        assert_eq!(parse_paths(" 12 , 11").unwrap(), vec![5, 0]);
        let e = parse_paths("11,21").unwrap_err().to_string();
        assert!(e.contains("`21`"), "{e}");
    }

    #[test]
    fn options_are_validated() {
        assert!(YadeRunOptions::default().validate().is_ok());
        let bad = [
            YadeRunOptions {
                strain: 0.0,
                ..Default::default()
            },
            YadeRunOptions {
                steps: 0,
                ..Default::default()
            },
            YadeRunOptions {
                damping: 1.0,
                ..Default::default()
            },
            YadeRunOptions {
                density: -1.0,
                ..Default::default()
            },
            YadeRunOptions {
                time_step: Some(f64::NAN),
                ..Default::default()
            },
            YadeRunOptions {
                safety: 1.5,
                ..Default::default()
            },
            YadeRunOptions {
                stress_volume: Some(0.0),
                ..Default::default()
            },
            YadeRunOptions {
                paths: vec![6],
                ..Default::default()
            },
        ];
        for o in bad {
            assert!(o.validate().is_err(), "{o:?} accepted");
        }
    }

    #[test]
    fn run_script_passes_every_option() {
        let o = YadeRunOptions {
            strain: 2e-6,
            steps: 77,
            damping: 0.0,
            density: 1234.5,
            time_step: Some(3e-8),
            safety: 0.5,
            paths: vec![3, 0],
            stress_volume: Some(2.5e-7),
        };
        let s = run_script(&o, 10, 20, false);
        for want in [
            "\"--strain\", \"2e-6\"",
            "\"--steps\", \"77\"",
            "\"--damping\", \"0.0\"",
            "\"--density\", \"1234.5\"",
            "\"--dt\", \"3e-8\"",
            "\"--safety\", \"0.5\"",
            "\"--paths\", \"23,11\"",
            "\"--stress-volume\", \"2.5e-7\"",
            "anisobond_yade.main(DEFAULTS + sys.argv[1:])",
        ] {
            assert!(s.contains(want), "run.py lacks {want}:\n{s}");
        }
    }

    #[test]
    fn history_reader_reports_bad_rows() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.csv");
        let header = "# c\npath,step,time_s,e11,e22,e33,e23,e13,e12,s11_Pa,s22_Pa,s33_Pa,s23_Pa,s13_Pa,s12_Pa\n";
        std::fs::write(&p, format!("{header}11,0,0.0,1,0,0,0,0,0,5,0,0,0,0,0\n")).unwrap();
        let rows = read_yade_history(&p).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].strain[0], 1.0);
        assert_eq!(rows[0].stress[0], 5.0);
        std::fs::write(&p, format!("{header}11,0,0.0,x,0,0,0,0,0,5,0,0,0,0,0\n")).unwrap();
        let e = read_yade_history(&p).unwrap_err().to_string();
        assert!(e.contains(":3:") && e.contains("`x`"), "{e}");
        std::fs::write(&p, format!("{header}44,0,0.0,0,0,0,0,0,0,5,0,0,0,0,0\n")).unwrap();
        assert!(read_yade_history(&p).is_err());
    }

    #[test]
    fn free_packing_is_refused() {
        let p = Packing::new(vec![crate::Vec3::zeros()], vec![1.0], None).unwrap();
        let e = check_exportable(&p, &BondSet::default(), &BondStiffness::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("not periodic"), "{e}");
    }
}
