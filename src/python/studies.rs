//! The studies (the library's [`crate::study`]) as Python functions: Kumar's buckled bars
//! (`Assembly.cavity` is a method, in `assembly.rs`). Their dicts are the studies' reports,
//! the keys of the command's JSON, plus numpy arrays.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{report_to_py, vec3_array};
use super::errors::to_py;
use super::model::PyModel;
use super::packing::PyPacking;
use crate::homogenize::buckling::{BucklingOptions, PreBuckling, RoundBar};
use crate::study::buckling::BarRow;
use crate::Error;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Kumar 2016 Sec. 5 (docs/buckling.md), as one row of `anisobond buckle`: the round bar of
/// radius `radius` (m) and slenderness l/r = `slenderness` cut along z from `packing`,
/// bonded by `model`, the spheres within `clamp_depth` (m; default the mean radius) of each
/// end clamped. Returns the row's dict (the keys of buckling.json's rows): E (`modulus_pa`),
/// the network's linearised critical stress beside Euler (Eq. 14) and Mazzilli (Eq. 15), with
/// `deformed` also on the bar deformed by its pre-buckling shortening (`sigma_deformed_pa`),
/// κGA, the full network result (`network`: EI, load factors, solver figures) and the first
/// mode (numpy, unit max norm). `tolerance` None: the library's (1e-6). GIL released.
#[pyfunction]
#[pyo3(signature = (packing, model, radius, slenderness, *, clamp_depth = None,
    deformed = true, tolerance = None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn buckle_bar<'py>(
    py: Python<'py>,
    packing: &PyPacking,
    model: &PyModel,
    radius: f64,
    slenderness: f64,
    clamp_depth: Option<f64>,
    deformed: bool,
    tolerance: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let (p, m) = (&packing.inner, model.inner.clone());
    let depth = clamp_depth.unwrap_or_else(|| p.mean_radius());
    let defaults = BucklingOptions::default();
    let opts = BucklingOptions {
        tolerance: tolerance.unwrap_or(defaults.tolerance),
        pre_buckling: if deformed {
            PreBuckling::UpdatedGeometry
        } else {
            PreBuckling::Linear
        },
        ..defaults
    };
    let (row, mode) = py
        .detach(|| {
            let bar = RoundBar::cut(p, m, radius, slenderness, depth)?;
            let r = bar.buckling(&opts)?;
            let row = BarRow::new(None, slenderness, &bar, &r, None)?;
            Ok::<_, Error>((row, r.mode))
        })
        .map_err(to_py)?;
    let d = report_to_py(py, &row, "buckle_bar")?;
    d.set_item("mode", vec3_array(py, &mode)?)?;
    Ok(d)
}
