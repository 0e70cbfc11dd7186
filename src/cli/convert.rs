//! `anisobond convert INPUT -o OUTPUT --to spherepack|text|liggghts|spec` (issue 20): any
//! packing file it reads, written for another program's own loader, keeping the cell (and
//! the particle ids where the target format has an id column).

use super::cell;
use anisobond::io::OutputSet;
use anisobond::packing::{write_liggghts_data_with_ids, write_packing, write_yade_spherepack};
use anisobond::{Error, Result};
use clap::ValueEnum;
use std::path::PathBuf;

/// The formats `convert` writes.
#[derive(Clone, Copy, ValueEnum, Debug, PartialEq, Eq)]
pub enum Target {
    /// YADE `SpherePack.load`: `##PERIODIC:: Lx Ly Lz`, then `x y z r`.
    Spherepack,
    /// YADE `ymport.text`: `#format x_y_z_r` lines (the cell as a `# periodic` comment,
    /// which ymport ignores and anisobond reads).
    Text,
    /// LIGGGHTS `read_data` (`atom_style granular`): the cell as the box, ids as atom ids.
    Liggghts,
    /// anisobond's SPEC text (`# periodic Lx Ly Lz` or `# free`, then `x y z r`).
    Spec,
}

/// Options of `anisobond convert`.
#[derive(clap::Args)]
pub struct ConvertArgs {
    /// Packing file to read (any format anisobond reads; see --cell / --periodic / --free).
    input: PathBuf,
    /// Output file.
    #[arg(short, long)]
    output: PathBuf,
    /// Output format.
    #[arg(long, value_enum)]
    to: Target,
    /// Particle density for LIGGGHTS data (kg/m³).
    #[arg(long, default_value_t = 2500.0)]
    density: f64,
}

/// Run `convert`.
pub fn run(a: ConvertArgs) -> Result<()> {
    let mut p = cell::read(&a.input)?;
    let mut out = OutputSet::new(&[&a.input]);
    let staged = out.file(&a.output)?;
    let mut notes = Vec::new();
    match a.to {
        Target::Liggghts => {
            if let Some(ids) = &mut p.ids {
                if ids.contains(&0) {
                    // LIGGGHTS atom ids start at 1 (YADE body ids at 0).
                    for id in ids.iter_mut() {
                        *id = id.checked_add(1).ok_or_else(|| {
                            Error::Invalid(format!("{}: id {id} too large", a.input.display()))
                        })?;
                    }
                    notes.push("ids include 0: every id written as atom id = id + 1".to_string());
                }
            }
            write_liggghts_data_with_ids(&staged, &p, a.density)?;
            if p.cell.is_none() {
                notes.push(
                    "a free packing: the box is the spheres' bounding box; use boundary f f f"
                        .into(),
                );
            }
        }
        Target::Spherepack | Target::Text | Target::Spec => {
            if p.ids.is_some() {
                notes.push(format!(
                    "the particle ids are not written: --to {} has no id column (the \
                     particles keep the input's order, sorted by id)",
                    a.to.to_possible_value().unwrap().get_name()
                ));
            }
            if a.to == Target::Spherepack {
                write_yade_spherepack(&staged, &p)?;
            } else {
                write_packing(&staged, &p)?;
            }
        }
    }
    out.commit()?;
    for n in notes {
        eprintln!("note: {}: {n}", a.output.display());
    }
    let cell = match &p.cell {
        Some(c) => format!(
            "periodic cell {} × {} × {} m",
            c.lengths.x, c.lengths.y, c.lengths.z
        ),
        None => "free".into(),
    };
    println!(
        "wrote {}: {} spheres, {cell}{}",
        a.output.display(),
        p.len(),
        if p.ids.is_some() && a.to == Target::Liggghts {
            ", ids kept"
        } else {
            ""
        }
    );
    Ok(())
}
