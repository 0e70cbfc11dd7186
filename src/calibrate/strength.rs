//! Strength calibration (issue 32 item 6; docs/calibrate-strength.md): the bond strengths of
//! a model's `[strength]` table that make the virtual laboratory
//! ([`crate::study::strength_test`]), run on the actual packing, reach a target direct
//! tensile strength (along one direction, or along and across the cross-anisotropy axis) or
//! a UCS.
//!
//! The parameters are scale factors of the table's strength values (tensile, cohesion and,
//! where given, bending and twisting; never the friction): one target scales
//! `[strength.bond]` and `[strength.along]` together; the two-direction target scales
//! `[strength.along]` by s_along and `[strength.bond]` (the across strengths) by s_across.
//! Planes of weakness keep their joint strengths (separate parameters of the rock).
//!
//! The peak of an elastic-brittle bonded specimen is proportional to the strength scale
//! only approximately (friction of broken pairs, the order in which bonds break), so the
//! fit iterates on the lab's measured peaks: unknowns x = ln s, residuals f = ln P(x) − ln T,
//! Broyden's method (1965) starting from the Jacobian I — in one dimension the secant method
//! started from the one-run linear estimate s₁ = s₀·T/P₀, in two the diagonal estimate.
//! Converged when every |P/T − 1| ≤ tolerance; otherwise [`crate::Error::NotConverged`]
//! naming the last error. The calibrated model is then written to text, read back, and run
//! once more: the report's `measured_*` peaks come from that verification run, its
//! `fitted_*` values are the parameters.

use crate::calibrate::target::{parse_value, target_items};
use crate::model::Model;
use crate::strength::spec::{StrengthTable, StrengthValues};
use crate::strength::{StrengthScheme, StrengthSpec};
use crate::study::strength_test::{run, StrengthTestOptions, StrengthTestReport, TestKind};
use crate::study::OptionNames;
use crate::{Error, Result};
use nalgebra::{Matrix2, Vector2};
use serde::Serialize;
use std::path::Path;

/// What the calibrated model must reach in the lab.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StrengthTarget {
    /// The direct tensile strength (Pa) with the load along z at the lab's bedding angle.
    Tension(f64),
    /// The uniaxial compressive strength (Pa) at the lab's bedding angle.
    Ucs(f64),
    /// Direct tensile strengths (Pa) with the load along and across the `[strength]` axis
    /// (which must lie in the x–z plane, the plane the lab turns the model in).
    TensionAlongAcross {
        /// Loaded along the axis.
        along: f64,
        /// Loaded across the axis (in the x–z plane).
        across: f64,
    },
}

impl StrengthTarget {
    /// Parse `tension=…`, `ucs=…` or `tension-along=…,tension-across=…` (Pa, or with a unit
    /// suffix kPa, MPa, GPa; keys case-insensitive). Values must be finite and > 0.
    pub fn parse(text: &str) -> Result<StrengthTarget> {
        let (mut tension, mut ucs, mut along, mut across) = (None, None, None, None);
        for item in target_items(text) {
            let (key, value) = item.split_once('=').ok_or_else(|| {
                Error::Invalid(format!("--target: `{item}` is not of the form KEY=VALUE"))
            })?;
            let slot = match key.trim().to_ascii_lowercase().as_str() {
                "tension" => &mut tension,
                "ucs" => &mut ucs,
                "tension-along" => &mut along,
                "tension-across" => &mut across,
                _ => {
                    return Err(Error::Invalid(format!(
                        "--target: unknown key `{key}` (expected tension, ucs, or \
                         tension-along and tension-across)"
                    )))
                }
            };
            if slot.is_some() {
                return Err(Error::Invalid(format!("--target: `{key}` given twice")));
            }
            *slot = Some(parse_value(value, key, true)?);
        }
        let t = match (tension, ucs, along, across) {
            (Some(t), None, None, None) => StrengthTarget::Tension(t),
            (None, Some(u), None, None) => StrengthTarget::Ucs(u),
            (None, None, Some(along), Some(across)) => {
                StrengthTarget::TensionAlongAcross { along, across }
            }
            _ => {
                return Err(Error::Invalid(format!(
                    "--target `{text}`: give exactly one of tension=…, ucs=…, or both \
                     tension-along=… and tension-across=… (Pa)"
                )))
            }
        };
        t.checked()
    }

