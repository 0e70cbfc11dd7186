//! The studies (the library's [`crate::study`]) as Python functions: Kumar's buckled bars,
//! the polycrystal study and the virtual laboratory's strength tests (`Assembly.cavity` is a method, in
//! `assembly.rs`). Their dicts are the studies' reports,
//! the keys of the command's JSON, plus numpy arrays.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use super::convert::{json_to_py, report_to_py, vec3_array};
use super::errors::to_py;
use super::model::PyModel;
use super::packing::PyPacking;
use crate::homogenize::buckling::{BucklingOptions, PreBuckling, RoundBar};
use crate::study::buckling::BarRow;
use crate::study::strength_test::StrengthTestOptions;
use crate::Error;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A `#[pyfunction]` with the given arguments and signature followed by the virtual
/// laboratory's keywords (`width_particles` … `points`, the `strength-test` flags of the same
/// names, keyword-only, default None). The body gets them as the function named by `lab`:
/// `lab(base)` is `base` with each keyword given set (one not given keeps `base`'s value,
/// except `aspect`, whose None is the test's own aspect ratio).
macro_rules! lab_pyfunction {
    (
        $(#[$meta:meta])*
        fn $name:ident<$lt:lifetime>($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty;
        signature = ($($sig:tt)*);
        lab = $lab:ident;
        $body:block
    ) => {
        $(#[$meta])*
        #[pyfunction]
        #[pyo3(signature = ($($sig)*, width_particles = None, aspect = None, end_layer = None,
            loading_rate = None, max_strain = None, stop_fraction = None, peak_drop = None,
            local_damping = None, cell_particles = None, seed = None, points = None))]
        #[allow(clippy::too_many_arguments)]
        pub(super) fn $name<$lt>(
            $($arg: $ty,)*
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
        ) -> $ret {
            let $lab = move |base: $crate::study::strength_test::StrengthTestOptions| {
                $crate::study::strength_test::StrengthTestOptions {
                    width_particles: width_particles.unwrap_or(base.width_particles),
                    aspect,
                    end_layer: end_layer.unwrap_or(base.end_layer),
                    loading_rate: loading_rate.unwrap_or(base.loading_rate),
                    max_strain: max_strain.unwrap_or(base.max_strain),
                    stop_fraction: stop_fraction.unwrap_or(base.stop_fraction),
                    peak_drop: peak_drop.unwrap_or(base.peak_drop),
                    local_damping: local_damping.unwrap_or(base.local_damping),
                    cell_particles: cell_particles.unwrap_or(base.cell_particles),
                    seed: seed.unwrap_or(base.seed),
                    points: points.unwrap_or(base.points),
                    ..base
                }
            };
            $body
        }
    };
}
pub(super) use lab_pyfunction;

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

/// The polycrystal study (docs/polycrystal.md), as `anisobond polycrystal`: `model` must have
/// a `[grains]` table. The relaxed tensor of `packing` bonded by `model` beside the single
/// crystal's (the model without `[grains]`) random-texture bounds and estimates, and each
/// grain's mean stress along `load_axis` ("x", "y" or "z") under the uniaxial engineering
/// `strain` against its longitudinal modulus; `grain_counts` (e.g. [1, 8, 64]) adds a
/// convergence series. Returns polycrystal.json's dict (the same keys). GIL released.
#[pyfunction]
#[pyo3(signature = (packing, model, *, strain = 1e-4, load_axis = "x", grain_counts = None))]
pub(super) fn polycrystal<'py>(
    py: Python<'py>,
    packing: &PyPacking,
    model: &PyModel,
    strain: f64,
    load_axis: &str,
    grain_counts: Option<Vec<usize>>,
) -> PyResult<Bound<'py, PyDict>> {
    use crate::study::polycrystal::{run, PolycrystalOptions};
    use crate::study::OptionNames;
    let opts = PolycrystalOptions {
        strain,
        load_axis: super::method::one_of("load_axis", load_axis, &[("x", 0), ("y", 1), ("z", 2)])?,
        grain_counts: grain_counts.unwrap_or_default(),
        ..PolycrystalOptions::default()
    };
    opts.check(OptionNames::Keywords).map_err(to_py)?;
    let (p, m) = (&packing.inner, &model.inner);
    let json = py
        .detach(|| run(p, m, &opts, OptionNames::Keywords, &|_| {})?.to_json())
        .map_err(to_py)?;
    Ok(json_to_py(py, &json)?.cast_into::<PyDict>()?)
}

