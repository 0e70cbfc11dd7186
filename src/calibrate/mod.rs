//! Calibration: the scheme parameters that reproduce a target stiffness tensor.
//!
//! - `target.rs`: the `--target` text (`C11=…,C12=…,C44=…`, `C12/C11=0.30,C44/C11=0.43`, or
//!   the cross-anisotropic `C11=…,C33=…,C13=…,C12=…`).
//! - `broyden` (private): the damped Broyden iteration both relaxed calibrations use (Broyden 1965).
//! - `kernel.rs`: the mean-field cubic constants of the spheroid scheme as fast 1-D orientation
//!   integrals (Truszkowska 2018 App. A, reduced by the cubic symmetry).
//! - `cubic.rs`: cubic calibration, at the mean-field level and on a packing with the relaxed
//!   solver; the parameter set nearest a_n = a_s = 1 (Truszkowska 2018 Sec. 6.3).
//! - `cross.rs`: cross-anisotropic calibration on a packing: the target written into the model
//!   is corrected until the *relaxed* tensor matches (Šmilauer's Voigt inversion is soft).
//! - `warm.rs`: the relaxed solver with a warm start, reused across calibration iterations.
//! - `strength.rs`: the `[strength]` table's scale(s) that make the virtual laboratory reach a
//!   target tensile strength (one or two directions) or UCS on the packing (issue 32 item 6).
//! - `domain.rs`: sampling of the accessible domain (Truszkowska 2018 Eq. 16, Fig. 8, Fig. C.1a).

mod broyden;
pub(crate) mod cross;
pub(crate) mod cubic;
pub(crate) mod domain;
pub(crate) mod kernel;
pub mod strength;
pub(crate) mod target;
pub(crate) mod warm;

pub use cross::CrossOptions;
pub use cross::{calibrate_cross_relaxed, CrossCalibration};
pub use cubic::IterationRecord;
pub use cubic::Level;
pub use cubic::{
    calibrate_cubic_mean_field, calibrate_cubic_relaxed, CubicCalibration, CubicOptions,
    CubicParameters, Family,
};
pub use domain::{log_normalised, sample_mean_field, DomainOptions, DomainSample};
pub use kernel::Cubic3;
pub use kernel::CubicKernel;
pub use strength::{
    calibrate_strength, StrengthCalibration, StrengthCalibrationOptions,
    StrengthCalibrationProgress, StrengthTarget,
};
pub use target::{CubicTarget, Target};

/// Refuse iteration settings of a relaxed calibration that would make "calibrated" meaningless:
/// the relative tolerance on the calibrated constants must be in (0, 0.1] (an infinite one
/// accepts the starting point), and at least one relaxed solve must be allowed.
pub fn check_iteration_options(tolerance: f64, max_iterations: usize) -> crate::Result<()> {
    if !(tolerance > 0.0 && tolerance <= 0.1) {
        return Err(crate::Error::Invalid(format!(
            "calibration --tolerance must be in (0, 0.1] (relative error of the calibrated \
             constants), got {tolerance}"
        )));
    }
    if max_iterations == 0 {
        return Err(crate::Error::Invalid(
            "calibration --max-iterations must be at least 1".into(),
        ));
    }
    Ok(())
}

use crate::assembly::{Assembly, EqualSpheres};
use crate::bonds::lattice_scaling;
use crate::model::{CrossTarget, Model, SchemeSpec};
use crate::schemes::cubic::CubicModel;
use crate::{Error, Result};

/// Which tensor a calibration matches the target with.
#[derive(Clone, Copy, Debug)]
pub enum CalibrateOn<'a> {
    /// The mean-field tensor at the bond density of equal spheres (no packing needed).
    MeanField(EqualSpheres),
    /// The mean-field tensor at this assembly's bond density (and, cross-anisotropic, its μ).
    MeanFieldOf(&'a Assembly),
    /// The exact relaxed tensor of this assembly (Broyden iteration on relaxed solves).
    Relaxed(&'a Assembly),
}

/// What a calibration found besides the model.
#[derive(Clone, Debug)]
pub enum Calibration {
    /// A cubic target: the spheroid parameters, the achieved constants and the iterations.
    Cubic(Box<CubicCalibration>),
    /// A cross-anisotropic target on a packing's relaxed tensor.
    CrossRelaxed(Box<CrossCalibration>),
    /// A cross-anisotropic target at the mean-field level: Šmilauer's inversion E′ = A⁻¹C/μ is
    /// exact under uniform strain, so the model holds the target itself.
    CrossMeanField,
}

/// A calibrated model and how it was obtained.
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The base model with the calibrated scheme parameters (geometry and bonding kept).
    pub model: Model,
    /// The calibration's details.
    pub calibration: Calibration,
}

