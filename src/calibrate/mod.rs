//! Calibration: the scheme parameters that reproduce a target stiffness tensor.
//!
//! - [`target`]: the `--target` text (`C11=…,C12=…,C44=…`, `C12/C11=0.30,C44/C11=0.43`, or
//!   the cross-anisotropic `C11=…,C33=…,C13=…,C12=…`).
//! - `broyden` (private): the damped Broyden iteration both relaxed calibrations use (Broyden 1965).
//! - [`kernel`]: the mean-field cubic constants of the spheroid scheme as fast 1-D orientation
//!   integrals (Truszkowska 2018 App. A, reduced by the cubic symmetry).
//! - [`cubic`]: cubic calibration, at the mean-field level and on a packing with the relaxed
//!   solver; the parameter set nearest a_n = a_s = 1 (Truszkowska 2018 Sec. 6.3).
//! - [`cross`]: cross-anisotropic calibration on a packing: the target written into the model
//!   is corrected until the *relaxed* tensor matches (Šmilauer's Voigt inversion is soft).
//! - [`warm`]: the relaxed solver with a warm start, reused across calibration iterations.
//! - [`domain`]: sampling of the accessible domain (Truszkowska 2018 Eq. 16, Fig. 8, Fig. C.1a).

mod broyden;
pub mod cross;
pub mod cubic;
pub mod domain;
pub mod kernel;
pub mod target;
pub mod warm;

pub use cross::{calibrate_cross_relaxed, CrossCalibration};
pub use cubic::{
    calibrate_cubic_mean_field, calibrate_cubic_relaxed, CubicCalibration, CubicOptions,
    CubicParameters, Family,
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
