//! Cross-anisotropic calibration on a packing: the transversely isotropic constants
//! (C11, C33, C13, C12) written into the model are corrected until the *relaxed* tensor of
//! the packing has the target's.
//!
//! Šmilauer's scheme inverts the microplane (Voigt) formula, E′ = A⁻¹C/μ (Šmilauer
//! Eq. 22), so a model file holding the target gives a Voigt tensor within a
//! fraction of a percent of it but a relaxed tensor 3–6 % softer (docs/references.md). Here the
//! constants W written into the model are the unknowns: relaxed(W) = target is solved by
//! Broyden's method (`calibrate/broyden.rs`; Broyden 1965) from W₀ = target with the
//! component-wise softening of the first solve as the initial Jacobian (the map is close to
//! a uniform softening), one warm-started relaxed solve per iteration; W that needs a
//! negative lattice modulus is outside the admissible domain and shortens the step.

use super::broyden::{self, BroydenOptions, End, Evaluation, Point};
use super::warm::WarmRelaxed;
use crate::bonds::{lattice_scaling, BondSet};
use crate::homogenize::relaxed::RelaxedOptions;
use crate::model::{CrossTarget, Model, SchemeSpec};
use crate::packing::Packing;
use crate::schemes::cross_anisotropic::{target_lattice_moduli, CrossAnisotropic};
use crate::tensor::{Stiffness6, TransverseProjection};
use crate::{Error, Result, Vec3};
use nalgebra::{DMatrix, DVector};

/// Options of the cross-anisotropic calibration.
#[derive(Clone, Copy, Debug)]
pub struct CrossOptions {
    /// Stop when every constant is within this relative error (relative to the largest
    /// target constant).
    pub tolerance: f64,
    /// Relaxed solves allowed.
    pub max_iterations: usize,
    /// Relaxed solver options.
    pub relaxed: RelaxedOptions,
}

impl Default for CrossOptions {
    fn default() -> Self {
        CrossOptions {
            tolerance: 5e-4,
            max_iterations: 20,
            relaxed: RelaxedOptions::default(),
        }
    }
}

/// Result of a cross-anisotropic calibration.
#[derive(Clone, Debug)]
pub struct CrossCalibration {
    /// Target (C11, C33, C13, C12) in Pa.
    pub target: [f64; 4],
    /// Constants written into the calibrated model (Pa): the Voigt-level target whose
    /// relaxed tensor is the target.
    pub written: [f64; 4],
    /// Lattice moduli (E_N^a′, E_N^b′, E_T^a′, E_T^b′) of the calibrated scheme (Pa).
    pub e_prime: [f64; 4],
    /// Lattice scaling μ of the packing.
    pub mu: f64,
    /// Symmetry axis.
    pub axis: Vec3,
    /// Achieved relaxed tensor, lab frame (Pa).
    pub achieved: Stiffness6,
    /// Its transversely isotropic projection about the axis.
    pub achieved_transverse: TransverseProjection,
    /// Relaxed (C11, C33, C13, C12) of Šmilauer's plain inversion (the first iterate).
    pub plain_inversion: [f64; 4],
    /// Relaxed (C11, C33, C13, C12) and CG iterations of every solve.
    pub history: Vec<([f64; 4], usize)>,
}

impl CrossCalibration {
    /// The base model with the corrected constants.
    pub fn model(&self, base: &Model) -> Model {
        let mut m = base.clone();
        m.scheme = SchemeSpec::CrossAnisotropic(CrossTarget {
            c11: self.written[0],
            c33: self.written[1],
            c13: self.written[2],
            c12: self.written[3],
            axis: self.axis,
        });
        m
    }
}

fn constants(p: &TransverseProjection) -> DVector<f64> {
    DVector::from_vec(vec![p.c11, p.c33, p.c13, p.c12])
}

/// Calibrate a cross-anisotropic `base` model (its axis and geometry are kept) so that the
/// relaxed tensor of `packing` (bonded as `bonds`) has the target (C11, C33, C13, C12).
pub fn calibrate_cross_relaxed(
    packing: &Packing,
    bonds: &BondSet,
    base: &Model,
    target: [f64; 4],
    opts: &CrossOptions,
) -> Result<CrossCalibration> {
    super::check_iteration_options(opts.tolerance, opts.max_iterations)?;
    let SchemeSpec::CrossAnisotropic(CrossTarget { axis, .. }) = base.scheme else {
        return Err(Error::Invalid(
            "a C11, C33, C13, C12 target needs a model file with [scheme] kind = \"cross-anisotropic\" (it gives the axis and geometry)".into(),
        ));
    };
    let mu = lattice_scaling(packing, bonds, base.geometry.pi_hat)?;
    let goal = DVector::from_column_slice(&target);
    let scale = goal.amax().max(f64::MIN_POSITIVE);
    let mut eval = CrossEvaluator {
        base,
        axis,
        mu,
        solver: WarmRelaxed::new(packing, bonds, opts.relaxed),
        history: Vec::new(),
    };
    let w0 = DVector::from_column_slice(&target);
    let first = eval.evaluate(&w0)?.map_err(Error::Model)?;
    let proj = &first.1;
    let plain_inversion = [proj.c11, proj.c33, proj.c13, proj.c12];
    let jac = softening_jacobian(proj, &w0);
    let start = Point {
        f: constants(proj) - &goal,
        x: w0,
        data: first,
    };
    let broyden_opts = BroydenOptions {
        tolerance: opts.tolerance,
        scale: DVector::from_element(4, scale),
        max_evaluations: opts.max_iterations,
        max_step: f64::INFINITY,
        max_trials: 9,
    };
    let result = broyden::solve(
        start,
        jac.clone(),
        |w| match eval.evaluate(w) {
            Ok(Ok(solved)) => Ok(Evaluation::Admissible(constants(&solved.1) - &goal, solved)),
            Ok(Err(_)) => Ok(Evaluation::Inadmissible),
            Err(e) => Err(out_of_reach(w, &e)),
        },
        |_| {},
        |_| jac.clone(),
        &broyden_opts,
    )?;
    if let Some(e) = not_reached(&result, &result.point.data.1, &target, mu) {
        return Err(e);
    }
    let w = &result.point.x;
    let (c, proj, e_prime) = result.point.data;
    Ok(CrossCalibration {
        target,
        written: [w[0], w[1], w[2], w[3]],
        e_prime,
        mu,
        axis,
        achieved: c,
        achieved_transverse: proj,
        plain_inversion,
        history: eval.history,
    })
}