/// Calibrate `base` (its scheme kind, geometry and bonding) to `target` on the tensor `on`
/// says. Cubic targets use `opts` in full; cross-anisotropic ones its tolerance, iteration
/// limit and relaxed-solver options. The one entry point of the CLI and the Python package.
pub fn calibrate(
    base: &Model,
    target: &Target,
    on: CalibrateOn<'_>,
    opts: &CubicOptions,
) -> Result<Calibrated> {
    match *target {
        Target::Cubic(t) => {
            let cal = calibrate_cubic(base, &t, on, opts)?;
            Ok(Calibrated {
                model: cal.model(base),
                calibration: Calibration::Cubic(Box::new(cal)),
            })
        }
        Target::CrossAnisotropic { c11, c33, c13, c12 } => {
            let goal = [c11, c33, c13, c12];
            if let CalibrateOn::Relaxed(b) = on {
                let cross = cross::CrossOptions {
                    tolerance: opts.tolerance,
                    max_iterations: opts.max_iterations,
                    relaxed: opts.relaxed,
                };
                let cal = calibrate_cross_relaxed(&b.packing, &b.bonds, base, goal, &cross)?;
                return Ok(Calibrated {
                    model: cal.model(base),
                    calibration: Calibration::CrossRelaxed(Box::new(cal)),
                });
            }
            let SchemeSpec::CrossAnisotropic(CrossTarget { axis, .. }) = base.scheme else {
                return Err(Error::Invalid(
                    "a C11, C33, C13, C12 target needs a model file with [scheme] kind = \"cross-anisotropic\"".into(),
                ));
            };
            // The scheme must be able to reproduce the target before "calibrated" is said:
            // without a packing μ = 1 serves, since the signs of the lattice moduli
            // E′ = A⁻¹C/μ do not depend on μ > 0.
            let mu = match on {
                CalibrateOn::MeanFieldOf(b) => {
                    lattice_scaling(&b.packing, &b.bonds, base.geometry.pi_hat)?
                }
                _ => 1.0,
            };
            let target = CrossTarget {
                c11,
                c33,
                c13,
                c12,
                axis,
            };
            target.scheme(mu).map_err(|e| {
                Error::Invalid(format!(
                    "target C11={c11:e},C33={c33:e},C13={c13:e},C12={c12:e} Pa: {e}"
                ))
            })?;
            let mut model = base.clone();
            model.scheme = SchemeSpec::CrossAnisotropic(target);
            Ok(Calibrated {
                model,
                calibration: Calibration::CrossMeanField,
            })
        }
    }
}

/// The cubic branch of [`calibrate`]: the model file's extended flag and normal magnitude
/// (or 1e13) are the defaults of the options and of an absolute target's scale.
fn calibrate_cubic(
    base: &Model,
    t: &CubicTarget,
    on: CalibrateOn<'_>,
    opts: &CubicOptions,
) -> Result<CubicCalibration> {
    let (base_extended, normal) = match &base.scheme {
        SchemeSpec::Cubic(c) => (c.extended, c.normal),
        SchemeSpec::Isotropic { normal, .. } => (false, *normal),
        SchemeSpec::CrossAnisotropic(_) => return Err(Error::Invalid(
            "a cubic target needs a cubic (or isotropic) model file; this one is cross-anisotropic"
                .into(),
        )),
    };
    let opts = CubicOptions {
        extended: opts.extended || base_extended,
        ..*opts
    };
    let default_normal = if normal > 0.0 { normal } else { 1e13 };
    match on {
        CalibrateOn::Relaxed(b) => {
            calibrate_cubic_relaxed(&b.packing, &b.bonds, base, t, default_normal, &opts)
        }
        CalibrateOn::MeanFieldOf(b) => {
            let prefactor = cubic::packing_prefactor(&b.packing, &b.bonds, &base.geometry);
            calibrate_cubic_mean_field(t, prefactor, default_normal, &opts)
        }
        CalibrateOn::MeanField(spheres) => {
            let prefactor = spheres.prefactor(&base.geometry)?;
            calibrate_cubic_mean_field(t, prefactor, default_normal, &opts)
        }
    }
}

/// The cubic model a forced choice names (`None`: by the target's Zener ratio).
pub fn forced_cubic_model(name: &str) -> Result<Option<CubicModel>> {
    match name {
        "auto" => Ok(None),
        "zener-above-1" => Ok(Some(CubicModel::ZenerAbove1)),
        "zener-below-1" => Ok(Some(CubicModel::ZenerBelow1)),
        other => Err(Error::Invalid(format!(
            "cubic model `{other}`: expected auto, zener-above-1 or zener-below-1"
        ))),
    }
}
