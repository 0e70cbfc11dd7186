//! The studies as Python functions: Kumar's buckled bars.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{json_to_py, vec3_array};
use super::errors::{to_py, InputError};
use super::model::PyModel;
use super::packing::PyPacking;
use crate::Error;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Kumar 2016 Sec. 5 (docs/buckling.md), as one row of `anisobond buckle`: the round bar of
/// radius `radius` (m) and slenderness l/r = `slenderness` cut along z from `packing`,
/// bonded by `model`, the spheres within `clamp_depth` (m; default the mean radius) of each
/// end clamped. Returns a dict: E (Pa), the network's linearised critical stress (Pa) beside
/// Euler (Eq. 14) and Mazzilli (Eq. 15), with `deformed` also on the bar deformed by its
/// pre-buckling shortening (`sigma_deformed_pa`), EI, κGA, solver figures and the first mode
/// (numpy, unit max norm). GIL released.
#[pyfunction]
#[pyo3(signature = (packing, model, radius, slenderness, *, clamp_depth = None,
    deformed = true, tolerance = 1e-6))]
#[allow(clippy::too_many_arguments)]
pub(super) fn buckle_bar<'py>(
    py: Python<'py>,
    packing: &PyPacking,
    model: &PyModel,
    radius: f64,
    slenderness: f64,
    clamp_depth: Option<f64>,
    deformed: bool,
    tolerance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    use crate::homogenize::buckling::{
        euler_stress, mazzilli_stress, BucklingOptions, PreBuckling, RoundBar,
    };
    let (p, m) = (&packing.inner, model.inner.clone());
    let depth = clamp_depth.unwrap_or_else(|| p.mean_radius());
    let opts = BucklingOptions {
        tolerance,
        pre_buckling: if deformed {
            PreBuckling::UpdatedGeometry
        } else {
            PreBuckling::Linear
        },
        ..BucklingOptions::default()
    };
    let (bar, r) = py
        .detach(|| {
            let bar = RoundBar::cut(p, m, radius, slenderness, depth)?;
            let r = bar.buckling(&opts)?;
            Ok::<_, Error>((bar, r))
        })
        .map_err(to_py)?;
    let json = serde_json::to_string(&r).map_err(|e| InputError::new_err(e.to_string()))?;
    let d = json_to_py(py, &json)?.cast_into::<PyDict>()?;
    let (e, l) = (r.modulus, bar.length);
    // None, never NaN or infinity: Mazzilli has no root below l/r = 2π, a bar without
    // measurable shear flexibility has κGA = ∞.
    let finite = |x: f64| Some(x).filter(|x| x.is_finite());
    d.set_item("spheres", bar.assembly.packing.len())?;
    d.set_item("radius_m", radius)?;
    d.set_item("length_m", l)?;
    d.set_item("sigma_euler_pa", euler_stress(e, slenderness))?;
    d.set_item("sigma_mazzilli_pa", finite(mazzilli_stress(e, slenderness)))?;
    d.set_item("sigma_network_pa", r.critical_stress)?;
    d.set_item(
        "sigma_deformed_pa",
        r.updated_geometry.map(|u| u.critical_stress),
    )?;
    d.set_item("bending_ratio", r.bending_ratio(bar.area()))?;
    d.set_item("shear_stiffness_n", finite(r.shear_stiffness(l)))?;
    d.set_item(
        "network_over_engesser_own",
        finite(r.critical_force / r.engesser_force_own(l)),
    )?;
    d.set_item("mode", vec3_array(py, &r.mode)?)?;
    Ok(d)
}
