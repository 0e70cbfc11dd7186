//! `anisobond.Model`: a model file's bonding rule, scheme and geometry.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{column, json_to_py, rows3, write_staged};
use super::errors::{to_py, InputError};
use crate::bonds::stiffness::{check_bond_columns, springs_along};
use crate::io::OutputSet;
use crate::model::Model;
use crate::schemes::StiffnessScheme;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// A bond stiffness model: the model file's bonding rule, stiffness scheme and geometry.
///
/// Make one with Model.load(path) (TOML, or JSON by extension), Model.from_toml(text),
/// Model.from_dict({...}) or Model.truszkowska_mrv(); docs/formats.md has the keys.
#[pyclass(name = "Model", module = "anisobond", frozen)]
#[derive(Clone)]
pub struct PyModel {
    pub(super) inner: Model,
    /// The scheme, built (and checked, which scans the sphere) once; None when it needs a
    /// lattice scaling μ (cross-anisotropic) or the model has `[grains]` (a polycrystal has
    /// no one scheme: `springs` then refuses through `Model::springs_for`).
    scheme: Option<Arc<dyn StiffnessScheme>>,
}

impl PyModel {
    pub(super) fn wrap(inner: Model) -> PyResult<Self> {
        let scheme = if inner.needs_packing() || inner.grains.is_some() {
            None
        } else {
            Some(Arc::from(inner.build_scheme(None).map_err(to_py)?))
        };
        Ok(PyModel { inner, scheme })
    }
}

