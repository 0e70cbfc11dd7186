//! `anisobond.Packing`: spheres in a periodic cell or as a free cluster.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{column, rows3, vec3_array, write_staged};
use super::errors::{to_py, InputError};
use crate::io::OutputSet;
use crate::packing::{Packing, PeriodicCell};
use crate::Vec3;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Spheres in a periodic cell or as a free cluster.
///
/// Packing(positions, radii, cell=None, ids=None): positions (N, 3) in m, radii (N,) in m
/// (> 0), cell (Lx, Ly, Lz) in m or None for a free cluster, ids N distinct integers (e.g.
/// LIGGGHTS atom ids; bond tables then carry id_i, id_j). Positions are wrapped into the cell;
/// periodic images (from_bonds, bond tables) are of the positions as given (YADE's cellDist
/// with its body positions, also outside the cell).
/// Packing.load(path, cell=None, periodic=False, free=False) reads every format the command
/// line reads (docs/formats.md).
#[pyclass(name = "Packing", module = "anisobond", frozen)]
#[derive(Clone)]
pub struct PyPacking {
    pub(super) inner: Packing,
}

#[pymethods]
impl PyPacking {
    #[new]
    #[pyo3(signature = (positions, radii, cell = None, ids = None))]
    fn new(
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        radii: &Bound<'_, PyAny>,
        cell: Option<&Bound<'_, PyAny>>,
        ids: Option<Vec<u64>>,
    ) -> PyResult<Self> {
        let p = rows3(py, positions, "positions")?;
        let r = column(py, radii, "radii", Some(p.len()))?;
        let cell = match cell {
            None => None,
            Some(c) if c.is_none() => None,
            Some(c) => {
                let l = column(py, c, "cell", Some(3))?;
                Some(PeriodicCell::new(Vec3::new(l[0], l[1], l[2])).map_err(to_py)?)
            }
        };
        let mut inner = Packing::new(p, r, cell).map_err(to_py)?;
        if let Some(ids) = ids {
            inner = inner.with_ids(ids).map_err(to_py)?;
        }
        Ok(PyPacking { inner })
    }

    /// Read a packing file: every format the command line reads (docs/formats.md).
    ///
    /// For a file that does not state its cell (YADE export.text, plain text, LIGGGHTS data):
    /// cell=(Lx, Ly, Lz) makes it periodic with that cell (m), periodic=True takes a
    /// LIGGGHTS box as the periodic cell, free=True makes it a free cluster. Without them
    /// the reader's default is used and a UserWarning says what was assumed.
    #[staticmethod]
    #[pyo3(signature = (path, *, cell = None, periodic = false, free = false))]
    fn load(
        py: Python<'_>,
        path: PathBuf,
        cell: Option<(f64, f64, f64)>,
        periodic: bool,
        free: bool,
    ) -> PyResult<Self> {
        use crate::packing::io::{read_packing_as, CellChoice, CellOptionNames, CellOrigin};
        let choice =
            match (cell, periodic, free) {
                (None, false, false) => CellChoice::AsStated,
                (Some((x, y, z)), false, false) => CellChoice::Cell(Vec3::new(x, y, z)),
                (None, true, false) => CellChoice::Periodic,
                (None, false, true) => CellChoice::Free,
                _ => return Err(InputError::new_err(
                    "Packing.load: give at most one of cell=(Lx, Ly, Lz), periodic=True, free=True",
                )),
            };
        if let CellChoice::Cell(l) = choice {
            PeriodicCell::new(l).map_err(to_py)?;
        }
        let read = py
            .detach(|| read_packing_as(&path, choice))
            .map_err(to_py)?;
        if read.origin == CellOrigin::Assumed {
            let names = CellOptionNames {
                cell: "cell=(Lx, Ly, Lz)",
                periodic: "periodic=True",
                free: "free=True",
            };
            if let Some(note) = read.cell_note(&path.display().to_string(), names) {
                let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
                PyErr::warn(py, &category, &std::ffi::CString::new(note)?, 1)?;
            }
        }
        Ok(PyPacking {
            inner: read.packing,
        })
    }

    /// Particle ids from the file (LIGGGHTS atom ids, YADE body ids) or the constructor,
    /// shape (N,), or None when the particles are known by their index only.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<u64>>> {
        self.inner
            .ids
            .as_ref()
            .map(|ids| PyArray1::from_slice(py, ids))
    }

    /// Write the packing as anisobond's text format (`# periodic Lx Ly Lz`, `x y z r`).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        write_staged(path, OutputSet::file, |p| {
            crate::packing::io::write_packing(p, &self.inner)
        })
    }

    /// Centres, shape (N, 3), m (wrapped into the cell when periodic).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        vec3_array(py, &self.inner.positions)
    }

    /// Radii, shape (N,), m.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.radii)
    }

    /// Cell lengths (Lx, Ly, Lz) in m, or None for a free cluster.
    #[getter]
    fn cell(&self) -> Option<(f64, f64, f64)> {
        self.inner
            .cell
            .map(|c| (c.lengths.x, c.lengths.y, c.lengths.z))
    }

    /// Volume (m³): the cell's, or the bounding box's of a free cluster.
    #[getter]
    fn volume(&self) -> f64 {
        self.inner.volume()
    }

    /// Solid fraction φ (sphere volume over [`Self::volume`]).
    #[getter]
    fn solid_fraction(&self) -> f64 {
        self.inner.solid_fraction()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        match self.inner.cell {
            Some(c) => format!(
                "<anisobond.Packing: {} spheres, periodic cell {} × {} × {} m>",
                self.inner.len(),
                c.lengths.x,
                c.lengths.y,
                c.lengths.z
            ),
            None => format!(
                "<anisobond.Packing: {} spheres, free cluster>",
                self.inner.len()
            ),
        }
    }
}
