//! The accessible (C12/C11, C44/C11) domain of the cubic models (Truszkowska 2018 Eq. 16,
//! Fig. 8, Fig. C.1a), sampled in the log-normalised parameter space on the mean field or
//! on the relaxed tensor of a packing: `anisobond domain` (domain.csv, domain.png).
//!
//! ```
//! use anisobond::calibrate::DomainOptions;
//! use anisobond::study::domain::{run, DomainOn};
//! let opts = DomainOptions { samples: 20, ..Default::default() };
//! let r = run(DomainOn::MeanField, &opts).unwrap();
//! assert_eq!(r.summary().len(), 4);
//! ```

use crate::assembly::Assembly;
use crate::calibrate::domain::{sample_mean_field, sample_relaxed, DomainOptions, DomainSample};
use crate::homogenize::relaxed::RelaxedOptions;
use crate::schemes::cubic::CubicModel;
use crate::Result;

/// Samples per model variant on the relaxed tensor when not given (one relaxed solve each;
/// the mean field's default is [`DomainOptions::default`]'s).
pub const RELAXED_SAMPLES: usize = 60;

/// Where the constants come from.
#[derive(Clone, Copy)]
pub enum DomainOn<'a> {
    /// The mean-field integral (fast).
    MeanField,
    /// The relaxed tensor of this periodic assembly's bonds (its geometry; midpoint lever
    /// arm).
    Relaxed(&'a Assembly),
}

impl DomainOn<'_> {
    /// Samples per variant when not given.
    pub fn default_samples(&self) -> usize {
        match self {
            DomainOn::MeanField => DomainOptions::default().samples,
            DomainOn::Relaxed(_) => RELAXED_SAMPLES,
        }
    }
}

/// One model variant's ranges over its samples.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VariantSummary {
    /// `zener-above-1` or `zener-below-1`.
    pub model: &'static str,
    /// Extended (<110>) model.
    pub extended: bool,
    /// Its samples.
    pub samples: usize,
    /// Zener ratio, lowest and highest.
    pub zener: (f64, f64),
    /// C12/C11, lowest and highest.
    pub c12_over_c11: (f64, f64),
    /// C44/C11, lowest and highest.
    pub c44_over_c11: (f64, f64),
    /// Largest (C12 − C44)/C11 (Cauchy's relation C12 = C44 is the boundary).
    pub max_c12_minus_c44_over_c11: f64,
}

/// The sampled domain.
pub struct DomainReport {
    /// "mean field" or "relaxed, N particles".
    pub label: String,
    /// The samples.
    pub samples: Vec<DomainSample>,
    /// Extended samples skipped for negative stiffness.
    pub skipped: usize,
}

/// Sample the domain `on` the mean field or a packing's relaxed tensor.
pub fn run(on: DomainOn, opts: &DomainOptions) -> Result<DomainReport> {
    let (samples, skipped, label) = match on {
        DomainOn::MeanField => {
            let (s, k) = sample_mean_field(opts)?;
            (s, k, "mean field".to_string())
        }
        DomainOn::Relaxed(b) => {
            let (s, k) = sample_relaxed(
                &b.packing,
                &b.bonds,
                &b.model.geometry,
                &RelaxedOptions::default(),
                opts,
            )?;
            (s, k, format!("relaxed, {} particles", b.packing.len()))
        }
    };
    Ok(DomainReport {
        label,
        samples,
        skipped,
    })
}

impl DomainReport {
    /// The ranges of every model variant that has samples (Z > 1 plain, extended, Z < 1
    /// plain, extended).
    pub fn summary(&self) -> Vec<VariantSummary> {
        let mut out = Vec::new();
        for model in [CubicModel::ZenerAbove1, CubicModel::ZenerBelow1] {
            for extended in [false, true] {
                let v: Vec<&DomainSample> = self
                    .samples
                    .iter()
                    .filter(|s| s.model == model && s.extended == extended)
                    .collect();
                if v.is_empty() {
                    continue;
                }
                let range = |f: &dyn Fn(&DomainSample) -> f64| {
                    v.iter()
                        .map(|s| f(s))
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                            (l.min(x), h.max(x))
                        })
                };
                out.push(VariantSummary {
                    model: model.as_str(),
                    extended,
                    samples: v.len(),
                    zener: range(&|s| s.zener),
                    c12_over_c11: range(&|s| s.c12_over_c11),
                    c44_over_c11: range(&|s| s.c44_over_c11),
                    max_c12_minus_c44_over_c11: range(&|s| s.c12_over_c11 - s.c44_over_c11).1,
                });
            }
        }
        out
    }

    /// Write domain.csv and domain.png into `dir`: the springs' sampled domain, the stable
    /// domain's bounds (inside them `calibrate` reaches any target with the many-body term),
    /// `target`'s (C12/C11, C44/C11) and the cubic metals of
    /// [`crate::calibrate::manybody::CUBIC_MATERIALS`] marked.
    #[cfg(feature = "plot")]
    pub fn write(&self, dir: &std::path::Path, target: Option<(f64, f64)>) -> Result<()> {
        crate::calibrate::domain::write_csv(&dir.join("domain.csv"), &self.samples)?;
        let materials: Vec<(&str, f64, f64)> = crate::calibrate::manybody::CUBIC_MATERIALS
            .iter()
            .map(|&(name, c11, c12, c44)| (name, c12 / c11, c44 / c11))
            .collect();
        crate::plot::plot_domain_with_materials(
            &dir.join("domain.png"),
            &self.samples,
            &format!("Accessible cubic domain ({})", self.label),
            target,
            &materials,
        )
    }
}
