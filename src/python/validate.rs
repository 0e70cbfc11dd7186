//! `anisobond.validate`: a validation against another code (YADE, LIGGGHTS, LAMMPS) through
//! the library's engine interface ([`crate::validate::validate`]); the report as a dict (the
//! report.json of `anisobond validate ENGINE`), and the command's end as exceptions.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::assembly::PyAssembly;
use super::convert::{get, json_to_py};
use super::errors::{to_py, InputError};
use crate::io::{OutputSet, WorkDir};
use crate::validate::harness::{outcome, report_json, EngineDetails};
use crate::validate::lammps::{find_lmp, Lammps, LammpsValidateOptions};
use crate::validate::liggghts::{Liggghts, Programs, ValidateOptions};
use crate::validate::yade::{Yade, YadeValidationOptions};
use crate::validate::{validate as run_validation, Engine, Problem, Tolerances};
use crate::{Error, Result};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Settings a caller may give (keyword options); each engine takes the ones it has and
/// refuses the others.
#[derive(Default)]
struct Settings {
    density: Option<f64>,
    time_step: Option<f64>,
    strain: Option<f64>,
    processes: Option<usize>,
    program: Option<PathBuf>,
    driver: Option<PathBuf>,
    tolerances: Option<HashMap<String, f64>>,
}

/// The keyword options of `validate`, in the order of the stubs.
const VALIDATE_OPTIONS: &str = "density, time_step, strain, processes, program, driver, tolerances";

/// The options each engine takes.
const ENGINE_OPTIONS: [(&str, &[&str]); 3] = [
    ("yade", &["density", "time_step", "strain", "tolerances"]),
    ("lammps", &["processes", "program", "tolerances"]),
    (
        "liggghts",
        &[
            "density",
            "time_step",
            "processes",
            "program",
            "driver",
            "tolerances",
        ],
    ),
];

impl Settings {
    /// The keyword `options` of `engine`; an unknown keyword, one the engine has no use for
    /// or a value of the wrong type is an InputError naming it (None leaves the engine's
    /// default).
    fn parse(engine: &str, options: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let Some((_, accepted)) = ENGINE_OPTIONS.iter().find(|(name, _)| *name == engine) else {
            return Err(InputError::new_err(format!(
                "validate: unknown engine `{engine}`: expected yade, liggghts or lammps"
            )));
        };
        let mut s = Settings::default();
        for (key, value) in options.iter().flat_map(|d| d.iter()) {
            let key: String = key.extract()?;
            if value.is_none() {
                continue;
            }
            if VALIDATE_OPTIONS.split(", ").any(|k| k == key) && !accepted.contains(&key.as_str()) {
                return Err(InputError::new_err(format!(
                    "validate {engine}: the option `{key}` does not apply to this engine"
                )));
            }
            match key.as_str() {
                "density" => s.density = Some(get(&key, &value, "a number (kg/m³)")?),
                "time_step" => s.time_step = Some(get(&key, &value, "a number (s)")?),
                "strain" => s.strain = Some(get(&key, &value, "a number")?),
                "processes" => s.processes = Some(get(&key, &value, "an integer ≥ 1")?),
                "program" => s.program = Some(get(&key, &value, "a path")?),
                "driver" => s.driver = Some(get(&key, &value, "a path")?),
                "tolerances" => {
                    s.tolerances = Some(get(&key, &value, "a dict of names to numbers")?)
                }
                other => {
                    return Err(InputError::new_err(format!(
                        "unknown option `{other}`: expected one of {VALIDATE_OPTIONS}"
                    )))
                }
            }
        }
        Ok(s)
    }

    /// The engine's default `base` tolerances with the given ones in place (keys `history`,
    /// `tensor`, `relaxed`, `processes`; any other is refused). The engine checks the values.
    fn tolerances(&self, engine: &str, base: Tolerances) -> Result<Tolerances> {
        let mut t = base;
        for (key, &value) in self.tolerances.iter().flatten() {
            match key.as_str() {
                "history" => t.history = value,
                "tensor" => t.tensor = value,
                "relaxed" => t.relaxed = value,
                "processes" => t.processes = value,
                other => {
                    return Err(Error::Invalid(format!(
                        "validate {engine}: unknown tolerance `{other}`: expected history, \
                         tensor, relaxed or processes"
                    )))
                }
            }
        }
        Ok(t)
    }

    /// YADE 2023.02a (`yade` on PATH): element tests in one step, undamped and
    /// damped, against the integrator and the relaxed solver (docs/validation.md).
    fn yade(&self) -> Result<Yade> {
        let d = YadeValidationOptions::default();
        Ok(Yade(YadeValidationOptions {
            density: self.density.unwrap_or(d.density),
            time_step: self.time_step.or(d.time_step),
            strain: self.strain.unwrap_or(d.strain),
            tolerances: self.tolerances("yade", d.tolerances)?,
            ..d
        }))
    }

