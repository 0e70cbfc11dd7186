//! The cell of packing files that do not state it (issue 20): the global options `--cell
//! Lx,Ly,Lz`, `--periodic` and `--free`, and the note every command that reads a packing
//! prints (standard error) when it assumed the cell or when the packing is a free cluster.

use anisobond::assembly::Assembly;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::packing::{read_packing_as, CellChoice, CellOptionNames, DataBonds, PackingRead};
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
    /// For a LAMMPS / LIGGGHTS data file: periodic along some axes only, as LAMMPS' `boundary`
    /// says it, e.g. "p p f" (a settled bed: bonds across the x and y faces only; f, s or m
    /// = not periodic). A dump's BOX BOUNDS state it themselves.
    #[arg(long, global = true, value_name = "\"X Y Z\"", conflicts_with_all = ["cell", "periodic", "free"])]
    boundary: Option<String>,
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
    } else if let Some(text) = &a.boundary {
        let words: Vec<&str> = text
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty())
            .collect();
        let flag = |w: &str| match w {
            "p" => Some(true),
            _ if !w.is_empty() && w.len() <= 2 && w.chars().all(|c| "fsm".contains(c)) => {
                Some(false)
            }
            _ => None,
        };
        let flags: Vec<bool> = words.iter().filter_map(|w| flag(w)).collect();
        if words.len() != 3 || flags.len() != 3 {
            return Err(Error::Invalid(format!(
                "--boundary {text}: expected three flags as LAMMPS' `boundary` gives them, e.g. \
                 \"p p f\" (p periodic; f, s or m not)"
            )));
        }
        match [flags[0], flags[1], flags[2]] {
            [true, true, true] => CellChoice::Periodic,
            [false, false, false] => CellChoice::Free,
            b => CellChoice::Boundary(b),
        }
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
    Ok(read_full(path)?.packing)
}

/// [`read`], with the file's own bonds (a data file's `Bonds` section) when it has them.
pub fn read_full(path: &Path) -> Result<PackingRead> {
    let choice = CHOICE.get().copied().unwrap_or_default();
    let r = read_packing_as(path, choice)?;
    if let Some(note) = r.cell_note(&path.display().to_string(), CellOptionNames::CLI) {
        eprintln!("note: {note}");
    }
    Ok(r)
}

/// The note of a packing whose file brings its own bonds (stderr).
fn bonds_note(path: &Path, b: &DataBonds) -> String {
    format!(
        "{}: its Bonds section is the bond network ({} bonds, {} bond type(s), kept as `type` \
         in bond tables) instead of the model's bonding rule; the model gives the springs",
        path.display(),
        b.len(),
        b.distinct_types()
    )
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

/// [`read`] the packing and bond it by `model` ([`Assembly::from_packing_file`]); a data
/// file with a `Bonds` section keeps its own bonds ([`Assembly::from_data_bonds`]), said in
/// a note.
pub fn assembly_with(packing_path: &Path, model: Model, model_path: &Path) -> Result<Assembly> {
    let r = read_full(packing_path)?;
    match &r.bonds {
        Some(b) => {
            eprintln!("note: {}", bonds_note(packing_path, b));
            Assembly::from_data_bonds(r.packing, model, b, &packing_path.display().to_string())
        }
        None => Assembly::from_packing_read(r.packing, packing_path, model, model_path),
    }
}

/// The packing of `packing_path` with the bonds and springs of the bond table `table`
/// (`--bonds`, [`Assembly::from_table_file`]). The rule when the file has its own bonds
/// too: the table given on the command line replaces them, said in a note.
pub fn assembly_with_table(packing_path: &Path, model: Model, table: &Path) -> Result<Assembly> {
    let r = read_full(packing_path)?;
    if let Some(b) = &r.bonds {
        eprintln!(
            "note: {}: --bonds {} replaces the {} bonds of its Bonds section (the table's bonds \
             and springs are used)",
            packing_path.display(),
            table.display(),
            b.len()
        );
    }
    Assembly::from_table_file(r.packing, model, table)
}

/// What every engine export reads and where it writes.
#[derive(clap::Args, Debug)]
pub struct ExportPaths {
    #[command(flatten)]
    pub input: BondedInput,
    /// Output directory (created if missing; must not exist as a file).
    #[arg(short, long)]
    pub output: PathBuf,
}

impl ExportPaths {
    /// The output set of these inputs and the staged directory the export writes into
    /// (committed to `output` once everything is written).
    pub fn stage(&self) -> Result<(OutputSet, PathBuf)> {
        let mut set = OutputSet::new(&self.input.paths());
        let staged = set.dir(&self.output)?;
        Ok((set, staged))
    }
}
