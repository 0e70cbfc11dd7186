//! The method names and keyword options of `Assembly.tensor` / `tensor_report`.

use super::convert::get;
use super::errors::{to_py, InputError};
use crate::assembly::{Method, MethodKind, MethodOptions};
use crate::dem::element::ElementTestOptions;
use crate::dem::LawKind;
use crate::homogenize::network::LeverArm;
use crate::homogenize::relaxed::{CgPreconditioner, RelaxedOptions, RelaxedSolver};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The value `name` stands for among `choices` (the strings keyword argument `key` takes),
/// or an error listing them all: "key `name`: expected 'a', 'b' or 'c'".
pub(super) fn one_of<T: Clone>(key: &str, name: &str, choices: &[(&str, T)]) -> PyResult<T> {
    if let Some((_, value)) = choices.iter().find(|(n, _)| *n == name) {
        return Ok(value.clone());
    }
    let quoted: Vec<String> = choices.iter().map(|(n, _)| format!("'{n}'")).collect();
    let expected = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => "nothing".into(),
    };
    Err(InputError::new_err(format!(
        "{key} `{name}`: expected {expected}"
    )))
}

/// The lever arms of the relaxed and LAF methods (`lever_arm=`).
pub(super) const LEVER_ARMS: [(&str, LeverArm); 3] = [
    ("mid-gap", LeverArm::MidGap),
    ("proportional", LeverArm::Proportional),
    ("half-length", LeverArm::HalfLength),
];

/// The solvers of the relaxed method (`solver=`; "cg" is the default, two-level CG), the
/// names of the CLI's `--solver`.
pub(super) fn relaxed_solvers() -> [(&'static str, RelaxedSolver); 4] {
    [
        ("cg", RelaxedSolver::default()),
        (
            "cg-jacobi",
            RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::BlockJacobi,
            },
        ),
        (
            "cg-amg",
            RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::Amg,
            },
        ),
        ("cholesky", RelaxedSolver::Cholesky),
    ]
}

/// The bond laws of the dynamic method (`law=`).
pub(super) const LAWS: [(&str, LawKind); 4] = [
    ("yade", LawKind::Yade),
    ("parallel-bond", LawKind::ParallelBond),
    ("kumar", LawKind::Kumar),
    ("lammps-bpm", LawKind::LammpsBpm),
];

/// The options of `Assembly.tensor` / `tensor_report` (keyword arguments; defaults as the
/// CLI's `tensor`): one parser for both methods.
pub(super) struct MethodArgs {
    method: String,
    shell: usize,
    energy: bool,
    lever_arm: String,
    tolerance: f64,
    solver: String,
    law: String,
    strain: f64,
    damping: f64,
    max_steps: usize,
    prestress: f64,
    pub(super) progress: Option<Py<PyAny>>,
}

/// The keyword arguments `MethodArgs::parse` accepts, in the order of the stubs.
pub(super) const METHOD_OPTIONS: &str =
    "shell, energy, lever_arm, tolerance, solver, law, strain, \
                              damping, max_steps, prestress, progress";

impl MethodArgs {
    /// `method` with the keyword `options`; an unknown keyword or a value of the wrong type
    /// is an `InputError` naming it.
    pub(super) fn parse(method: &str, options: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let d = MethodOptions::default();
        let mut a = MethodArgs {
            method: method.to_owned(),
            shell: d.shell,
            energy: d.energy,
            lever_arm: "mid-gap".into(),
            tolerance: d.relaxed.tolerance,
            solver: "cg".into(),
            law: "yade".into(),
            strain: d.element.strain,
            damping: d.element.local_damping,
            max_steps: d.element.max_steps,
            prestress: d.prestress,
            progress: None,
        };
        let Some(options) = options else {
            return Ok(a);
        };
        for (key, value) in options.iter() {
            let key: String = key.extract()?;
            match key.as_str() {
                "shell" => a.shell = get(&key, &value, "an integer ≥ 1")?,
                "energy" => a.energy = get(&key, &value, "True or False")?,
                "lever_arm" => a.lever_arm = get(&key, &value, "a string")?,
                "tolerance" => a.tolerance = get(&key, &value, "a number")?,
                "solver" => a.solver = get(&key, &value, "a string")?,
                "law" => a.law = get(&key, &value, "a string")?,
                "strain" => a.strain = get(&key, &value, "a number")?,
                "damping" => a.damping = get(&key, &value, "a number")?,
                "max_steps" => a.max_steps = get(&key, &value, "an integer ≥ 0")?,
                "prestress" => a.prestress = get(&key, &value, "a number (Pa)")?,
                "progress" => a.progress = (!value.is_none()).then(|| value.clone().unbind()),
                other => {
                    return Err(InputError::new_err(format!(
                        "unknown option `{other}`: expected one of {METHOD_OPTIONS}"
                    )))
                }
            }
        }
        Ok(a)
    }
}

impl MethodArgs {
    pub(super) fn method(&self) -> PyResult<Method> {
        let kind: MethodKind = self.method.parse().map_err(to_py)?;
        Ok(match kind {
            MethodKind::MeanField => Method::MeanField,
            MethodKind::Voigt => Method::Voigt,
            MethodKind::Relaxed | MethodKind::Prestressed => {
                let opts = RelaxedOptions {
                    lever_arm: one_of("lever_arm", &self.lever_arm, &LEVER_ARMS)?,
                    tolerance: self.tolerance,
                    solver: one_of("solver", &self.solver, &relaxed_solvers())?,
                    ..Default::default()
                };
                opts.validate().map_err(to_py)?;
                if kind == MethodKind::Prestressed {
                    Method::Prestressed {
                        options: opts,
                        pressure: self.prestress,
                    }
                } else {
                    Method::Relaxed(opts)
                }
            }
            MethodKind::Laf => Method::Laf {
                shell: self.shell,
                energy: self.energy,
                lever_arm: one_of("lever_arm", &self.lever_arm, &LEVER_ARMS)?,
            },
            MethodKind::Dynamic => {
                let mut options = ElementTestOptions {
                    strain: self.strain,
                    local_damping: self.damping,
                    max_steps: self.max_steps,
                    ..Default::default()
                };
                options.dem.local_damping = self.damping;
                Method::Dynamic {
                    law: one_of("law", &self.law, &LAWS)?,
                    options,
                }
            }
        })
    }
}
