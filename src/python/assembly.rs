//! `anisobond.Assembly`: a bonded packing, its tensors, studies on it and its exports.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{
    column, json_to_py, report_to_py, rows3, tensor_array, vec3_array, write_staged,
};
use super::errors::{to_py, InputError};
use super::method::MethodArgs;
use super::model::PyModel;
use super::packing::PyPacking;
use crate::assembly::Assembly;
use crate::homogenize::report::TensorReport;
use crate::io::OutputSet;
use crate::study::cavity::CavityStudyOptions;
use crate::study::OptionNames;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Mutex;

/// A bonded packing: the bonds the model's rule draws and every bond's springs.
///
/// Assembly(packing, model) bonds by the model's rule; Assembly.from_bonds(packing, model,
/// i, j, image=None) takes given pairs (a YADE or LIGGGHTS scene's own interactions).
/// .bonds is the bond table, .tensor(method) the 6×6 stiffness in Pa.
#[pyclass(name = "Assembly", module = "anisobond", frozen)]
pub struct PyAssembly {
    pub(super) inner: Assembly,
}

impl PyAssembly {
    /// The checked report of `args`' method, computed without the GIL; `progress(fraction)`
    /// is called (with the GIL) as the dynamic method advances, at most every 1 %.
    fn report(&self, py: Python<'_>, args: MethodArgs) -> PyResult<TensorReport> {
        let method = args.method()?;
        let progress = args.progress;
        let last = Mutex::new(-1.0_f64);
        let report = |f: f64| {
            let Some(cb) = &progress else { return };
            let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
            if f - *l < 0.01 && f < 1.0 {
                return;
            }
            *l = f;
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (f,)) {
                    e.write_unraisable(py, None);
                }
            });
        };
        let asm = &self.inner;
        let result = py
            .detach(|| asm.tensor_with_progress(&method, &report))
            .map_err(to_py)?;
        Ok(result.report)
    }
}

#[pymethods]
impl PyAssembly {
    #[new]
    fn new(py: Python<'_>, packing: &PyPacking, model: &PyModel) -> PyResult<Self> {
        let (p, m) = (packing.inner.clone(), model.inner.clone());
        let inner = py.detach(|| Assembly::new(p, m)).map_err(to_py)?;
        Ok(PyAssembly { inner })
    }

