//! Cross-anisotropic calibration on a packing: the transversely isotropic constants
//! (C11, C33, C13, C12) written into the model are corrected until the *relaxed* tensor of
//! the packing has the target's.
//!
//! Šmilauer's scheme inverts the microplane (Voigt) formula, E′ = A⁻¹C/μ (Šmilauer
//! Eq. 22), so a model file holding the target gives a Voigt tensor within a
//! fraction of a percent of it but a relaxed tensor 3–6 % softer (docs/references.md). Here the
//! constants W written into the model are the unknowns: relaxed(W) = target is solved by
//! Broyden's method from W₀ = target with the identity as the initial Jacobian (the map is
//! close to a uniform softening), one warm-started relaxed solve per iteration.

use super::warm::WarmRelaxed;
use crate::bonds::{assign_stiffness, BondSet};
use crate::homogenize::relaxed::RelaxedOptions;
use crate::model::{Model, SchemeSpec};
use crate::packing::Packing;
use crate::schemes::cross_anisotropic::{lattice_scaling, CrossAnisotropic};
use crate::tensor::{Stiffness6, TransverseProjection};
use crate::{Error, Result, Vec3};
use nalgebra::{Matrix4, Vector4};

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
        m.scheme = SchemeSpec::CrossAnisotropic {
            c11: self.written[0],
            c33: self.written[1],
            c13: self.written[2],
            c12: self.written[3],
            axis: self.axis,
        };
        m
    }
}

fn constants(p: &TransverseProjection) -> Vector4<f64> {
    Vector4::new(p.c11, p.c33, p.c13, p.c12)
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
    let SchemeSpec::CrossAnisotropic { axis, .. } = base.scheme else {
        return Err(Error::Invalid(
            "a C11, C33, C13, C12 target needs a model file with [scheme] kind = \"cross-anisotropic\" (it gives the axis and geometry)".into(),
        ));
    };
    let mu = lattice_scaling(packing, bonds, base.geometry.pi_hat)?;
    let goal = Vector4::from(target);
    let scale = goal.amax().max(f64::MIN_POSITIVE);
    let mut solver = WarmRelaxed::new(packing, bonds, opts.relaxed);
    let mut history = Vec::new();
    let mut evaluate = |w: &Vector4<f64>,
                        history: &mut Vec<([f64; 4], usize)>|
     -> Result<(Stiffness6, TransverseProjection, [f64; 4])> {
        let scheme = CrossAnisotropic::from_target(w[0], w[1], w[2], w[3], axis, mu)?;
        let k = assign_stiffness(packing, bonds, &scheme, &base.geometry)?;
        let sol = solver.solve(&k)?;
        let (proj, _) = TransverseProjection::about_axis(&sol.c, &axis)?;
        history.push(([proj.c11, proj.c33, proj.c13, proj.c12], sol.iterations));
        Ok((sol.c, proj, scheme.e_prime))
    };
    let mut w = goal;
    let (mut c, mut proj, mut e_prime) = evaluate(&w, &mut history)?;
    let plain_inversion = [proj.c11, proj.c33, proj.c13, proj.c12];
    let mut f = constants(&proj) - goal;
    // Initial Jacobian: the component-wise softening of the first solve (relaxed/written),
    // refined by Broyden's rank-one updates.
    let mut jac = Matrix4::<f64>::from_diagonal(&Vector4::from_fn(|i, _| {
        let r = constants(&proj)[i] / w[i];
        if r.is_finite() {
            r.clamp(0.2, 5.0)
        } else {
            1.0
        }
    }));
    while f.amax() / scale > opts.tolerance {
        if history.len() >= opts.max_iterations {
            return Err(Error::Invalid(format!(
                "cross-anisotropic calibration: no convergence in {} relaxed solves; relaxed (C11, C33, C13, C12) = ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa vs target ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa",
                history.len(), proj.c11, proj.c33, proj.c13, proj.c12, target[0], target[1], target[2], target[3]
            )));
        }
        let mut step = jac
            .try_inverse()
            .map(|inv| -(inv * f))
            .unwrap_or_else(|| -f);
        // Shorten steps that would need a negative lattice modulus (Error::Model).
        let mut attempt = 0;
        let (w_new, c_new, proj_new, e_new) = loop {
            let w_try = w + step;
            match evaluate(&w_try, &mut history) {
                Ok((c, p, e)) => break (w_try, c, p, e),
                Err(Error::Model(m)) if attempt < 8 => {
                    attempt += 1;
                    step *= 0.5;
                    let _ = m;
                }
                Err(e) => {
                    return Err(Error::Invalid(format!(
                        "cross-anisotropic calibration: the corrected constants ({:.4e}, {:.4e}, {:.4e}, {:.4e}) Pa are not admissible: {e}; the target is out of reach of the elliptic scheme on this packing",
                        w_try[0], w_try[1], w_try[2], w_try[3]
                    )))
                }
            }
        };
        let f_new = constants(&proj_new) - goal;
        let dw = w_new - w;
        let denominator = dw.norm_squared();
        if denominator > 0.0 {
            jac += (f_new - f - jac * dw) * dw.transpose() / denominator;
        }
        (w, c, proj, e_prime, f) = (w_new, c_new, proj_new, e_new, f_new);
    }
    Ok(CrossCalibration {
        target,
        written: [w[0], w[1], w[2], w[3]],
        e_prime,
        mu,
        axis,
        achieved: c,
        achieved_transverse: proj,
        plain_inversion,
        history,
    })
}
