//! The cell of packing files that do not state it (issue 20): the global options `--cell
//! Lx,Ly,Lz`, `--periodic` and `--free`, and the note every command that reads a packing
//! prints (standard error) when it assumed the cell or when the packing is a free cluster.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::io::{read_packing_as, CellChoice, CellOptionNames};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::{Error, Result, Vec3};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Options of every command that reads a packing file.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CellArgs {
    /// For a packing file that states no cell (YADE export.text, plain `x y z r` text): it
    /// is periodic with this cell [0,Lx)×[0,Ly)×[0,Lz) (m).
    #[arg(long, global = true, value_name = "Lx,Ly,Lz", conflicts_with_all = ["periodic", "free"])]
    cell: Option<String>,
    /// For a LIGGGHTS data file: the box is the periodic cell (`boundary p p p`).
    #[arg(long, global = true, conflicts_with = "free")]
    periodic: bool,
    /// For a packing file that states no cell: a free cluster (no bonds across faces, the
    /// volume the spheres' bounding box), e.g. a walled LIGGGHTS box (`boundary f f f`).
    #[arg(long, global = true)]
    free: bool,
}

static CHOICE: OnceLock<CellChoice> = OnceLock::new();

/// Record the options for the readers below (once, before the command runs).
pub fn set(a: &CellArgs) -> Result<()> {
    let choice = if let Some(text) = &a.cell {
        let words: Vec<&str> = text.split(',').map(str::trim).collect();
        let lengths: Vec<f64> = words.iter().filter_map(|w| w.parse().ok()).collect();
        if words.len() != 3
            || lengths.len() != 3
            || lengths.iter().any(|l| !l.is_finite() || *l <= 0.0)
        {
            return Err(Error::Invalid(format!(
                "--cell {text}: expected three lengths > 0 in m, `Lx,Ly,Lz`"
            )));
        }
        let l = Vec3::new(lengths[0], lengths[1], lengths[2]);
        // The check of a `# periodic` header too (one function): the volume must not
        // overflow or underflow.
        if let Some(problem) = PeriodicCell::check_lengths(&l) {
            return Err(Error::Invalid(format!(
                "--cell {text}: {problem}; expected three lengths > 0 in m, `Lx,Ly,Lz`"
            )));
        }
        CellChoice::Cell(l)
    } else if a.periodic {
        CellChoice::Periodic
    } else if a.free {
        CellChoice::Free
    } else {
        CellChoice::AsStated
    };
    let _ = CHOICE.set(choice);
    Ok(())
}

/// Read a packing file with the user's cell options, printing the note on its cell.
pub fn read(path: &Path) -> Result<Packing> {
    let choice = CHOICE.get().copied().unwrap_or_default();
    let r = read_packing_as(path, choice)?;
    if let Some(note) = r.cell_note(&path.display().to_string(), CellOptionNames::CLI) {
        eprintln!("note: {note}");
    }
    Ok(r.packing)
}

/// The `PACKING --model MODEL` pair of every command that bonds a packing.
#[derive(clap::Args, Clone, Debug)]
pub struct BondedInput {
    /// Packing file: SPEC text (`x y z r`, `# periodic Lx Ly Lz`), YADE `SpherePack.save` or
    /// `export.text`, or LIGGGHTS data; a file that does not state its cell takes
    /// --cell/--periodic/--free.
    pub packing: PathBuf,
    /// Model file (TOML or JSON): bonding rule, stiffness scheme, geometry.
    #[arg(long)]
    pub model: PathBuf,
}

impl BondedInput {
    /// The two input files (an output never overwrites them, [`OutputSet`]).
    pub fn paths(&self) -> [&Path; 2] {
        [&self.packing, &self.model]
    }

    /// The packing bonded by the model ([`assembly`]).
    pub fn assembly(&self) -> Result<Assembly> {
        assembly(&self.packing, &self.model)
    }
}

/// [`read`] the packing and bond it by the model file ([`Assembly::from_files`]).
pub fn assembly(packing_path: &Path, model_path: &Path) -> Result<Assembly> {
    let model = Model::from_path(model_path)?;
    assembly_with(packing_path, model, model_path)
}

/// [`read`] the packing and bond it by `model` ([`Assembly::from_packing_file`]).
pub fn assembly_with(packing_path: &Path, model: Model, model_path: &Path) -> Result<Assembly> {
    let packing = read(packing_path)?;
    Assembly::from_packing_read(packing, packing_path, model, model_path)
}