    /// Refuses a target strength that is not finite and > 0, by name.
    pub fn checked(self) -> Result<StrengthTarget> {
        for (name, v) in self.values() {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Invalid(format!(
                    "target {name} = {v} Pa: expected a finite strength > 0"
                )));
            }
        }
        Ok(self)
    }

    /// The target values by name (`tension`, `ucs`, `tension-along`, `tension-across`).
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        match *self {
            StrengthTarget::Tension(t) => vec![("tension", t)],
            StrengthTarget::Ucs(u) => vec![("ucs", u)],
            StrengthTarget::TensionAlongAcross { along, across } => {
                vec![("tension-along", along), ("tension-across", across)]
            }
        }
    }
}

/// Options of [`calibrate_strength`].
#[derive(Clone, Debug)]
pub struct StrengthCalibrationOptions {
    /// The lab's options (packing, law, specimen, rate, ...). Its `model` is ignored (the
    /// base model is given apart); its `test` is set by the target; its `bedding_deg` is
    /// used by one-direction targets and set from the axis by the two-direction one.
    pub lab: StrengthTestOptions,
    /// Relative tolerance on every peak, |P/T − 1|, in (0, 0.1].
    pub tolerance: f64,
    /// Iterations allowed (lab runs per iteration: one per target value), the starting
    /// point's included; the verification run comes on top.
    pub max_iterations: usize,
}

impl Default for StrengthCalibrationOptions {
    fn default() -> Self {
        StrengthCalibrationOptions {
            lab: StrengthTestOptions::default(),
            tolerance: 0.01,
            max_iterations: 12,
        }
    }
}

/// What the calibration reports as it goes: one line per lab run.
#[derive(Clone, Copy, Debug)]
pub enum StrengthCalibrationProgress {
    /// A lab run ended.
    Run {
        /// Lab runs so far (this one included).
        run: usize,
        /// The target's name of this run (`tension`, `ucs`, `tension-along`, ...).
        target: &'static str,
        /// The strength scale of the run (of the parameter this target mainly sets).
        scale: f64,
        /// The run's peak stress (Pa).
        peak_pa: f64,
        /// The target (Pa).
        target_pa: f64,
        /// Whether the specimen failed (the stress dropped after its peak).
        failed: bool,
        /// Whether this is the verification run at the fitted values.
        verification: bool,
    },
}

/// One iteration: the scales tried and the peaks the lab measured with them.
#[derive(Clone, Debug, Serialize)]
pub struct StrengthIteration {
    /// The scale factors (one per parameter, in the order of `parameters`).
    pub scale: Vec<f64>,
    /// Measured peak stresses (Pa), one per target value.
    pub peak_pa: Vec<f64>,
    /// Whether each specimen failed before the largest strain.
    pub failed: Vec<bool>,
}

/// The result: the calibrated model, the fitted parameters and the verification run's
/// measured peaks (strength_calibration.json; Python's dict).
#[derive(Clone, Debug, Serialize)]
pub struct StrengthCalibration {
    /// Units of the keys.
    pub units: serde_json::Value,
    /// `tension`, `ucs` or `tension-along-across`.
    pub kind: &'static str,
    /// The target names, in the order of every per-target list.
    pub targets: Vec<&'static str>,
    /// The targets (Pa).
    pub target_pa: Vec<f64>,
    /// The bedding angle of each target's test (degrees; the lab turns the model by it).
    pub bedding_deg: Vec<f64>,
    /// The fitted parameters' names: `scale` (every bond strength) or `scale_along`,
    /// `scale_across`.
    pub parameters: Vec<&'static str>,
    /// The fitted scale factors of the input table's strengths.
    pub fitted_scale: Vec<f64>,
    /// The fitted `[strength]` table written into the calibrated model.
    pub fitted_strength: StrengthTable,
    /// Peaks (Pa) of the verification run of the calibrated model as written and read back.
    pub measured_peak_pa: Vec<f64>,
    /// measured / target − 1, per target.
    pub measured_relative_error: Vec<f64>,
    /// Relative tolerance on each peak.
    pub tolerance: f64,
    /// Iterations (each one lab run per target value).
    pub iterations: usize,
    /// Lab runs, the verification runs included.
    pub runs: usize,
    /// Every iteration.
    pub history: Vec<StrengthIteration>,
    /// The verification runs' lab reports.
    #[serde(skip)]
    pub verification: Vec<StrengthTestReport>,
    /// The calibrated model (the base with the fitted `[strength]` table).
    #[serde(skip)]
    pub model: Model,
}

