//! The accessible domain of the cubic models: random samples of the log-normalised parameter
//! space (Truszkowska 2018 Eq. 16) mapped to (C12/C11, C44/C11) by the mean field or by the
//! relaxed tensor of a packing (paper Fig. 8, Fig. C.1a).
//!
//! α = (ln a − ln a_min)/(ln a_max − ln a_min) is drawn uniformly in [0, 1] for a_n, a_s
//! and the shear/normal ratio; the paper's ranges are a ∈ [0.022, 5] (α = 0.703 at a = 1)
//! and shear/normal ∈ [0.005, 1]. Extended models whose stiffness goes negative somewhere
//! are skipped (they cannot be built, [`CubicSpheroid::new`]).

use super::cubic::extended_interval;
use super::kernel::CubicKernel;
use super::warm::WarmRelaxed;
use crate::bonds::BondSet;
use crate::homogenize::relaxed::RelaxedOptions;
use crate::packing::Packing;
use crate::schemes::cubic::{CubicModel, CubicSpheroid};
use crate::schemes::Geometry;
use crate::tensor::CubicProjection;
use crate::{Error, Mat3, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// One sampled model and its normalised constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DomainSample {
    /// Z > 1 or Z < 1 model.
    pub model: CubicModel,
    /// Extended (<110>) model.
    pub extended: bool,
    /// Normal aspect ratio.
    pub a_n: f64,
    /// Shear aspect ratio.
    pub a_s: f64,
    /// Shear/normal magnitude ratio.
    pub shear_over_normal: f64,
    /// C12/C11.
    pub c12_over_c11: f64,
    /// C44/C11.
    pub c44_over_c11: f64,
    /// Zener ratio 2C44/(C11 − C12).
    pub zener: f64,
    /// Poisson's ratio along <100>, C12/(C11 + C12).
    pub poisson_100: f64,
}

impl DomainSample {
    fn new(
        model: CubicModel,
        extended: bool,
        (a_n, a_s, rho): (f64, f64, f64),
        c11: f64,
        c12: f64,
        c44: f64,
    ) -> Self {
        DomainSample {
            model,
            extended,
            a_n,
            a_s,
            shear_over_normal: rho,
            c12_over_c11: c12 / c11,
            c44_over_c11: c44 / c11,
            zener: 2.0 * c44 / (c11 - c12),
            poisson_100: c12 / (c11 + c12),
        }
    }
}

/// Sampling ranges and count.
#[derive(Clone, Copy, Debug)]
pub struct DomainOptions {
    /// Samples drawn per model variant (4 variants: two models, plain and extended).
    pub samples: usize,
    /// Seed of the random stream (ChaCha8).
    pub seed: u64,
    /// a range of a_n and a_s (Truszkowska 2018: 0.022–5).
    pub a_min: f64,
    /// Upper end.
    pub a_max: f64,
    /// Shear/normal range (Truszkowska 2018: 0.005–1).
    pub ratio_min: f64,
    /// Upper end.
    pub ratio_max: f64,
    /// Include the extended models.
    pub extended: bool,
    /// Keep extended models whose shear stiffness goes negative somewhere (mean field only:
    /// the paper's Fig. C.1a; such models cannot be built for a packing).
    pub allow_negative: bool,
}

impl Default for DomainOptions {
    fn default() -> Self {
        DomainOptions {
            samples: 2500,
            seed: 2018,
            a_min: 0.022,
            a_max: 5.0,
            ratio_min: 0.005,
            ratio_max: 1.0,
            extended: true,
            allow_negative: false,
        }
    }
}

/// a from its log-normalised coordinate α (inverse of Truszkowska 2018 Eq. 16).
pub fn from_log_normalised(alpha: f64, min: f64, max: f64) -> f64 {
    (min.ln() + alpha * (max.ln() - min.ln())).exp()
}

/// α = (ln a − ln a_min)/(ln a_max − ln a_min) (Truszkowska 2018 Eq. 16).
pub fn log_normalised(a: f64, min: f64, max: f64) -> f64 {
    (a.ln() - min.ln()) / (max.ln() - min.ln())
}

fn check(opts: &DomainOptions) -> Result<()> {
    if opts.samples == 0 {
        return Err(Error::Invalid(
            "domain: the number of samples per model variant must be at least 1".into(),
        ));
    }
    // Four variants, each with its drawn triples and its samples.
    let per_sample = (std::mem::size_of::<DomainSample>() + 3 * 8) as f64;
    crate::io::check_memory(
        &format!("domain with {} samples per variant", opts.samples),
        4.0 * opts.samples as f64 * per_sample,
    )?;
    let ok = opts.a_min > 0.0
        && opts.a_max > opts.a_min
        && opts.a_max.is_finite()
        && opts.ratio_min > 0.0
        && opts.ratio_max > opts.ratio_min
        && opts.ratio_max.is_finite();
    if !ok {
        return Err(Error::Invalid(format!(
            "domain: ranges must satisfy 0 < min < max: a [{}, {}], shear/normal [{}, {}]",
            opts.a_min, opts.a_max, opts.ratio_min, opts.ratio_max
        )));
    }
    Ok(())
}

