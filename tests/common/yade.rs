//! Shared helpers of the YADE tests: skip only when `yade` is not on PATH, and never when
//! the environment variable CI is set (then the missing executable is a failure).

#![allow(dead_code)]

use anisobond::export::yade::find_yade;

/// True when YADE can be run. Without `yade` on PATH: panics under CI, else prints why
/// the test is skipped and returns false.
pub fn yade_available(test: &str) -> bool {
    if find_yade().is_some() {
        return true;
    }
    if std::env::var_os("CI").is_some() {
        panic!("{test}: CI is set but `yade` is not on PATH — install it (apt install yade)");
    }
    eprintln!("SKIPPED {test}: `yade` is not on PATH (YADE 2023.02a needed)");
    false
}

/// Largest |a − b| over all entries divided by the largest |b|.
pub fn max_relative(a: &anisobond::tensor::Stiffness6, b: &anisobond::tensor::Stiffness6) -> f64 {
    (a - b).abs().max() / b.abs().max()
}
