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
//! - `manybody.rs`: targets the springs alone cannot reach (beyond the Cauchy line, a free
//!   fifth transversely isotropic constant): springs plus the many-body term (issue 33).
//! - `domain.rs`: sampling of the accessible domain (Truszkowska 2018 Eq. 16, Fig. 8, Fig. C.1a).

mod broyden;
pub(crate) mod cross;
pub(crate) mod cubic;
pub(crate) mod domain;
pub(crate) mod kernel;
pub mod manybody;
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
pub use manybody::{ManyBodyCalibration, Symmetry};
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
use crate::schemes::cross_anisotropic::dependent_c44;
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
    /// A target the springs alone cannot reach: springs plus the many-body term
    /// (docs/manybody.md "Calibration").
    ManyBody(Box<ManyBodyCalibration>),
}

/// A calibrated model and how it was obtained.
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The base model with the calibrated scheme parameters (geometry and bonding kept) and,
    /// only where the springs cannot reach the target, a `[manybody]` term.
    pub model: Model,
    /// The calibration's details.
    pub calibration: Calibration,
}

/// Calibrate `base` (its scheme kind, geometry and bonding) to `target` on the tensor `on`
/// says. Cubic targets use `opts` in full; cross-anisotropic ones its tolerance, iteration
/// limit and relaxed-solver options. The one entry point of the CLI and the Python package.
///
/// The springs alone are tried first (as without the term); only a target they cannot reach
/// gets the many-body term ([`manybody`]), so any target inside the stability conditions is
/// reached. A `[manybody]` table of `base` is not kept: the calibration decides the term.
pub fn calibrate(
    base: &Model,
    target: &Target,
    on: CalibrateOn<'_>,
    opts: &CubicOptions,
) -> Result<Calibrated> {
    // A polycrystal's tensor is not one scheme's: fitting the crystal's parameters to it is
    // not done yet (docs/polycrystal.md).
    base.refuse_grains("calibration (it fits one scheme's parameters)")?;
    let mut base = base.clone();
    base.manybody = None;
    let base = &base;
    match *target {
        Target::Cubic(t) => calibrate_cubic_target(base, &t, on, opts),
        Target::CrossAnisotropic {
            c11,
            c33,
            c13,
            c12,
            c44,
        } => {
            let goal = [c11, c33, c13, c12];
            if let CalibrateOn::Relaxed(b) = on {
                let cross = cross::CrossOptions {
                    tolerance: opts.tolerance,
                    max_iterations: opts.max_iterations,
                    relaxed: opts.relaxed,
                };
                check_iteration_options(opts.tolerance, opts.max_iterations)?;
                let pairwise = calibrate_cross_relaxed(&b.packing, &b.bonds, base, goal, &cross);
                let refusal = match (pairwise, c44) {
                    (Ok(cal), None) => {
                        return Ok(Calibrated {
                            model: cal.model(base),
                            calibration: Calibration::CrossRelaxed(Box::new(cal)),
                        })
                    }
                    (Ok(cal), Some(c44))
                        if (cal.achieved_transverse.c44 - c44).abs()
                            <= opts.tolerance * c44.abs() =>
                    {
                        return Ok(Calibrated {
                            model: cal.model(base),
                            calibration: Calibration::CrossRelaxed(Box::new(cal)),
                        })
                    }
                    (Ok(cal), Some(c44)) => format!(
                        "the springs reach (C11, C33, C13, C12) on the relaxed tensor, but their C44 is {:.5e} Pa, not the target's {c44:.5e} Pa (the elliptic scheme ties C44 to the others)",
                        cal.achieved_transverse.c44
                    ),
                    // Model: the elliptic scheme cannot hold the target's four constants
                    // (a negative lattice modulus); the other two: out of its reach.
                    (
                        Err(e @ (Error::NotConverged(_) | Error::Invalid(_) | Error::Model(_))),
                        _,
                    ) => e.to_string(),
                    (Err(e), _) => return Err(e),
                };
                let axis = cross_axis(base)?;
                let mu = lattice_scaling(&b.packing, &b.bonds, base.geometry.pi_hat)?;
                let five = [
                    c11,
                    c33,
                    c13,
                    c12,
                    c44.unwrap_or(dependent_c44(c11, c33, c13)),
                ];
                let cal = manybody::relaxed_split(
                    base,
                    manybody::Symmetry::TransverselyIsotropic { axis },
                    five.to_vec(),
                    manybody::Springs::Elliptic(manybody::elliptic_reach(&five, axis, mu)),
                    term_fraction(b)?,
                    refusal,
                    |m| relaxed_with_term(b, m, opts),
                    &solve_options(opts),
                )?;
                return Ok(many_body(base, cal));
            }
            let axis = cross_axis(base)?;
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
            let dependent = dependent_c44(c11, c33, c13);
            let refusal = match (target.scheme(mu), c44) {
                (Ok(_), None) => None,
                (Ok(_), Some(c44)) if (c44 - dependent).abs() <= 1e-12 * c11.abs().max(c33.abs()) => None,
                (Ok(_), Some(c44)) => Some(format!(
                    "the elliptic scheme's C44 is dependent, (C11 + C33)/4 − C13/2 = {dependent:.5e} Pa (Šmilauer Eq. 12), not the target's {c44:.5e} Pa"
                )),
                (Err(e), None) => {
                    return Err(Error::Invalid(format!(
                        "target C11={c11:e},C33={c33:e},C13={c13:e},C12={c12:e} Pa: {e}"
                    )))
                }
                (Err(e), Some(_)) => Some(format!(
                    "the elliptic scheme cannot reproduce (C11, C33, C13, C12): {e}"
                )),
            };
            let Some(refusal) = refusal else {
                let mut model = base.clone();
                model.scheme = SchemeSpec::CrossAnisotropic(target);
                return Ok(Calibrated {
                    model,
                    calibration: Calibration::CrossMeanField,
                });
            };
            let phi = match on {
                CalibrateOn::MeanFieldOf(b) => term_fraction(b)?,
                _ => 1.0,
            };
            let five = [c11, c33, c13, c12, c44.unwrap_or(dependent)];
            let cal = manybody::transverse_voigt(base, five, axis, mu, phi, refusal)?;
            Ok(many_body(base, cal))
        }
    }
}

