//! `anisobond validate lammps PACKING --model MODEL [--np 1|2] [-o DIR] [--bond-style
//! anisobond] [--types K]`: the exported element tests run by LAMMPS (BPM package) against
//! the relaxed solver (of the quantised network with `--types`), and on two MPI processes
//! against one; a table, report.json and checks.csv, non-zero exit outside tolerance.

use anisobond::validate::lammps::{find_lmp, Lammps, LammpsValidateOptions};
use anisobond::Result;
use std::path::PathBuf;

/// Options of `anisobond validate lammps`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub input: super::cell::BondedInput,
    /// Output directory (the exported run, report.json, checks.csv).
    #[arg(short, long, default_value = "validate-lammps")]
    pub output: PathBuf,
    /// MPI processes: 1, or 2 to also compare two processes with one.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub np: u8,
    /// The `lmp` executable (default: $ANISOBOND_LMP, else `lmp` on PATH).
    #[arg(long)]
    pub lmp: Option<PathBuf>,
    /// Tolerance of LAMMPS' tensor against the relaxed one (largest difference / largest C).
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f64,
    /// The deck's bonds, as for `export lammps`.
    #[command(flatten)]
    pub bonds: super::export_lammps::BondArgs,
    /// The specimen or the strength test instead of the element tests.
    #[command(flatten)]
    pub tests: super::validate_strength::FreeTestFlags,
}

impl Args {
    /// The LAMMPS engine: `lmp` from --lmp, $ANISOBOND_LMP, else `lmp` on PATH, made
    /// absolute (run.sh runs in the deck's directory and takes `mpirun` from beside `lmp`).
    pub fn engine(&self) -> Result<Lammps> {
        let (bond_style, types) = self.bonds.options("validate lammps")?;
        let mut opts = LammpsValidateOptions::new(find_lmp(self.lmp.clone())?);
        opts.export.bond_style = bond_style;
        opts.export.types = types;
        opts.two_processes = self.np == 2;
        opts.tolerances.relaxed = self.tolerance;
        Ok(Lammps(opts))
    }
}