/// The model variants and, per variant, the parameter triples drawn (seeded, in order), with
/// inadmissible extended models removed. Returns (variant, triples) and the number skipped.
#[allow(clippy::type_complexity)]
fn draw(opts: &DomainOptions) -> (Vec<(CubicModel, bool, Vec<(f64, f64, f64)>)>, usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let mut variants = Vec::new();
    let mut skipped = 0;
    let exts: &[bool] = if opts.extended {
        &[false, true]
    } else {
        &[false]
    };
    for model in [CubicModel::ZenerAbove1, CubicModel::ZenerBelow1] {
        for &extended in exts {
            let (lo, hi) = (opts.a_min.ln(), opts.a_max.ln());
            // Admissible ln a intervals of the factors (the extended shear factor goes
            // negative away from a = 1).
            let range = |normal: bool| {
                if !extended || opts.allow_negative {
                    return (lo, hi);
                }
                extended_interval(model, lo.min(0.0), hi.max(0.0), normal)
            };
            let (xr, yr) = (range(true), range(false));
            let mut triples = Vec::with_capacity(opts.samples);
            for _ in 0..opts.samples {
                let a_n = from_log_normalised(rng.gen::<f64>(), opts.a_min, opts.a_max);
                let a_s = from_log_normalised(rng.gen::<f64>(), opts.a_min, opts.a_max);
                let rho = from_log_normalised(rng.gen::<f64>(), opts.ratio_min, opts.ratio_max);
                let inside = |a: f64, r: (f64, f64)| a.ln() >= r.0 && a.ln() <= r.1;
                if inside(a_n, xr) && inside(a_s, yr) {
                    triples.push((a_n, a_s, rho));
                } else {
                    skipped += 1;
                }
            }
            variants.push((model, extended, triples));
        }
    }
    (variants, skipped)
}

/// Mean-field domain: the samples and the number of extended models skipped for negative
/// stiffness.
pub fn sample_mean_field(opts: &DomainOptions) -> Result<(Vec<DomainSample>, usize)> {
    check(opts)?;
    let kernel = CubicKernel::default();
    let (variants, skipped) = draw(opts);
    let mut out = Vec::new();
    for (model, extended, triples) in variants {
        let samples: Vec<DomainSample> = triples
            .par_iter()
            .map(|&(a_n, a_s, rho)| {
                let c = kernel.constants(model, extended, a_n, a_s, rho);
                DomainSample::new(model, extended, (a_n, a_s, rho), c.c11, c.c12, c.c44)
            })
            .collect();
        out.extend(samples);
    }
    Ok((out, skipped))
}

/// Relaxed domain on a periodic bonded packing (one warm-started relaxed solve per sample;
/// keep `samples` modest). The cubic projection of the relaxed tensor gives the constants.
pub fn sample_relaxed(
    packing: &Packing,
    bonds: &BondSet,
    geometry: &Geometry,
    relaxed: &RelaxedOptions,
    opts: &DomainOptions,
) -> Result<(Vec<DomainSample>, usize)> {
    check(opts)?;
    if opts.allow_negative {
        return Err(Error::Invalid(
            "domain: models with negative stiffness cannot be built on a packing (allow_negative is mean-field only)".into(),
        ));
    }
    let (variants, skipped) = draw(opts);
    let mut out = Vec::new();
    for (model, extended, triples) in variants {
        let mut solver = WarmRelaxed::new(packing, bonds, *relaxed);
        for (a_n, a_s, rho) in triples {
            let scheme = CubicSpheroid::new(model, extended, a_n, a_s, 1.0, rho, Mat3::identity())?;
            let sol = solver.solve_scheme(&scheme, geometry)?;
            let p = CubicProjection::from_stiffness(&sol.c);
            out.push(DomainSample::new(
                model,
                extended,
                (a_n, a_s, rho),
                p.c11,
                p.c12,
                p.c44,
            ));
        }
    }
    Ok((out, skipped))
}

/// Write the samples as CSV (atomic): model,extended,a_n,a_s,shear_over_normal,
/// C12/C11,C44/C11,zener,nu_100.
#[cfg(feature = "plot")]
pub fn write_csv(path: &std::path::Path, samples: &[DomainSample]) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        let io = |e| Error::io(path, e);
        writeln!(
            w,
            "model,extended,a_n,a_s,shear_over_normal,C12/C11,C44/C11,zener,nu_100"
        )
        .map_err(io)?;
        for s in samples {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{}",
                s.model.as_str(),
                s.extended,
                s.a_n,
                s.a_s,
                s.shear_over_normal,
                s.c12_over_c11,
                s.c44_over_c11,
                s.zener,
                s.poisson_100
            )
            .map_err(io)?;
        }
        Ok(())
    })
}
