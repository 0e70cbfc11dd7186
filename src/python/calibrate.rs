//! `anisobond.calibrate`: target tensor to scheme parameters.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::assembly::PyAssembly;
use super::errors::{to_py, InputError};
use super::model::PyModel;
use super::packing::PyPacking;
use crate::assembly::{Assembly, EqualSpheres};
use crate::calibrate::cubic::{CubicOptions, Family};
use crate::calibrate::target::Target;
use crate::calibrate::{calibrate, CalibrateOn, Calibration};
use crate::model::Model;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Calibrate `model`'s scheme parameters to `target`; returns (Model, details dict).
/// Use anisobond.calibrate (documented there).
#[pyfunction]
#[pyo3(signature = (model, target, on = None, *, family = "nearest", cubic_model = "auto",
    extended = false, tolerance = 5e-4, max_iterations = 30, coordination = 7.7,
    solid_fraction = 0.6, radius = 1e-3))]
#[allow(clippy::too_many_arguments)]
pub(super) fn calibrate_model<'py>(
    py: Python<'py>,
    model: &PyModel,
    target: &Bound<'py, PyAny>,
    on: Option<&Bound<'py, PyAny>>,
    family: &str,
    cubic_model: &str,
    extended: bool,
    tolerance: f64,
    max_iterations: usize,
    coordination: f64,
    solid_fraction: f64,
    radius: f64,
) -> PyResult<(PyModel, Bound<'py, PyDict>)> {
    let target = Target::parse(&target_text(target)?).map_err(to_py)?;
    let opts = CubicOptions {
        family: Family::from_name(family).map_err(to_py)?,
        extended,
        model: crate::calibrate::forced_cubic_model(cubic_model).map_err(to_py)?,
        tolerance,
        max_iterations,
        ..Default::default()
    };
    let base = &model.inner;
    let on_assembly = on_assembly(py, on, base)?;
    let spheres = EqualSpheres {
        coordination,
        solid_fraction,
        radius,
    };
    let calibrated = py
        .detach(|| {
            let on = match &on_assembly {
                Some((a, true)) => CalibrateOn::Relaxed(a),
                Some((a, false)) => CalibrateOn::MeanFieldOf(a),
                None => CalibrateOn::MeanField(spheres),
            };
            calibrate(base, &target, on, &opts)
        })
        .map_err(to_py)?;
    let info = info_dict(py, &calibrated.calibration)?;
    Ok((PyModel::wrap(calibrated.model)?, info))
}

/// The target as the CLI's text (`C12/C11=0.3,…`), from that text or a dict.
fn target_text(target: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(s) = target.extract::<String>() {
        Ok(s)
    } else if let Ok(d) = target.cast::<PyDict>() {
        let mut parts = Vec::new();
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let v: f64 = v.extract().map_err(|_| {
                InputError::new_err(format!("target {k}: expected a number (Pa or a ratio)"))
            })?;
            parts.push(format!("{k}={v:e}"));
        }
        Ok(parts.join(","))
    } else {
        Err(PyTypeError::new_err(
            "target: expected a dict such as {'C12/C11': 0.30, 'C44/C11': 0.43} or the CLI's text",
        ))
    }
}

/// `on`: None or 'mean-field' (the mean field of equal spheres), or a Packing or Assembly
/// bonded by `base` (its relaxed tensor).
fn on_assembly(
    py: Python<'_>,
    on: Option<&Bound<'_, PyAny>>,
    base: &Model,
) -> PyResult<Option<(Assembly, bool)>> {
    let o = match on {
        None => return Ok(None),
        Some(o) if o.is_none() => return Ok(None),
        Some(o) => o,
    };
    if let Ok(s) = o.extract::<String>() {
        if s != "mean-field" {
            return Err(InputError::new_err(format!(
                "on = '{s}': expected 'mean-field', a Packing (relaxed tensor) or None"
            )));
        }
        Ok(None)
    } else if let Ok(p) = o.cast::<PyPacking>() {
        let p = p.get().inner.clone();
        let m = base.clone();
        Ok(Some((
            py.detach(|| Assembly::new(p, m)).map_err(to_py)?,
            true,
        )))
    } else if let Ok(a) = o.cast::<PyAssembly>() {
        let a = &a.get().inner;
        let rebonded = Assembly::new(a.packing.clone(), base.clone()).map_err(to_py)?;
        Ok(Some((rebonded, true)))
    } else {
        Err(PyTypeError::new_err(
            "on: expected 'mean-field', a Packing or an Assembly",
        ))
    }
}

/// What the calibration achieved, as the details dict.
fn info_dict<'py>(py: Python<'py>, calibration: &Calibration) -> PyResult<Bound<'py, PyDict>> {
    let info = PyDict::new(py);
    match calibration {
        Calibration::Cubic(c) => {
            info.set_item("level", format!("{:?}", c.level).to_lowercase())?;
            info.set_item("a_n", c.parameters.a_n)?;
            info.set_item("a_s", c.parameters.a_s)?;
            info.set_item("shear_over_normal", c.parameters.shear_over_normal)?;
            info.set_item("C11", c.achieved_cubic.c11)?;
            info.set_item("C12", c.achieved_cubic.c12)?;
            info.set_item("C44", c.achieved_cubic.c44)?;
            info.set_item("iterations", c.history.len())?;
        }
        Calibration::CrossRelaxed(c) => {
            info.set_item("level", "relaxed")?;
            info.set_item("lattice_scaling", c.mu)?;
            info.set_item("written", PyList::new(py, c.written)?)?;
            let t = &c.achieved_transverse;
            info.set_item("C11", t.c11)?;
            info.set_item("C33", t.c33)?;
            info.set_item("C13", t.c13)?;
            info.set_item("C12", t.c12)?;
            info.set_item("C44", t.c44)?;
            info.set_item("iterations", c.history.len())?;
        }
        Calibration::CrossMeanField => {
            info.set_item("level", "meanfield")?;
        }
        Calibration::ManyBody(c) => {
            info.set_item("level", format!("{:?}", c.level).to_lowercase())?;
            info.set_item("manybody", true)?;
            info.set_item("spring_share", c.share)?;
            info.set_item("volume_fraction", c.volume_fraction)?;
            let names = c.symmetry.names();
            let fitted_d = PyDict::new(py);
            for ((name, a), d) in names.iter().zip(&c.achieved).zip(&c.d) {
                info.set_item(*name, *a)?;
                fitted_d.set_item(*name, *d)?;
            }
            info.set_item("fitted_d", fitted_d)?;
            info.set_item("pairwise_refusal", c.pairwise_refusal.as_str())?;
            info.set_item("iterations", c.history.len())?;
        }
    }
    Ok(info)
}