impl StrengthCalibration {
    /// The report as pretty JSON; refuses a non-finite number.
    pub fn to_json(&self) -> Result<String> {
        crate::io::finite_json(self, "strength_calibration.json")
    }
}

/// Largest |Δ ln s| of one step (a factor 10).
const MAX_LOG_STEP: f64 = std::f64::consts::LN_10;

/// The values scaled by `s` (not the friction).
fn scale_values(v: &StrengthValues, s: f64) -> StrengthValues {
    StrengthValues {
        tensile: v.tensile * s,
        cohesion: v.cohesion * s,
        friction: v.friction,
        bending: v.bending.map(|b| b * s),
        twisting: v.twisting.map(|t| t * s),
    }
}

/// The table with `[strength.along]` scaled by `along` and `[strength.bond]` by `bond`.
fn scaled_table(t: &StrengthTable, bond: f64, along: f64) -> StrengthTable {
    StrengthTable {
        bond: scale_values(&t.bond, bond),
        along: t.along.as_ref().map(|a| scale_values(a, along)),
        ..t.clone()
    }
}

/// The table of the parameters `scale` (one: everything; two: along, across).
fn table_of(t: &StrengthTable, scale: &[f64]) -> StrengthTable {
    match *scale {
        [s] => scaled_table(t, s, s),
        [along, across] => scaled_table(t, across, along),
        _ => unreachable!("one or two parameters"),
    }
}

/// The lab's bedding angles β (degrees) that load along and across the cross-anisotropic
/// strength axis: the lab turns the model by β about y, so the axis (sin a, 0, cos a) lies
/// along z at β = −a and across it at β = 90° − a.
fn along_across_bedding(spec: &StrengthSpec) -> Result<(f64, f64)> {
    let StrengthScheme::CrossAnisotropic(c) = &spec.scheme else {
        return Err(Error::Model(
            "a tension-along/tension-across target needs a cross-anisotropic [strength] table \
             (with [strength.along] and its axis)"
                .into(),
        ));
    };
    if c.axis.y.abs() > 1e-9 {
        return Err(Error::Invalid(format!(
            "tension-along/tension-across: the [strength] axis [{:.6}, {:.6}, {:.6}] has a y \
             component; the lab turns the model about y, so the axis must lie in the x-z plane",
            c.axis.x, c.axis.y, c.axis.z
        )));
    }
    let a = c.axis.x.atan2(c.axis.z).to_degrees();
    Ok((-a, 90.0 - a))
}

/// The calibration's state: the lab runs and their count.
struct Lab<'a> {
    opts: &'a StrengthCalibrationOptions,
    base: &'a Model,
    table: &'a StrengthTable,
    /// One (test, bedding, target name, target value) per target value.
    tests: Vec<(TestKind, f64, &'static str, f64)>,
    runs: usize,
    progress: &'a (dyn Fn(StrengthCalibrationProgress) + Sync),
}