    /// LAMMPS with the BPM package: `program` (default $ANISOBOND_LMP, else `lmp` on PATH),
    /// on one and two MPI processes (`processes` = 1: one only).
    fn lammps(&self) -> Result<Lammps> {
        let mut opts = LammpsValidateOptions::new(find_lmp(self.program.clone())?);
        opts.tolerances = self.tolerances("lammps", opts.tolerances)?;
        match self.processes {
            None | Some(2) => {}
            Some(1) => opts.two_processes = false,
            Some(n) => {
                return Err(Error::Invalid(format!(
                    "validate lammps: processes must be 1 or 2, got {n}"
                )))
            }
        }
        Ok(Lammps(opts))
    }

    /// LIGGGHTS: the driver `anisobond-liggghts` (`driver`, default on PATH; `make -C cpp`)
    /// and the stock `liggghts` (`program`, default on PATH), on `processes` MPI processes.
    fn liggghts(&self) -> Result<Liggghts> {
        let d = ValidateOptions::default();
        let driver = self
            .driver
            .clone()
            .unwrap_or_else(|| PathBuf::from("anisobond-liggghts"));
        Ok(Liggghts {
            programs: Programs {
                driver,
                liggghts: self
                    .program
                    .clone()
                    .unwrap_or_else(|| PathBuf::from("liggghts")),
            },
            options: ValidateOptions {
                density: self.density.unwrap_or(d.density),
                timestep: self.time_step.or(d.timestep),
                processes: self.processes.unwrap_or(d.processes),
                tolerances: self.tolerances("liggghts", d.tolerances)?,
                ..d
            },
        })
    }
}

/// Run `engine` on the assembly in `directory` (staged, moved into place with the report
/// files when done) or in a temporary directory; the report JSON and the verdict.
fn run_engine<E: Engine>(
    engine: &E,
    assembly: &crate::assembly::Assembly,
    directory: Option<&Path>,
) -> Result<(String, Result<()>)> {
    engine.check()?;
    let mut set = OutputSet::new(&[]);
    let work = set.dir_or_temporary(directory)?;
    let report = run_validation(engine, &Problem::of(work.path(), assembly), &|_| {})?;
    if let WorkDir::Staged(dir) = &work {
        engine.write_files(dir, &report)?;
        set.commit()?;
    }
    Ok((report_json(&report)?, outcome(E::Details::ENGINE, &report)))
}

/// Validate `assembly` against another code: `engine` "yade", "liggghts" or "lammps" runs
/// the periodic element tests in that program and in anisobond and compares (as `anisobond
/// validate ENGINE`, docs/validation.md). Returns the report as a dict (report.json: `passed`,
/// `checks`, the engine's tensors …); with `directory` the decks, logs and report files are
/// kept there (written atomically, after the run). Raises EngineError when the program
/// cannot be run or fails, and, with `check` (default), ValidationError when a comparison is
/// outside its tolerance and NotConvergedError when a compared run had not settled
/// (`check=False` returns the report instead). Options: `density` (kg/m³), `time_step` (s),
/// `strain` (YADE), `processes` (LIGGGHTS; LAMMPS 1 or 2), `program` (the `lmp` or
/// `liggghts` executable), `driver` (LIGGGHTS' anisobond-liggghts), `tolerances` (a dict
/// of `history`, `tensor`, `relaxed`, `processes`: relative agreement required, replacing
/// the engine's defaults). GIL released.
#[pyfunction]
#[pyo3(signature = (engine, assembly, directory = None, *, check = true, **options))]
pub(super) fn validate<'py>(
    py: Python<'py>,
    engine: &str,
    assembly: &PyAssembly,
    directory: Option<PathBuf>,
    check: bool,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let s = Settings::parse(engine, options)?;
    let (asm, dir) = (&assembly.inner, directory.as_deref());
    let (json, verdict) = py
        .detach(|| match engine {
            "yade" => run_engine(&s.yade()?, asm, dir),
            "lammps" => run_engine(&s.lammps()?, asm, dir),
            // `Settings::parse` accepted the three names only.
            _ => run_engine(&s.liggghts()?, asm, dir),
        })
        .map_err(to_py)?;
    if check {
        verdict.map_err(to_py)?;
    }
    json_to_py(py, &json)?
        .cast_into::<PyDict>()
        .map_err(|e| InputError::new_err(format!("validation report: {e}")))
}
