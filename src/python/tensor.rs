//! Tensor helpers: engineering constants of a stiffness tensor.

use super::convert::tensor_from;
use super::errors::to_py;
use crate::tensor::elastic::EngineeringConstants;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Engineering constants of a (6, 6) stiffness tensor C in Pa, from S = C⁻¹: Young's
/// moduli E1, E2, E3 (Pa), shear moduli G23, G13, G12 (Pa), Poisson ratios nu_ij.
#[pyfunction]
pub(super) fn engineering_constants<'py>(
    py: Python<'py>,
    stiffness: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let c = tensor_from(py, stiffness, "stiffness")?;
    let e = EngineeringConstants::from_stiffness(&c).map_err(to_py)?;
    let d = PyDict::new(py);
    for (k, name) in ["E1", "E2", "E3"].iter().enumerate() {
        d.set_item(*name, e.e[k])?;
    }
    for (k, name) in ["G23", "G13", "G12"].iter().enumerate() {
        d.set_item(*name, e.g[k])?;
    }
    for i in 0..3 {
        for j in 0..3 {
            if i != j {
                d.set_item(format!("nu{}{}", i + 1, j + 1), e.nu[(i, j)])?;
            }
        }
    }
    Ok(d)
}
