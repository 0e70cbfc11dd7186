//! `anisobond.ManyBody`: the many-body term of an assembly (src/manybody, docs/manybody.md)
//! evaluated at positions another code holds — what YADE's route (`anisobond_yade.
//! add_manybody`) calls every step, since YADE's bond laws are pairwise.

use super::convert::{column, rows3, tensor_array, vec3_array};
use super::errors::{to_py, InputError, ModelError};
use crate::manybody::ManyBody;
use crate::{Mat3, Vec3};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The many-body term of an assembly's bonds, its reference state the assembly's packing.
#[pyclass(name = "ManyBody", module = "anisobond", frozen)]
pub struct PyManyBody {
    pub(super) inner: ManyBody,
}

impl PyManyBody {
    /// The term of `assembly`'s model; refuses a model without `[manybody]`.
    pub(super) fn of(assembly: &crate::Assembly) -> PyResult<Self> {
        let inner = assembly.manybody().map_err(to_py)?.ok_or_else(|| {
            ModelError::new_err(
                "the model has no [manybody] table (docs/manybody.md): it has no many-body term",
            )
        })?;
        Ok(PyManyBody { inner })
    }
}

/// A (3, 3) float64 matrix, finite.
fn mat3_from(py: Python<'_>, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Mat3> {
    let rows = rows3(py, obj, name)?;
    if rows.len() != 3 {
        return Err(InputError::new_err(format!(
            "{name}: expected a (3, 3) matrix, got {} rows",
            rows.len()
        )));
    }
    Ok(Mat3::from_rows(&[
        rows[0].transpose(),
        rows[1].transpose(),
        rows[2].transpose(),
    ]))
}

/// A (3, 3) float64 array of a matrix.
fn mat3_array<'py>(py: Python<'py>, m: &Mat3) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows: Vec<Vec3> = (0..3).map(|i| m.row(i).transpose()).collect();
    vec3_array(py, &rows)
}

#[pymethods]
impl PyManyBody {
    /// Energy (J), forces (N, (N, 3)) and nominal stress (Pa, (3, 3)) of the term at
    /// `positions` ((N, 3) m, not re-wrapped since the reference) in the cell deformed by
    /// `cell_gradient` H ((3, 3); default identity): a dict with keys `energy`, `forces`,
    /// `stress`. Forces are −∂U/∂x (docs/manybody.md).
    #[pyo3(signature = (positions, cell_gradient = None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        cell_gradient: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let x = rows3(py, positions, "positions")?;
        let h = match cell_gradient {
            Some(h) if !h.is_none() => mat3_from(py, h, "cell_gradient")?,
            _ => Mat3::identity(),
        };
        let term = &self.inner;
        let e = py
            .detach(|| {
                let branch = term.branch_vectors(&x, &h)?;
                term.evaluate(&branch)
            })
            .map_err(to_py)?;
        let out = PyDict::new(py);
        out.set_item("energy", e.energy)?;
        out.set_item("forces", vec3_array(py, &e.forces)?)?;
        out.set_item("stress", mat3_array(py, &e.stress)?)?;
        Ok(out)
    }

    /// Per particle, the term's Gershgorin row bound of ω² (1/s²) for `masses` ((N,) kg):
    /// added to the springs' rows it keeps an explicit time step 2/ω_max safe.
    fn gershgorin_rows<'py>(
        &self,
        py: Python<'py>,
        masses: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let m = column(py, masses, "masses", Some(self.inner.len()))?;
        let term = &self.inner;
        let rows = py.detach(|| term.gershgorin_rows(&m)).map_err(to_py)?;
        Ok(PyArray1::from_vec(py, rows))
    }

    /// The lab-frame tensor D (Pa, (6, 6) Voigt); a polycrystal's term (one D per grain) is refused.
    #[getter]
    fn tensor<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let d = self.inner.tensor().map_err(to_py)?;
        tensor_array(
            py,
            &[0, 1, 2, 3, 4, 5].map(|i| [0, 1, 2, 3, 4, 5].map(|j| d[(i, j)])),
        )
    }

    /// Σ_p V_p / V over the particles that carry the term (1 when none is excluded).
    #[getter]
    fn volume_fraction(&self) -> f64 {
        self.inner.volume_fraction()
    }

    /// Indices of the particles left out (fewer than three non-coplanar bonds).
    #[getter]
    fn excluded(&self) -> Vec<u32> {
        self.inner.excluded().to_vec()
    }

    /// Number of particles.
    fn __len__(&self) -> usize {
        self.inner.len()
    }
}