lab_pyfunction! {
    /// The virtual laboratory (docs/strength-test.md), as `anisobond strength-test`: `test`
    /// "ucs", "tension" or "brazilian" on a specimen cut from `packing` (None: a generated
    /// periodic packing of `cell_particles`, `seed`) bonded by `model` (None: the command's
    /// default model), the model turned by `bedding_deg` about y; the keywords are the
    /// command's flags (defaults the same). Returns strength_test.json's dict plus the curve
    /// as numpy arrays: `strain`, `stress_pa`, `lateral_strain` (NaN where not measured),
    /// `broken`. GIL released.
    fn strength_test<'py>(
        py: Python<'py>,
        test: &str,
        packing: Option<&PyPacking>,
        model: Option<&PyModel>,
        law: &str,
        shape: &str,
        bedding_deg: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>>;
    signature = (test = "ucs", *, packing = None, model = None, law = "yade",
        shape = "prism", bedding_deg = None);
    lab = lab;
    {
        use crate::study::strength_test::{run, TestKind};
        use crate::study::OptionNames;
        let test = TestKind::from_name(test).ok_or_else(|| {
            to_py(Error::Invalid(format!(
                "test {test:?}: expected \"ucs\", \"tension\" or \"brazilian\""
            )))
        })?;
        let d = StrengthTestOptions::default();
        let opts = lab(StrengthTestOptions {
            test,
            shape: lab_shape(shape)?,
            packing: packing.map(|p| p.inner.clone()),
            model: model.map(|m| m.inner.clone()),
            law: law_kind(law)?,
            bedding_deg: bedding_deg.unwrap_or(d.bedding_deg),
            ..d
        });
        opts.check(OptionNames::Keywords).map_err(to_py)?;
        let report = py.detach(|| run(&opts, &|_| {})).map_err(to_py)?;
        let dict = report_to_py(py, &report, "strength_test")?;
        let column = |f: &dyn Fn(&crate::study::strength_test::CurvePoint) -> f64| -> Vec<f64> {
            report.curve.iter().map(f).collect()
        };
        dict.set_item("strain", PyArray1::from_vec(py, column(&|c| c.strain)))?;
        dict.set_item(
            "stress_pa",
            PyArray1::from_vec(py, column(&|c| c.stress_pa)),
        )?;
        dict.set_item(
            "lateral_strain",
            PyArray1::from_vec(py, column(&|c| c.lateral_strain.unwrap_or(f64::NAN))),
        )?;
        dict.set_item(
            "broken",
            PyArray1::from_vec(py, column(&|c| c.broken as f64)),
        )?;
        Ok(dict)
    }
}

lab_pyfunction! {
    /// The bedding sweep (docs/strength-test.md), as `anisobond strength-test --bedding-sweep`:
    /// UCS and Brazilian disc at each angle of `angles_deg` (None: 0, 15, …, 90) on one packing
    /// with one model; the keywords are the lab's. Returns strength_sweep.json's dict (`rows`:
    /// per angle ucs_pa, modulus_pa, poisson, brazilian_pa, cracks, ratios). GIL released.
    fn strength_sweep<'py>(
        py: Python<'py>,
        angles_deg: Option<Vec<f64>>,
        packing: Option<&PyPacking>,
        model: Option<&PyModel>,
        law: &str,
        shape: &str,
    ) -> PyResult<Bound<'py, PyDict>>;
    signature = (angles_deg = None, *, packing = None, model = None, law = "yade",
        shape = "prism");
    lab = lab;
    {
        use crate::study::strength_sweep::{run, StrengthSweepOptions};
        use crate::study::OptionNames;
        let opts = StrengthSweepOptions {
            lab: lab(StrengthTestOptions {
                shape: lab_shape(shape)?,
                packing: packing.map(|p| p.inner.clone()),
                model: model.map(|m| m.inner.clone()),
                law: law_kind(law)?,
                ..StrengthTestOptions::default()
            }),
            angles_deg: angles_deg.unwrap_or_else(|| StrengthSweepOptions::default().angles_deg),
        };
        opts.check(OptionNames::Keywords).map_err(to_py)?;
        let report = py.detach(|| run(&opts, &|_| {})).map_err(to_py)?;
        report_to_py(py, &report, "strength_sweep")
    }
}

/// The lab's specimen shape by its keyword (`"prism"` or `"cylinder"`), refused by name.
pub(super) fn lab_shape(shape: &str) -> PyResult<crate::study::strength_test::SpecimenShape> {
    use crate::study::strength_test::SpecimenShape;
    match shape {
        "prism" => Ok(SpecimenShape::Prism),
        "cylinder" => Ok(SpecimenShape::Cylinder),
        other => Err(to_py(Error::Invalid(format!(
            "shape {other:?}: expected \"prism\" or \"cylinder\""
        )))),
    }
}

/// The integrator's bond law by its keyword (`method::LAWS`), refused by name.
pub(super) fn law_kind(law: &str) -> PyResult<crate::dem::LawKind> {
    super::method::LAWS
        .iter()
        .find(|(name, _)| *name == law)
        .map(|(_, k)| *k)
        .ok_or_else(|| {
            to_py(Error::Invalid(format!(
                "law {law:?}: expected \"yade\", \"parallel-bond\", \"kumar\" or \"lammps-bpm\""
            )))
        })
}