/// The calibrated model and details of a split into springs and term.
fn many_body(base: &Model, cal: ManyBodyCalibration) -> Calibrated {
    Calibrated {
        model: cal.model(base),
        calibration: Calibration::ManyBody(Box::new(cal)),
    }
}

/// The symmetry axis of a cross-anisotropic base model (refused for other kinds).
fn cross_axis(base: &Model) -> Result<crate::Vec3> {
    match base.scheme {
        SchemeSpec::CrossAnisotropic(CrossTarget { axis, .. }) => Ok(axis),
        _ => Err(Error::Invalid(
            "a C11, C33, C13, C12 target needs a model file with [scheme] kind = \"cross-anisotropic\"".into(),
        )),
    }
}

/// φ = Σ V_p / V of the particles of `b` that carry the term (rattlers excluded, as a
/// model file's `[manybody]` does by default): the term adds φ·D at the Voigt level.
fn term_fraction(b: &Assembly) -> Result<f64> {
    let unit = crate::manybody::LocalTensor::Isotropic {
        bulk: 1.0,
        shear: 1.0,
    };
    let opts = crate::manybody::ManyBodyOptions {
        degenerate: crate::manybody::DegenerateParticles::Exclude,
        ..Default::default()
    };
    let fraction =
        crate::manybody::ManyBody::new(&b.packing, &b.bonds, &unit, &opts)?.volume_fraction();
    if fraction <= 0.0 || fraction.is_nan() {
        return Err(Error::Degenerate(
            "many-body calibration: no particle of the packing has three non-coplanar bonds, so the term cannot act".into(),
        ));
    }
    Ok(fraction)
}

/// The relaxed options of the D iteration from the calibration's.
fn solve_options(opts: &CubicOptions) -> manybody::SolveOptions {
    manybody::SolveOptions {
        tolerance: opts.tolerance,
        max_evaluations: opts.max_iterations,
    }
}

/// The relaxed tensor (lab frame) of `model`'s springs and `[manybody]` term on the bonds
/// of `b`.
fn relaxed_with_term(
    b: &Assembly,
    model: &Model,
    opts: &CubicOptions,
) -> Result<crate::tensor::Stiffness6> {
    let mu = match model.scheme {
        SchemeSpec::CrossAnisotropic(_) => Some(lattice_scaling(
            &b.packing,
            &b.bonds,
            model.geometry.pi_hat,
        )?),
        _ => None,
    };
    let scheme = model.scheme_for(mu)?;
    let k = crate::bonds::assign_stiffness(&b.packing, &b.bonds, scheme.as_ref(), &model.geometry)?;
    let term = match &model.manybody {
        Some(spec) => Some(spec.build(&b.packing, &b.bonds)?),
        None => None,
    };
    Ok(crate::homogenize::relaxed_tensor_with_term(
        &b.packing,
        &b.bonds,
        &k,
        term.as_ref(),
        &opts.relaxed,
    )?
    .c)
}