    /// An assembly of given bonds (e.g. a YADE scene's interactions) instead of the
    /// model's bonding rule.
    #[staticmethod]
    #[pyo3(signature = (packing, model, i, j, image = None))]
    fn from_bonds(
        py: Python<'_>,
        packing: &PyPacking,
        model: &PyModel,
        i: &Bound<'_, PyAny>,
        j: &Bound<'_, PyAny>,
        image: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let index = |obj: &Bound<'_, PyAny>, name: &str| -> PyResult<Vec<u32>> {
            let v = column(py, obj, name, None)?;
            v.iter()
                .enumerate()
                .map(|(k, &x)| {
                    if x >= 0.0 && x.fract() == 0.0 && x <= u32::MAX as f64 {
                        Ok(x as u32)
                    } else {
                        Err(InputError::new_err(format!(
                            "{name}[{k}] = {x}: expected a particle index (integer >= 0)"
                        )))
                    }
                })
                .collect()
        };
        let (i, j) = (index(i, "i")?, index(j, "j")?);
        let image = match image {
            Some(m) if !m.is_none() => {
                let rows = rows3(py, m, "image")?;
                let mut out = Vec::with_capacity(rows.len());
                for (k, r) in rows.iter().enumerate() {
                    if r.iter().any(|x| x.fract() != 0.0 || x.abs() > 1e6) {
                        return Err(InputError::new_err(format!(
                            "image[{k}] = {:?}: expected integer cell shifts",
                            [r.x, r.y, r.z]
                        )));
                    }
                    out.push([r.x as i32, r.y as i32, r.z as i32]);
                }
                Some(out)
            }
            _ => None,
        };
        let (p, m) = (packing.inner.clone(), model.inner.clone());
        let inner = py
            .detach(|| {
                let bonds = crate::bonds::BondSet::from_pairs(&p, &i, &j, image.as_deref())?;
                Assembly::with_bonds(p, m, bonds)
            })
            .map_err(to_py)?;
        Ok(PyAssembly { inner })
    }

    /// The bond table as a dict of numpy columns: i, j (particle indices, i < j), normal
    /// (Nb, 3, unit, from i to the image of j), length (m), radius (bond radius, m), kn, ks
    /// (N/m), kr, ktw (N·m/rad), image (Nb, 3, cell shifts of j among the positions as
    /// given to Packing, as from_bonds takes them).
    #[getter]
    fn bonds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (b, k) = (&self.inner.bonds, &self.inner.springs);
        let d = PyDict::new(py);
        d.set_item("i", PyArray1::from_slice(py, &b.i))?;
        d.set_item("j", PyArray1::from_slice(py, &b.j))?;
        d.set_item("normal", vec3_array(py, &b.normal)?)?;
        d.set_item("length", PyArray1::from_slice(py, &b.length))?;
        d.set_item("radius", PyArray1::from_slice(py, &k.radius))?;
        d.set_item("kn", PyArray1::from_slice(py, &k.kn))?;
        d.set_item("ks", PyArray1::from_slice(py, &k.ks))?;
        d.set_item("kr", PyArray1::from_slice(py, &k.kr))?;
        d.set_item("ktw", PyArray1::from_slice(py, &k.ktw))?;
        let as_given = self.inner.bonds_as_given();
        let image: Vec<i32> = as_given.image.iter().flatten().copied().collect();
        d.set_item(
            "image",
            PyArray1::from_vec(py, image).reshape([b.len(), 3])?,
        )?;
        Ok(d)
    }

    /// The grains the springs were assigned by (a model with `[grains]`, docs/polycrystal.md)
    /// as a dict: `grain` (N,) uint32, each particle's grain id; `orientation` (G, 3, 3), each
    /// grain's Bunge matrix (sample → crystal); `centres` (G, 3) m, the Voronoi centres, or
    /// None for a grain file's map. None for a single crystal or bonds from a table.
    #[getter]
    fn grains<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(g) = self.inner.grains() else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("grain", PyArray1::from_slice(py, &g.grain))?;
        let rows: Vec<f64> = g
            .orientation
            .iter()
            .flat_map(|m| (0..3).flat_map(move |r| (0..3).map(move |c| m[(r, c)])))
            .collect();
        d.set_item(
            "orientation",
            PyArray1::from_vec(py, rows).reshape([g.len(), 3, 3])?,
        )?;
        match &g.centres {
            Some(c) => d.set_item("centres", vec3_array(py, c)?)?,
            None => d.set_item("centres", py.None())?,
        }
        Ok(Some(d))
    }

    /// The packing.
    #[getter]
    fn packing(&self) -> PyPacking {
        PyPacking {
            inner: self.inner.packing.clone(),
        }
    }

    /// The model.
    #[getter]
    fn model(&self) -> PyResult<PyModel> {
        PyModel::wrap(self.inner.model.clone())
    }

    /// Number of bonds.
    #[getter]
    fn n_bonds(&self) -> usize {
        self.inner.bonds.len()
    }

    /// Number of particles.
    #[getter]
    fn n_particles(&self) -> usize {
        self.inner.packing.len()
    }

    /// Mean bonds per particle Z = 2 N_b / N.
    #[getter]
    fn coordination(&self) -> f64 {
        self.inner.coordination()
    }

    /// The many-body term of the model's `[manybody]` table on these bonds (docs/manybody.md);
    /// `ModelError` when the model has none.
    fn many_body(&self) -> PyResult<super::manybody::PyManyBody> {
        super::manybody::PyManyBody::of(&self.inner)
    }

    /// Šmilauer's lattice scaling μ of these bonds (the cross-anisotropic scheme's input).
    #[getter]
    fn lattice_scaling(&self) -> PyResult<f64> {
        let a = &self.inner;
        crate::bonds::lattice_scaling(&a.packing, &a.bonds, a.model.geometry.pi_hat).map_err(to_py)
    }

    /// The (6, 6) stiffness tensor in Pa (Voigt order 11 22 33 23 13 12, engineering strain).
    ///
    /// method: "mean-field" (orientation integral at the bond density), "voigt" (affine sum
    /// over the bonds), "relaxed" (exact static equilibrium, sparse solve), "prestressed"
    /// (relaxed tangent under the isotropic preload `prestress` Pa), "laf" (Kruyt's
    /// local adjustment field, shell order `shell` 1-6, `energy` for the upper bound) or
    /// "dynamic" (the reference integrator's damped element tests).
    /// Keyword options (defaults): shell=2, energy=False, lever_arm="mid-gap",
    /// tolerance=1e-6, solver="cg", law="yade", strain=1e-5, damping=0.4, max_steps=20000,
    /// progress=None; an unknown keyword is an InputError.
    /// lever_arm: "mid-gap" (YADE's contact point), "proportional" or "half-length"
    /// (LAMMPS bpm/rotational). tolerance, solver: relaxed only; relative CG residual in [1e-12, 1e-2], "cg",
    /// "cg-jacobi", "cg-amg" (smoothed-aggregation multigrid) or "cholesky".
    /// law, strain, damping, max_steps: dynamic only; "yade", "parallel-bond", "kumar" or "lammps-bpm",
    /// strain per path, Cundall damping, step limit per path.
    /// progress: a callable taking the completed fraction (0-1), called as the dynamic
    /// method advances. The GIL is released during the computation.
    #[pyo3(signature = (method = "relaxed", **options))]
    fn tensor<'py>(
        &self,
        py: Python<'py>,
        method: &str,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.report(py, MethodArgs::parse(method, options)?)?;
        tensor_array(py, &r.c)
    }

    /// The tensor report of `method` as a dict: the JSON `anisobond tensor --json` prints
    /// (C in Pa, cubic and transverse projections, coordination, relative_residual, …).
    /// Arguments as for `tensor`.
    #[pyo3(signature = (method = "relaxed", **options))]
    fn tensor_report<'py>(
        &self,
        py: Python<'py>,
        method: &str,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let r = self.report(py, MethodArgs::parse(method, options)?)?;
        json_to_py(py, &r.to_json())
    }

    /// The relaxed solve's linear system as a dict, for solving it with another code:
    /// "indptr", "indices", "data" (K in CSR over the 6·m DOFs of the m active particles: ux,
    /// uy, uz in m, then θx, θy, θz in rad, scipy.sparse.csr_matrix((data, indices, indptr))),
    /// "g" (6m, 6) the loads of the six unit strains (Voigt order, engineering shears), "h"
    /// (6, 6) the affine energy matrix (Pa·m³), "volume" (m³) and "active" (m,) the packing
    /// index of each row block. The relaxed tensor is C = (h − gᵀq)/volume with K q = g (K is
    /// singular along the rigid translations; g is orthogonal to them). lever_arm and
    /// rotations as for tensor("relaxed"); a many-body term is included. GIL released.
    #[pyo3(signature = (*, lever_arm = "mid-gap", rotations = true))]
    fn relaxed_system<'py>(
        &self,
        py: Python<'py>,
        lever_arm: &str,
        rotations: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let opts = crate::homogenize::relaxed::RelaxedOptions {
            lever_arm: super::method::one_of("lever_arm", lever_arm, &super::method::LEVER_ARMS)?,
            rotations,
            ..Default::default()
        };
        let asm = &self.inner;
        let s = py.detach(|| asm.relaxed_system(&opts)).map_err(to_py)?;
        let d = PyDict::new(py);
        let indptr: Vec<i64> = s.row_start.iter().map(|&r| r as i64).collect();
        let indices: Vec<i64> = s.column.iter().map(|&c| c as i64).collect();
        let active: Vec<i64> = s.active.iter().map(|&p| p as i64).collect();
        d.set_item("indptr", PyArray1::from_vec(py, indptr))?;
        d.set_item("indices", PyArray1::from_vec(py, indices))?;
        d.set_item("data", PyArray1::from_vec(py, s.value))?;
        d.set_item("g", PyArray1::from_vec(py, s.g).reshape([s.unknowns, 6])?)?;
        let h: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| s.h[(i, j)]));
        d.set_item("h", tensor_array(py, &h)?)?;
        d.set_item("volume", s.volume)?;
        d.set_item("active", PyArray1::from_vec(py, active))?;
        Ok(d)
    }

    /// The assembly as a finite specimen between two platens (`anisobond specimen`,
    /// docs/specimens.md): the dict of specimen.json (platen_stiffness N/m, young Pa, poisson,
    /// reactions N, …) plus "displacement" (N, 3) m and "layer" (N,) 0/1/2 (none, held,
    /// moved). The options are the command's: `held`/`moved` as `box:…`, `cylinder:…`,
    /// `ids:…` or `file:PATH`; at most one of `strain`, `displacement` (m), `force` (N);
    /// `confining_pressure` (Pa), `shape` "prism" | "cylinder", `lateral` "free" |
    /// "periodic". `axis` and `lateral` default as the command's: a box of mixed periodicity
    /// (a slab as read) along its free axis, laterally periodic; otherwise z, free. GIL
    /// released.
    #[pyo3(signature = (axis = None, *, end_layer = None, platens = "frictionless", strain = None,
        displacement = None, force = None, held = None, moved = None, confining_pressure = None,
        shape = "prism", lateral = None))]
    #[allow(clippy::too_many_arguments)]
    fn specimen<'py>(
        &self,
        py: Python<'py>,
        axis: Option<&str>,
        end_layer: Option<f64>,
        platens: &str,
        strain: Option<f64>,
        displacement: Option<f64>,
        force: Option<f64>,
        held: Option<&str>,
        moved: Option<&str>,
        confining_pressure: Option<f64>,
        shape: &str,
        lateral: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        use crate::specimen::{solve, Lateral, Load, Platens, Selection, Shape, SpecimenOptions};
        let axis = axis
            .map(|a| choose("axis", a, &[("x", 0), ("y", 1), ("z", 2)]))
            .transpose()?;
        let platens = choose(
            "platens",
            platens,
            &[
                ("frictionless", Platens::Frictionless),
                ("bonded", Platens::Bonded),
            ],
        )?;
        let load = match (strain, displacement, force) {
            (None, None, None) => Load::default(),
            (Some(s), None, None) => Load::Strain(s),
            (None, Some(d), None) => Load::Displacement(d),
            (None, None, Some(f)) => Load::Force(f),
            _ => {
                return Err(InputError::new_err(
                    "give at most one of strain, displacement and force",
                ))
            }
        };
        let group = |t: Option<&str>, name: &str| {
            t.map(|t| Selection::parse(t, name))
                .transpose()
                .map_err(to_py)
        };
        let src = &self.inner;
        let mut opts = SpecimenOptions::defaults_for(&src.packing, axis, end_layer);
        opts.platens = platens;
        opts.load = load;
        opts.held = group(held, "held")?;
        opts.moved = group(moved, "moved")?;
        opts.confining_pressure = confining_pressure;
        opts.shape = choose(
            "shape",
            shape,
            &[("prism", Shape::Prism), ("cylinder", Shape::Cylinder)],
        )?;
        if let Some(lateral) = lateral {
            opts.lateral = choose(
                "lateral",
                lateral,
                &[("free", Lateral::Free), ("periodic", Lateral::Periodic)],
            )?;
        }
        let r = py.detach(|| solve(src, &opts)).map_err(to_py)?;
        let d = report_to_py(py, &r, "specimen")?;
        d.set_item("displacement", vec3_array(py, &r.displacement_field)?)?;
        d.set_item(
            "layer",
            numpy::PyArray1::from_vec(py, r.layer.iter().map(|&l| l as i64).collect()),
        )?;
        Ok(d)
    }

    /// Šmilauer's pressurised cavity (docs/cavity.md), as `anisobond cavity` without the
    /// wave run: a slab with a hole of radius `hole_radius` (m; default 10 R̄) cut from this
    /// periodic assembly, clamped beyond `outer_radius` (default 24 R̄), the wall under
    /// `pressure` (Pa; default 1e6). Returns the dict of cavity.json (the same keys): the DEM
    /// wall displacement (m) beside Lamé (the relaxed tensor's isotropic projection) and,
    /// under `continuum`, the anisotropic continuum of the full relaxed tensor and the ±20°
    /// wall bins; the in-plane Christoffel speeds at `density` (kg/m³; default 2600); and
    /// numpy arrays `positions`, `displacement` (m) of the slab's spheres. GIL released.
    #[pyo3(signature = (hole_radius = None, *, outer_radius = None, pressure = None,
        clamp_width = None, ray_spacing = None, density = None))]
    #[allow(clippy::too_many_arguments)]
    fn cavity<'py>(
        &self,
        py: Python<'py>,
        hole_radius: Option<f64>,
        outer_radius: Option<f64>,
        pressure: Option<f64>,
        clamp_width: Option<f64>,
        ray_spacing: Option<f64>,
        density: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let defaults = CavityStudyOptions::default();
        let opts = CavityStudyOptions {
            hole_radius,
            outer_radius,
            clamp_width,
            ray_spacing,
            pressure: pressure.unwrap_or(defaults.pressure),
            density: density.unwrap_or(defaults.density),
            ..defaults
        };
        let src = &self.inner;
        let (json, positions, displacement) = py
            .detach(|| {
                let r = crate::study::cavity::run(src, &opts, OptionNames::Keywords)?;
                Ok::<_, crate::Error>((
                    r.to_json()?,
                    r.cavity.cut.packing.positions,
                    r.comparison.solution.displacement,
                ))
            })
            .map_err(to_py)?;
        let d = json_to_py(py, &json)?.cast_into::<PyDict>()?;
        d.set_item("positions", vec3_array(py, &positions)?)?;
        d.set_item("displacement", vec3_array(py, &displacement)?)?;
        Ok(d)
    }

    /// Write the bond table (CSV, docs/formats.md) to `path` atomically.
    fn write_bonds(&self, path: PathBuf) -> PyResult<()> {
        write_staged(path, OutputSet::file, |p| self.inner.write_bonds(p))
    }

    /// Write a directory YADE 2023.02a runs as it is (`yade -n -x DIR/run.py`), as
    /// `anisobond export yade` does: strain per path, steps after it, damping λ, density
    /// (kg/m³), time_step (s; None: safety × the critical step), paths ("11,22,…").
    #[pyo3(signature = (directory, *, strain = 1e-5, steps = 200, damping = 0.4,
        density = 2600.0, time_step = None, safety = 0.8, paths = "11,22,33,23,13,12"))]
    #[allow(clippy::too_many_arguments)]
    fn export_yade(
        &self,
        directory: PathBuf,
        strain: f64,
        steps: usize,
        damping: f64,
        density: f64,
        time_step: Option<f64>,
        safety: f64,
        paths: &str,
    ) -> PyResult<()> {
        use crate::export::yade::{parse_paths, write_assembly_export, YadeRunOptions};
        let opts = YadeRunOptions {
            strain,
            steps,
            damping,
            density,
            time_step,
            safety,
            paths: parse_paths(paths).map_err(to_py)?,
            stress_volume: None,
        };
        opts.validate().map_err(to_py)?;
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            write_assembly_export(d, a, &opts).map(|_| ())
        })
    }

    /// Write LIGGGHTS 3.8 decks into `directory` as `anisobond export liggghts` does
    /// (driver deck `anisobond.in`, stock `harmonic.in`); shear=False: the three normal cases.
    #[pyo3(signature = (directory, *, shear = true))]
    fn export_liggghts(&self, directory: PathBuf, shear: bool) -> PyResult<()> {
        use crate::export::liggghts::{export_liggghts, DeckOptions};
        let opts = DeckOptions {
            shear,
            ..Default::default()
        };
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            export_liggghts(d, &a.packing, &a.bonds, &a.springs, &opts).map(|_| ())
        })
    }

    /// ParaView files `particles.vtu` and `bonds.vtu` in `directory`, as `anisobond export
    /// vtk` writes them: unloaded, or with `strain` (6 Voigt components, engineering, each
    /// |ε| ≤ 0.1; periodic packings) the quasi-static state (displacements, bond forces).
    #[pyo3(signature = (directory, *, strain = None))]
    fn export_vtk(
        &self,
        py: Python<'_>,
        directory: PathBuf,
        strain: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let strain = match strain {
            Some(s) if !s.is_none() => {
                let e = column(py, s, "strain", Some(6))?;
                Some(crate::tensor::Voigt6::from_column_slice(&e))
            }
            _ => None,
        };
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            py.detach(|| a.write_vtk(d, strain.as_ref())).map(|_| ())
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "<anisobond.Assembly: {} particles, {} bonds, Z = {:.3}>",
            self.inner.packing.len(),
            self.inner.bonds.len(),
            self.inner.coordination()
        )
    }
}

/// The value of `choices` called `given`, or an InputError naming `option` and every name.
fn choose<T: Copy>(option: &str, given: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices
        .iter()
        .find(|(name, _)| *name == given)
        .map(|&(_, v)| v)
        .ok_or_else(|| {
            let names: Vec<String> = choices.iter().map(|(n, _)| format!("{n:?}")).collect();
            InputError::new_err(format!("{option} {given:?}: expected {}", names.join(", ")))
        })
}
