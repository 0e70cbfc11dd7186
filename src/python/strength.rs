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

super::studies::lab_pyfunction! {
    /// Calibrate `model`'s `[strength]` table to `target` (the command's `--target` text,
    /// e.g. "tension=2MPa", "ucs=50MPa", "tension-along=1MPa,tension-across=3MPa") on specimens
    /// cut from `packing` (None: a generated packing); the keywords are the command's flags.
    /// Returns (calibrated Model, report dict: fitted_scale, fitted_strength, measured_peak_pa
    /// of the verification run, iterations, runs, history). GIL released.
    fn calibrate_strength_model<'py>(
        py: Python<'py>,
        model: &PyModel,
        target: &str,
        packing: Option<&PyPacking>,
        law: &str,
        shape: &str,
        bedding_deg: Option<f64>,
        tolerance: Option<f64>,
        max_iterations: Option<usize>,
    ) -> PyResult<(PyModel, Bound<'py, PyDict>)>;
    signature = (model, target, *, packing = None, law = "yade", shape = "prism",
        bedding_deg = None, tolerance = None, max_iterations = None);
    lab = lab;
    {
        let target = StrengthTarget::parse(target).map_err(to_py)?;
        let d = StrengthCalibrationOptions::default();
        let opts = StrengthCalibrationOptions {
            lab: lab(StrengthTestOptions {
                shape: super::studies::lab_shape(shape)?,
                packing: packing.map(|p| p.inner.clone()),
                law: super::studies::law_kind(law)?,
                bedding_deg: bedding_deg.unwrap_or(d.lab.bedding_deg),
                ..StrengthTestOptions::default()
            }),
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
}