/// A relaxed solve: tensor, transverse projection and lattice moduli E′.
type Solved = (Stiffness6, TransverseProjection, [f64; 4]);

/// Relaxed solves of the packing with constants W written into the model (warm-started),
/// each recorded in the calibration's history.
struct CrossEvaluator<'a> {
    /// The model whose geometry the springs follow.
    base: &'a Model,
    /// The symmetry axis.
    axis: Vec3,
    /// Lattice scaling μ of the packing (Šmilauer Eq. 22).
    mu: f64,
    /// The warm-started relaxed solver.
    solver: WarmRelaxed<'a>,
    /// Relaxed (C11, C33, C13, C12) and CG iterations of every solve.
    history: Vec<([f64; 4], usize)>,
}

impl CrossEvaluator<'_> {
    /// One relaxed solve with the constants w written into the model; Err(why) when the
    /// elliptic scheme cannot reproduce w (the admissible domain, no solve made).
    fn evaluate(&mut self, w: &DVector<f64>) -> Result<std::result::Result<Solved, String>> {
        let e = match target_lattice_moduli(w[0], w[1], w[2], w[3], self.mu) {
            Ok(e) => e,
            Err(why) => return Ok(Err(why)),
        };
        let scheme = CrossAnisotropic::from_moduli(e, self.axis)?;
        let sol = self.solver.solve_scheme(&scheme, &self.base.geometry)?;
        let (proj, _) = TransverseProjection::about_axis(&sol.c, &self.axis)?;
        self.history
            .push(([proj.c11, proj.c33, proj.c13, proj.c12], sol.iterations));
        Ok(Ok((sol.c, proj, scheme.e_prime)))
    }
}

/// Initial Jacobian: the component-wise softening of the first solve (relaxed/written,
/// clamped to [0.2, 5]), refined by Broyden's rank-one updates.
fn softening_jacobian(proj: &TransverseProjection, w0: &DVector<f64>) -> DMatrix<f64> {
    DMatrix::<f64>::from_diagonal(&DVector::from_fn(4, |i, _| {
        let r = constants(proj)[i] / w0[i];
        if r.is_finite() {
            r.clamp(0.2, 5.0)
        } else {
            1.0
        }
    }))
}

/// The error of corrected constants `w` the elliptic scheme cannot reproduce.
fn out_of_reach(w: &DVector<f64>, e: &dyn std::fmt::Display) -> Error {
    Error::Invalid(format!(
        "cross-anisotropic calibration: the corrected constants ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa are not admissible: {e}; the target is out of reach of the elliptic scheme on this packing",
        w[0], w[1], w[2], w[3]
    ))
}

/// The error of an iteration that did not converge (out of solves, or every trial
/// inadmissible); `None` when it converged. `proj` is the last accepted point's projection.
fn not_reached<T>(
    result: &broyden::BroydenResult<T>,
    proj: &TransverseProjection,
    target: &[f64; 4],
    mu: f64,
) -> Option<Error> {
    match &result.end {
        End::Converged => None,
        End::Budget => Some(Error::NotConverged(format!(
            "cross-anisotropic calibration: no convergence in {} relaxed solves; relaxed (C11, C33, C13, C12) = ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa vs target ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa",
            result.evaluations, proj.c11, proj.c33, proj.c13, proj.c12, target[0], target[1], target[2], target[3]
        ))),
        End::Pinned => Some(Error::NotConverged(format!(
            "cross-anisotropic calibration: after {} relaxed solves the step toward the target leaves the scheme's parameter box; relaxed (C11, C33, C13, C12) = ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa vs target ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa",
            result.evaluations, proj.c11, proj.c33, proj.c13, proj.c12, target[0], target[1], target[2], target[3]
        ))),
        End::Inadmissible(w_try) => {
            let why = target_lattice_moduli(w_try[0], w_try[1], w_try[2], w_try[3], mu)
                .err()
                .unwrap_or_default();
            Some(out_of_reach(w_try, &why))
        }
    }
}