/// The cubic branch of [`calibrate`]: the springs alone (as [`calibrate_cubic`]) where they
/// reach the target, else springs plus the many-body term.
fn calibrate_cubic_target(
    base: &Model,
    t: &CubicTarget,
    on: CalibrateOn<'_>,
    opts: &CubicOptions,
) -> Result<Calibrated> {
    let (opts, default_normal) = cubic_settings(base, opts)?;
    let pairwise = |on| -> Result<Calibrated> {
        let cal = calibrate_cubic(base, t, on, &opts)?;
        Ok(Calibrated {
            model: cal.model(base),
            calibration: Calibration::Cubic(Box::new(cal)),
        })
    };
    let prefactor = match on {
        CalibrateOn::Relaxed(b) | CalibrateOn::MeanFieldOf(b) => {
            cubic::packing_prefactor(&b.packing, &b.bonds, &base.geometry)
        }
        CalibrateOn::MeanField(spheres) => spheres.prefactor(&base.geometry)?,
    };
    match on {
        CalibrateOn::Relaxed(b) => {
            check_iteration_options(opts.tolerance, opts.max_iterations)?;
            let refusal = match pairwise(on) {
                Ok(c) => return Ok(c),
                Err(e @ (Error::NotConverged(_) | Error::Invalid(_))) => e.to_string(),
                Err(e) => return Err(e),
            };
            let reach = manybody::CubicReach::new(t, prefactor, default_normal, &opts)?;
            let target = {
                // A ratio target takes its C11 from the springs' relaxed tensor at the
                // model's normal magnitude.
                let (c11, c12, c44) = match t.c11 {
                    Some(_) => t.constants(0.0),
                    None => {
                        let mut m = base.clone();
                        m.scheme = reach.scheme_at(1.0, cubic::base_rotation(base));
                        let c = relaxed_with_term(b, &m, &opts)?;
                        let sym = manybody::Symmetry::Cubic {
                            rotation: cubic::base_rotation(base),
                        };
                        t.constants(sym.constants(&c)?[0])
                    }
                };
                vec![c11, c12, c44]
            };
            let cal = manybody::relaxed_split(
                base,
                manybody::Symmetry::Cubic {
                    rotation: cubic::base_rotation(base),
                },
                target,
                manybody::Springs::Cubic(&reach),
                term_fraction(b)?,
                refusal,
                |m| relaxed_with_term(b, m, &opts),
                &solve_options(&opts),
            )?;
            Ok(many_body(base, cal))
        }
        CalibrateOn::MeanFieldOf(_) | CalibrateOn::MeanField(_) => {
            let Err(refusal) = manybody::mean_field_reaches(t, default_normal, &opts)? else {
                return pairwise(on);
            };
            let phi = match on {
                CalibrateOn::MeanFieldOf(b) => term_fraction(b)?,
                _ => 1.0,
            };
            let reach = manybody::CubicReach::new(t, prefactor, default_normal, &opts)?;
            let cal = manybody::cubic_mean_field(base, t, prefactor, &reach, phi, refusal)?;
            Ok(many_body(base, cal))
        }
    }
}

/// The cubic options with the model file's extended flag, and the normal magnitude of a
/// ratio target (the model file's, or 1e13); a cross-anisotropic base is refused.
fn cubic_settings(base: &Model, opts: &CubicOptions) -> Result<(CubicOptions, f64)> {
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
    Ok((opts, if normal > 0.0 { normal } else { 1e13 }))
}

/// The cubic branch of [`calibrate`] with the springs alone: the model file's extended flag
/// and normal magnitude (or 1e13) are the defaults of the options and of an absolute
/// target's scale.
fn calibrate_cubic(
    base: &Model,
    t: &CubicTarget,
    on: CalibrateOn<'_>,
    opts: &CubicOptions,
) -> Result<CubicCalibration> {
    let (opts, default_normal) = cubic_settings(base, opts)?;
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
