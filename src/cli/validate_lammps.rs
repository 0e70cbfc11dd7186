//! `anisobond validate lammps PACKING --model MODEL [--np 1|2] [-o DIR] [--bond-style
//! anisobond] [--types K]`: the exported element tests run by LAMMPS (BPM package) against
//! the relaxed solver (of the quantised network with `--types`), and on two MPI processes
//! against one; a table, report.json and checks.csv, non-zero exit outside tolerance.

use anisobond::io::OutputSet;
use anisobond::validate::harness::checks_table;
use anisobond::validate::lammps::{
    resolve_program, validate_lammps, write_report, LammpsValidateOptions,
};
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
}

/// Run `anisobond validate lammps`.
pub fn run(a: Args) -> Result<()> {
    let (bond_style, types) = a.bonds.options("validate lammps")?;
    // --lmp, $ANISOBOND_LMP, else `lmp` on PATH; made absolute (run.sh runs in the deck's
    // directory and takes `mpirun` from beside `lmp`).
    let lmp = a
        .lmp
        .or_else(|| std::env::var_os("ANISOBOND_LMP").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("lmp"));
    let lmp = resolve_program(&lmp)?;
    let mut set = OutputSet::new(&a.input.paths());
    let dir = set.dir(&a.output)?;
    let asm = a.input.assembly()?;
    let mut opts = LammpsValidateOptions::new(lmp);
    opts.export.bond_style = bond_style;
    opts.export.types = types;
    opts.two_processes = a.np == 2;
    opts.relaxed_tolerance = a.tolerance;
    opts.check()?;
    println!(
        "validate lammps: {} particles, {} bonds, {} process(es)",
        asm.packing.len(),
        asm.bonds.len(),
        a.np
    );
    let report = validate_lammps(&dir, &asm.packing, &asm.bonds, &asm.springs, &opts)?;
    println!("time step {:.4e} s\n", report.time_step);
    println!("relative differences (dimensionless; tensors in Pa):");
    print!("{}", checks_table(&report));
    let mut tensors = vec![("relaxed".to_string(), report.relaxed)];
    for (np, c) in &report.lammps {
        tensors.push((format!("lammps -np {np}"), *c));
    }
    let files = write_report(&dir, &report)?;
    set.commit()?;
    super::validate::finish("lammps", &report, &tensors, &files, &dir, &a.output)
}