#[pymethods]
impl PyModel {
    /// Read a model file (TOML, or JSON by extension `.json`).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        PyModel::wrap(Model::from_path(&path).map_err(to_py)?)
    }

    /// Parse a TOML model text; `name` appears in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<toml>"))]
    fn from_toml(text: &str, name: &str) -> PyResult<Self> {
        PyModel::wrap(Model::from_toml_str(text, name).map_err(to_py)?)
    }

    /// A model from a dict with the model file's tables (`bonding`, `scheme`, `geometry`).
    #[staticmethod]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyAny>) -> PyResult<Self> {
        let text: String = py
            .import("json")?
            .call_method1("dumps", (d,))
            .map_err(|e| InputError::new_err(format!("model dict: not JSON-serialisable ({e})")))?
            .extract()?;
        PyModel::wrap(Model::from_json_str(&text, "<dict>").map_err(to_py)?)
    }

    /// Truszkowska 2018's MRV model (Sec. 5.1), the default of `anisobond demo`.
    #[staticmethod]
    fn truszkowska_mrv() -> PyResult<Self> {
        PyModel::wrap(Model::truszkowska_mrv())
    }

    /// The model file text (TOML), as `anisobond calibrate` writes it.
    fn to_toml(&self) -> String {
        self.inner.to_toml_string()
    }

    /// The model as a dict of its tables.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("tomllib")
            .and_then(|t| t.call_method1("loads", (self.inner.to_toml_string(),)))
            .or_else(|_| {
                let text = serde_json::to_string(
                    &toml::from_str::<toml::Value>(&self.inner.to_toml_string())
                        .map_err(|e| InputError::new_err(e.to_string()))?,
                )
                .map_err(|e| InputError::new_err(e.to_string()))?;
                json_to_py(py, &text)
            })
    }

    /// Write the model file atomically: JSON when `path` ends in `.json`, TOML otherwise.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let text = self.inner.to_string_for(&path);
        write_staged(path, OutputSet::file, |p| {
            crate::io::write_string_atomic(p, &text)
        })
    }

    /// The scheme kind: `cubic`, `isotropic` or `cross-anisotropic`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.inner.scheme.kind_name()
    }

    /// Springs of arbitrary bonds, exactly as an Assembly assigns them.
    ///
    /// normals: (N, 3) unit bond normals, lab frame (|n| = 1 within 1e-9).
    /// r_i, r_j: (N,) sphere radii at the two ends, m.
    /// lengths: (N,) centre distances, m.
    /// lattice_scaling: Šmilauer's μ (cross-anisotropic models only; `Assembly.lattice_scaling`).
    /// Returns a dict of (N,) arrays: kn, ks (N/m), kr, ktw (N·m/rad), radius (bond radius, m).
    #[pyo3(signature = (normals, r_i, r_j, lengths, lattice_scaling = None))]
    fn springs<'py>(
        &self,
        py: Python<'py>,
        normals: &Bound<'py, PyAny>,
        r_i: &Bound<'py, PyAny>,
        r_j: &Bound<'py, PyAny>,
        lengths: &Bound<'py, PyAny>,
        lattice_scaling: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = rows3(py, normals, "normals")?;
        let ri = column(py, r_i, "r_i", Some(n.len()))?;
        let rj = column(py, r_j, "r_j", Some(n.len()))?;
        let l = column(py, lengths, "lengths", Some(n.len()))?;
        let (model, cached) = (&self.inner, &self.scheme);
        let k = py
            .detach(|| match (cached, lattice_scaling) {
                (Some(scheme), _) => {
                    check_bond_columns(&n, &ri, &rj, &l)?;
                    springs_along(scheme.as_ref(), &model.geometry, &n, &ri, &rj, &l, &|b| {
                        format!("bond {b}")
                    })
                }
                _ => model.springs_for(&n, &ri, &rj, &l, lattice_scaling),
            })
            .map_err(to_py)?;
        let d = PyDict::new(py);
        d.set_item("kn", PyArray1::from_vec(py, k.kn))?;
        d.set_item("ks", PyArray1::from_vec(py, k.ks))?;
        d.set_item("kr", PyArray1::from_vec(py, k.kr))?;
        d.set_item("ktw", PyArray1::from_vec(py, k.ktw))?;
        d.set_item("radius", PyArray1::from_vec(py, k.radius))?;
        Ok(d)
    }

    /// True when the model has a `[strength]` table (docs/strength.md).
    #[getter]
    fn has_strength(&self) -> bool {
        self.inner.strength.is_some()
    }

    /// True when the model has a `[manybody]` table (docs/manybody.md).
    #[getter]
    fn has_many_body(&self) -> bool {
        self.inner.manybody.is_some()
    }

    /// YADE CohFrict limits of arbitrary bonds by the model's `[strength]` table, as
    /// `anisobond_yade.assign` sets them (docs/strength.md, "YADE"): each bond's strength
    /// (`strength::strengths_along`: scheme, planes of weakness, scatter by bond index) made
    /// into YADE's adhesions by `YadeAdhesion::of` (a_n = σ_t·r², a_s = c·r², r = min(r_i, r_j)).
    ///
    /// starts: (N, 3) first sphere centres (m); branches: (N, 3) vectors to the (image of the)
    /// second (m); r_i, r_j: (N,) radii (m). Returns a dict of (N,) arrays normal_adhesion,
    /// shear_adhesion (N), tan_friction, joint (the plane family crossed, or -1); None when
    /// the model has no `[strength]` table.
    fn yade_adhesions<'py>(
        &self,
        py: Python<'py>,
        starts: &Bound<'py, PyAny>,
        branches: &Bound<'py, PyAny>,
        r_i: &Bound<'py, PyAny>,
        r_j: &Bound<'py, PyAny>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        use crate::strength::criteria::YadeAdhesion;
        let Some(table) = &self.inner.strength else {
            return Ok(None);
        };
        let x = rows3(py, starts, "starts")?;
        let l = rows3(py, branches, "branches")?;
        let ri = column(py, r_i, "r_i", Some(l.len()))?;
        let rj = column(py, r_j, "r_j", Some(l.len()))?;
        let s = py
            .detach(|| {
                let spec = crate::strength::StrengthSpec::from_table(table)?;
                spec.refuse_cut_sections("Model.yade_adhesions")?;
                refuse_boundary_strength(&self.inner)?;
                crate::strength::strengths_along(&spec, &x, &l)
            })
            .map_err(to_py)?;
        let a = s.map(|b, st| YadeAdhesion::of(&st, ri[b], rj[b], false));
        let joint: Vec<i64> = (0..s.len())
            .map(|b| s.joint_of(b).map_or(-1, |k| k as i64))
            .collect();
        let d = PyDict::new(py);
        d.set_item(
            "normal_adhesion",
            PyArray1::from_vec(py, a.iter().map(|a| a.normal).collect()),
        )?;
        d.set_item(
            "shear_adhesion",
            PyArray1::from_vec(py, a.iter().map(|a| a.shear).collect()),
        )?;
        d.set_item(
            "tan_friction",
            PyArray1::from_vec(py, a.iter().map(|a| a.tan_friction).collect()),
        )?;
        d.set_item("joint", PyArray1::from_vec(py, joint))?;
        Ok(Some(d))
    }

    fn __repr__(&self) -> String {
        format!(
            "anisobond.Model.from_toml('''\n{}''')",
            self.inner.to_toml_string()
        )
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner.to_toml_string() == other.inner.to_toml_string()
    }
}

/// Refuse ([`crate::Error::Model`]) a model whose `[grains]` scale the strengths of boundary
/// bonds: bonds given as arrays have no particles, so no grains to tell a boundary bond by.
fn refuse_boundary_strength(model: &crate::model::Model) -> crate::Result<()> {
    match &model.grains {
        Some(g) if g.boundary_strength_factor != 1.0 => Err(crate::Error::Model(format!(
            "Model.yade_adhesions: [grains] boundary_strength_factor = {} needs each bond's              grains, and bonds given as arrays have no particles; use the assembly's export              (Assembly.export_yade) or remove the factor",
            g.boundary_strength_factor
        ))),
        _ => Ok(()),
    }
}
