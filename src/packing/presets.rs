//! The papers' standard assemblies as presets: how many particles, which solid fraction,
//! which radius spread, which preparation route, and how the papers bond them.

use super::generate::TRUSZKOWSKA_2018_HALF_WIDTH;
use super::routes::{PreparationRoute, KUMAR_2016_HALF_WIDTH, KUMAR_2016_SOLID_FRACTION};
use crate::bonds::BondingRule;

/// Truszkowska 2018 Sec. 4.1/5.1: the standard assembly's particle count (the MRV).
pub const TRUSZKOWSKA_STANDARD_PARTICLES: usize = 30_700;
/// Truszkowska 2018 Sec. 4.1: void fraction 0.40.
pub const TRUSZKOWSKA_STANDARD_VOID_FRACTION: f64 = 0.40;
/// Truszkowska 2018 Sec. 5.1: gap cutoff 0.17 R̄ (Eq. 4), mean coordination ≈ 7.7.
pub const TRUSZKOWSKA_STANDARD_GAP: f64 = 0.17;
/// Kumar 2016 Sec. 3: 5000 particles per sample.
pub const KUMAR_STANDARD_PARTICLES: usize = 5000;
/// Kumar 2016 Table 1: the interaction ranges κ the paper bonds its samples with (Eq. 10).
pub const KUMAR_2016_RANGES: [f64; 4] = [1.0, 1.025, 1.05, 1.075];

/// How a packing is prepared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Route {
    /// Random positions at the target solid fraction, overlaps removed by energy
    /// minimisation (Truszkowska 2018 Sec. 4.1).
    Random,
    /// One of Kumar 2016's three preparation routes (Sec. 3).
    Kumar(PreparationRoute),
}

/// A paper's standard assembly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    /// How it is prepared.
    pub route: Route,
    /// Number of particles.
    pub particles: usize,
    /// Solid fraction φ.
    pub solid_fraction: f64,
    /// Radius half width h: radii uniform in R̄(1 ± h).
    pub half_width: f64,
    /// The bonding rules the paper uses on it.
    pub bonding: &'static [BondingRule],
}

/// Truszkowska 2018's standard assembly: 30,700 particles, void fraction 0.40, radius range
/// ΔR = R̄/6, random route, gap bonding 0.17 R̄ (118,008 bonds in the paper, Z ≈ 7.7).
pub const TRUSZKOWSKA_STANDARD: Preset = Preset {
    route: Route::Random,
    particles: TRUSZKOWSKA_STANDARD_PARTICLES,
    solid_fraction: 1.0 - TRUSZKOWSKA_STANDARD_VOID_FRACTION,
    half_width: TRUSZKOWSKA_2018_HALF_WIDTH,
    bonding: &[BondingRule::Gap(TRUSZKOWSKA_STANDARD_GAP)],
};

/// Kumar 2016's samples: 5000 particles, solid fraction 0.65, R̄ ± 5 %, jammed route,
/// bonded with the interaction ranges κ = 1.000 … 1.075 of Table 1.
pub const KUMAR_2016: Preset = Preset {
    route: Route::Kumar(PreparationRoute::Jammed),
    particles: KUMAR_STANDARD_PARTICLES,
    solid_fraction: KUMAR_2016_SOLID_FRACTION,
    half_width: KUMAR_2016_HALF_WIDTH,
    bonding: &[
        BondingRule::Factor(KUMAR_2016_RANGES[0]),
        BondingRule::Factor(KUMAR_2016_RANGES[1]),
        BondingRule::Factor(KUMAR_2016_RANGES[2]),
        BondingRule::Factor(KUMAR_2016_RANGES[3]),
    ],
};

/// The defaults without a preset: 2000 particles, φ = 0.6, Truszkowska's radius spread,
/// random route, gap bonding 0.17 R̄.
pub const DEFAULT: Preset = Preset {
    particles: 2000,
    solid_fraction: 0.6,
    ..TRUSZKOWSKA_STANDARD
};
