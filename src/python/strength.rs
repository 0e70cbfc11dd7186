//! `anisobond.calibrate_strength`: the `[strength]` table's scale(s) that make the virtual
//! laboratory reach a target tensile strength or UCS on the packing
//! ([`crate::calibrate::calibrate_strength`]), as `anisobond calibrate-strength`.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::report_to_py;
use super::errors::to_py;
use super::model::PyModel;
use super::packing::PyPacking;
use crate::calibrate::{calibrate_strength, StrengthCalibrationOptions, StrengthTarget};
use crate::study::strength_test::StrengthTestOptions;
use crate::study::OptionNames;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Calibrate `model`'s `[strength]` table to `target` (the command's `--target` text,
/// e.g. "tension=2MPa", "ucs=50MPa", "tension-along=1MPa,tension-across=3MPa") on specimens
/// cut from `packing` (None: a generated packing); the keywords are the command's flags.
/// Returns (calibrated Model, report dict: fitted_scale, fitted_strength, measured_peak_pa
/// of the verification run, iterations, runs, history). GIL released.
#[pyfunction]
#[pyo3(signature = (model, target, *, packing = None, law = "yade", shape = "prism",
    bedding_deg = None, width_particles = None, aspect = None, end_layer = None,
    loading_rate = None, max_strain = None, stop_fraction = None, peak_drop = None, local_damping = None,
    cell_particles = None, seed = None, points = None, tolerance = None,
    max_iterations = None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn calibrate_strength_model<'py>(
    py: Python<'py>,
    model: &PyModel,
    target: &str,
    packing: Option<&PyPacking>,
    law: &str,
    shape: &str,
    bedding_deg: Option<f64>,
    width_particles: Option<f64>,
    aspect: Option<f64>,
    end_layer: Option<f64>,
    loading_rate: Option<f64>,
    max_strain: Option<f64>,
    stop_fraction: Option<f64>,
    peak_drop: Option<f64>,
    local_damping: Option<f64>,
    cell_particles: Option<usize>,
    seed: Option<u64>,
    points: Option<usize>,
    tolerance: Option<f64>,
    max_iterations: Option<usize>,
) -> PyResult<(PyModel, Bound<'py, PyDict>)> {
    let target = StrengthTarget::parse(target).map_err(to_py)?;
    let d = StrengthCalibrationOptions::default();
    let lab = &d.lab;
    let shape = super::studies::lab_shape(shape)?;
    let law = super::studies::law_kind(law)?;
    let opts = StrengthCalibrationOptions {
        lab: StrengthTestOptions {
            shape,
            packing: packing.map(|p| p.inner.clone()),
            law,
            bedding_deg: bedding_deg.unwrap_or(lab.bedding_deg),
            width_particles: width_particles.unwrap_or(lab.width_particles),
            aspect,
            end_layer: end_layer.unwrap_or(lab.end_layer),
            loading_rate: loading_rate.unwrap_or(lab.loading_rate),
            max_strain: max_strain.unwrap_or(lab.max_strain),
            stop_fraction: stop_fraction.unwrap_or(lab.stop_fraction),
            peak_drop: peak_drop.unwrap_or(lab.peak_drop),
            local_damping: local_damping.unwrap_or(lab.local_damping),
            cell_particles: cell_particles.unwrap_or(lab.cell_particles),
            seed: seed.unwrap_or(lab.seed),
            points: points.unwrap_or(lab.points),
            ..StrengthTestOptions::default()
        },
        tolerance: tolerance.unwrap_or(d.tolerance),
        max_iterations: max_iterations.unwrap_or(d.max_iterations),
    };
    let base = model.inner.clone();
    let cal = py
        .detach(|| calibrate_strength(&base, &target, &opts, OptionNames::Keywords, &|_| {}))
        .map_err(to_py)?;
    let dict = report_to_py(py, &cal, "calibrate_strength")?;
    Ok((PyModel::wrap(cal.model)?, dict))
}