impl Lab<'_> {
    /// Run every test on `model`; each report with whether the specimen failed.
    fn run_all(
        &mut self,
        model: &Model,
        scale: &[f64],
        verification: bool,
    ) -> Result<Vec<StrengthTestReport>> {
        let mut out = Vec::new();
        for (k, &(test, bedding, name, target)) in self.tests.clone().iter().enumerate() {
            let lab = StrengthTestOptions {
                test,
                bedding_deg: bedding,
                model: Some(model.clone()),
                ..self.opts.lab.clone()
            };
            let report = run(&lab, &|_| {})?;
            self.runs += 1;
            (self.progress)(StrengthCalibrationProgress::Run {
                run: self.runs,
                target: name,
                scale: scale[k.min(scale.len() - 1)],
                peak_pa: report.peak_stress_pa,
                target_pa: target,
                failed: failed(&report),
                verification,
            });
            out.push(report);
        }
        Ok(out)
    }

    /// One iteration at `scale`: the residuals ln P − ln T and the record.
    fn evaluate(&mut self, scale: &[f64]) -> Result<(Vec<f64>, StrengthIteration)> {
        let model = Model {
            strength: Some(table_of(self.table, scale)),
            ..self.base.clone()
        };
        let reports = self.run_all(&model, scale, false)?;
        let peak: Vec<f64> = reports.iter().map(|r| r.peak_stress_pa).collect();
        let f = peak
            .iter()
            .zip(&self.tests)
            .map(|(p, t)| (p / t.3).ln())
            .collect();
        Ok((
            f,
            StrengthIteration {
                scale: scale.to_vec(),
                peak_pa: peak,
                failed: reports.iter().map(failed).collect(),
            },
        ))
    }
}

/// Whether the specimen failed: the stress dropped after its peak (below the lab's stop
/// fraction) before the largest strain, so the peak is a strength and not the stress the
/// largest strain happened to reach.
fn failed(r: &StrengthTestReport) -> bool {
    r.stop == "drop"
}

/// Calibrate the `[strength]` table of `base` (stiffness and bonding kept as they are) so
/// that the lab's peak on `opts.lab`'s packing reaches `target` (see the module doc).
/// Refuses a model without `[strength]`, a table whose scaled values are all zero, bad
/// options (by name), a target the specimen cannot reach before the lab's largest strain
/// (Invalid, naming it), and an iteration that does not meet the tolerance (NotConverged,
/// naming the last error).
pub fn calibrate_strength(
    base: &Model,
    target: &StrengthTarget,
    opts: &StrengthCalibrationOptions,
    names: OptionNames,
    progress: &(dyn Fn(StrengthCalibrationProgress) + Sync),
) -> Result<StrengthCalibration> {
    let n = |f: &str| names.name(f);
    let target = target.checked()?;
    crate::calibrate::check_iteration_options(opts.tolerance, opts.max_iterations).map_err(
        |_| {
            Error::Invalid(format!(
                "{} {} must be in (0, 0.1] and {} {} at least 1",
                n("tolerance"),
                opts.tolerance,
                n("max_iterations"),
                opts.max_iterations
            ))
        },
    )?;
    opts.lab.check(names)?;
    let table = base.strength.as_ref().ok_or_else(|| {
        Error::Model(
            "strength calibration needs a model with a [strength] table (its values are the \
             starting point and the ratios kept; docs/strength.md)"
                .into(),
        )
    })?;
    let spec = StrengthSpec::from_table(table)?;
    let scaled = |v: &StrengthValues| {
        v.tensile > 0.0
            || v.cohesion > 0.0
            || v.bending.is_some_and(|b| b > 0.0)
            || v.twisting.is_some_and(|t| t > 0.0)
    };
    let (kind, tests, parameters) = match target {
        StrengthTarget::Tension(t) => (
            "tension",
            vec![(TestKind::Tension, opts.lab.bedding_deg, "tension", t)],
            vec!["scale"],
        ),
        StrengthTarget::Ucs(u) => (
            "ucs",
            vec![(TestKind::Ucs, opts.lab.bedding_deg, "ucs", u)],
            vec!["scale"],
        ),
        StrengthTarget::TensionAlongAcross { along, across } => {
            let (b_along, b_across) = along_across_bedding(&spec)?;
            (
                "tension-along-across",
                vec![
                    (TestKind::Tension, b_along, "tension-along", along),
                    (TestKind::Tension, b_across, "tension-across", across),
                ],
                vec!["scale_along", "scale_across"],
            )
        }
    };
    let zero_bond = !scaled(&table.bond);
    let zero_along = table.along.as_ref().is_some_and(|a| !scaled(a));
    if (parameters.len() == 1 && zero_bond && table.along.as_ref().is_none_or(|a| !scaled(a)))
        || (parameters.len() == 2 && (zero_bond || zero_along))
    {
        return Err(Error::Model(
            "[strength]: the strengths to be scaled are all zero (no scale factor changes \
             them); give non-zero starting values"
                .into(),
        ));
    }
    let mut lab = Lab {
        opts,
        base,
        table,
        tests: tests.clone(),
        runs: 0,
        progress,
    };
    let dim = parameters.len();
    let mut x = vec![0.0; dim];
    let mut history = Vec::new();
    let mut jacobian = Matrix2::identity();
    // The last evaluation whose specimens all failed (for the Broyden update).
    let mut last: Option<(Vec<f64>, Vec<f64>)> = None;
    let converged = loop {
        if history.len() >= opts.max_iterations {
            break false;
        }
        let scale: Vec<f64> = x.iter().map(|v: &f64| v.exp()).collect();
        let (f, record) = lab.evaluate(&scale)?;
        let all_failed = record.failed.iter().all(|&b| b);
        let ok = all_failed && f.iter().all(|r| r.exp_m1().abs() <= opts.tolerance);
        let failed_now = record.failed.clone();
        let peaks = record.peak_pa.clone();
        history.push(record);
        if ok {
            break true;
        }
        if !all_failed {
            // A specimen that did not fail carried `peak` at the largest strain with no
            // drop: a target at or above it is not reached before that strain whatever the
            // strengths (breaking only lowers the stress); below it, the bonds are too
            // strong, so step below the linear estimate.
            let mut step = vec![0.0; dim];
            for (k, (&(_, _, name, t), &fk)) in tests.iter().zip(&failed_now).enumerate() {
                if fk {
                    continue;
                }
                if t >= peaks[k] {
                    return Err(Error::Invalid(format!(
                        "target {name} = {t:e} Pa is not reached: the specimen did not fail \
                         by {} {} and carried at most {:e} Pa there (the strengths do not \
                         raise that); raise {} or lower the target",
                        n("max_strain"),
                        opts.lab.max_strain,
                        peaks[k],
                        n("max_strain")
                    )));
                }
                step[k.min(dim - 1)] = -(peaks[k] / t).ln() - std::f64::consts::LN_2;
            }
            for (xi, si) in x.iter_mut().zip(&step) {
                *xi += si.clamp(-MAX_LOG_STEP, MAX_LOG_STEP);
            }
            continue;
        }
        if let Some((x0, f0)) = &last {
            let dx = Vector2::from_fn(|i, _| if i < dim { x[i] - x0[i] } else { 0.0 });
            let df = Vector2::from_fn(|i, _| if i < dim { f[i] - f0[i] } else { 0.0 });
            let norm2 = dx.norm_squared();
            if norm2 > 0.0 {
                jacobian += (df - jacobian * dx) * dx.transpose() / norm2;
            }
            if dim == 1 {
                jacobian[(1, 1)] = 1.0;
                jacobian[(0, 1)] = 0.0;
                jacobian[(1, 0)] = 0.0;
            }
        }
        // A Jacobian that says the peak falls with the strength, or is singular, is not
        // trusted: back to the linear (diagonal) estimate.
        let trusted = jacobian.determinant() > 1e-6
            && (0..dim).all(|i| jacobian[(i, i)] > 0.0)
            && jacobian.iter().all(|v| v.is_finite());
        if !trusted {
            jacobian = Matrix2::identity();
        }
        let fv = Vector2::from_fn(|i, _| if i < dim { f[i] } else { 0.0 });
        let step = jacobian.try_inverse().map(|inv| -(inv * fv)).unwrap_or(-fv);
        last = Some((x.clone(), f.clone()));
        for (i, xi) in x.iter_mut().enumerate() {
            *xi += step[i].clamp(-MAX_LOG_STEP, MAX_LOG_STEP);
        }
    };
    if !converged {
        let h = history.last().expect("at least one iteration");
        let errors: Vec<String> = tests
            .iter()
            .zip(h.peak_pa.iter().zip(&h.failed))
            .map(|(t, (p, fl))| {
                format!(
                    "{} peak {p:e} Pa vs target {:e} Pa ({:+.3} %{})",
                    t.2,
                    t.3,
                    100.0 * (p / t.3 - 1.0),
                    if *fl { "" } else { ", did not fail" }
                )
            })
            .collect();
        return Err(Error::NotConverged(format!(
            "strength calibration: not within {} {} after {} {} ({} lab runs); last: {}",
            n("tolerance"),
            opts.tolerance,
            history.len(),
            n("max_iterations"),
            lab.runs,
            errors.join("; ")
        )));
    }
    let fitted = history.last().expect("converged").scale.clone();
    // The verification run: the calibrated model written to text and read back.
    let model = Model {
        strength: Some(table_of(table, &fitted)),
        ..base.clone()
    };
    let name = Path::new("calibrated-strength.toml");
    let model = Model::from_str_for(&model.to_string_for(name), name)?;
    let verification = lab.run_all(&model, &fitted, true)?;
    let measured: Vec<f64> = verification.iter().map(|r| r.peak_stress_pa).collect();
    let errors: Vec<f64> = measured
        .iter()
        .zip(&tests)
        .map(|(p, t)| p / t.3 - 1.0)
        .collect();
    if let Some(k) =
        (0..tests.len()).find(|&k| !failed(&verification[k]) || errors[k].abs() > opts.tolerance)
    {
        return Err(Error::NotConverged(format!(
            "strength calibration: the verification run of the calibrated model gives {} \
             peak {:e} Pa vs target {:e} Pa ({:+.3} %), outside {} {}",
            tests[k].2,
            measured[k],
            tests[k].3,
            100.0 * errors[k],
            n("tolerance"),
            opts.tolerance
        )));
    }
    Ok(StrengthCalibration {
        units: serde_json::json!({
            "*_pa": "Pa", "bedding_deg": "degrees", "fitted_scale": "1",
            "measured_relative_error": "1", "tolerance": "1",
            "fitted_strength": "Pa (friction: tan φ)"
        }),
        kind,
        targets: tests.iter().map(|t| t.2).collect(),
        target_pa: tests.iter().map(|t| t.3).collect(),
        bedding_deg: tests.iter().map(|t| t.1).collect(),
        parameters,
        fitted_scale: fitted,
        fitted_strength: model.strength.clone().expect("the fitted table"),
        measured_peak_pa: measured,
        measured_relative_error: errors,
        tolerance: opts.tolerance,
        iterations: history.len(),
        runs: lab.runs,
        history,
        verification,
        model,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_with_units_and_refuse_by_name() {
        assert_eq!(
            StrengthTarget::parse("tension=2 MPa").unwrap(),
            StrengthTarget::Tension(2e6)
        );
        assert_eq!(
            StrengthTarget::parse("UCS = 50MPa").unwrap(),
            StrengthTarget::Ucs(5e7)
        );
        assert_eq!(
            StrengthTarget::parse("tension-along=1MPa, tension-across=3e6").unwrap(),
            StrengthTarget::TensionAlongAcross {
                along: 1e6,
                across: 3e6
            }
        );
        for (bad, word) in [
            ("tension=-1", "tension"),
            ("ucs=0", "ucs"),
            ("tension-along=1MPa", "tension-across"),
            ("tension=1,ucs=2", "exactly one"),
            ("shear=1", "shear"),
            ("tension=1,tension=2", "twice"),
        ] {
            let e = StrengthTarget::parse(bad).unwrap_err();
            assert!(matches!(e, Error::Invalid(_)), "{bad}: {e}");
            assert!(e.to_string().contains(word), "{bad}: {e}");
        }
    }

    #[test]
    fn along_and_across_bedding_turn_the_axis_onto_and_off_z() {
        let table: StrengthTable = toml::from_str(
            "axis = [0.5, 0.0, 0.8660254037844386]\n[bond]\ntensile = 1.0\ncohesion = 1.0\n\
             [along]\ntensile = 2.0\ncohesion = 2.0\n",
        )
        .unwrap();
        let spec = StrengthSpec::from_table(&table).unwrap();
        let (a, c) = along_across_bedding(&spec).unwrap();
        let StrengthScheme::CrossAnisotropic(s) = &spec.scheme else {
            unreachable!()
        };
        let q = crate::study::strength_test::bedding_rotation(a);
        assert!(((q * s.axis).z - 1.0).abs() < 1e-12);
        let q = crate::study::strength_test::bedding_rotation(c);
        assert!((q * s.axis).z.abs() < 1e-12);
    }
}
