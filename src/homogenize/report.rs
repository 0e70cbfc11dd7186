//! The tensor report of SPEC.md (`--json`): the 6×6 tensor in Pa with its symmetrised cubic
//! and transversely isotropic projections (Truszkowska 2018 Sec. 4.4 / Eq. 30).

use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::tensor::{CubicProjection, Stiffness6, TransverseProjection};
use serde::Serialize;

/// Cubic projection: C11, C12, C44 (Pa), Zener ratio and the paper's uncertainty.
#[derive(Clone, Debug, Serialize)]
pub struct CubicSummary {
    /// Mean of C11, C22, C33 (Pa).
    #[serde(rename = "C11")]
    pub c11: f64,
    /// Mean of C12, C13, C23 (Pa).
    #[serde(rename = "C12")]
    pub c12: f64,
    /// Mean of C44, C55, C66 (Pa).
    #[serde(rename = "C44")]
    pub c44: f64,
    /// Zener ratio 2C44/(C11 − C12).
    pub zener: f64,
    /// Largest deviation within each group and mean magnitude of the terms that should be
    /// zero (Pa).
    pub uncertainty: Uncertainty,
}

/// Uncertainty of the cubic projection (Pa), Truszkowska 2018 Sec. 5.3.
#[derive(Clone, Debug, Serialize)]
pub struct Uncertainty {
    /// Largest |C_ii − C̄11|, i = 1..3.
    #[serde(rename = "C11")]
    pub c11: f64,
    /// Largest |C_ij − C̄12|.
    #[serde(rename = "C12")]
    pub c12: f64,
    /// Largest |C_ii − C̄44|, i = 4..6.
    #[serde(rename = "C44")]
    pub c44: f64,
    /// Mean magnitude of the terms that are zero under cubic symmetry.
    pub zero_terms: f64,
}

/// Transversely isotropic projection about z (Pa).
#[derive(Clone, Debug, Serialize)]
pub struct TransverseSummary {
    /// C11 = C22.
    #[serde(rename = "C11")]
    pub c11: f64,
    /// C33.
    #[serde(rename = "C33")]
    pub c33: f64,
    /// C13 = C23.
    #[serde(rename = "C13")]
    pub c13: f64,
    /// C12.
    #[serde(rename = "C12")]
    pub c12: f64,
    /// C44 = C55.
    #[serde(rename = "C44")]
    pub c44: f64,
}

/// The SPEC tensor report.
#[derive(Clone, Debug, Serialize)]
pub struct TensorReport {
    /// mean-field | voigt | relaxed | laf | dynamic.
    pub method: String,
    /// Always "Pa".
    pub units: String,
    /// The 6×6 Voigt tensor, row by row (Pa).
    #[serde(rename = "C")]
    pub c: [[f64; 6]; 6],
    /// Number of particles (null for a mean field without packing).
    pub n_particles: Option<usize>,
    /// Number of bonds.
    pub n_bonds: Option<usize>,
    /// Mean bonds per particle Z.
    pub coordination: Option<f64>,
    /// Volume (m³).
    pub volume: Option<f64>,
    /// Cubic projection.
    pub cubic: CubicSummary,
    /// Transversely isotropic projection about z.
    pub transverse: TransverseSummary,
}

impl TensorReport {
    /// Build the report of tensor `c` computed by `method`, with the packing's counts.
    pub fn new(method: &str, c: Stiffness6, bonded: Option<(&Packing, &BondSet)>) -> Self {
        let cp = CubicProjection::from_stiffness(&c);
        let tp = TransverseProjection::from_stiffness(&c);
        TensorReport {
            method: method.to_string(),
            units: "Pa".to_string(),
            c: [0, 1, 2, 3, 4, 5].map(|i| [0, 1, 2, 3, 4, 5].map(|j| c[(i, j)])),
            n_particles: bonded.map(|(p, _)| p.len()),
            n_bonds: bonded.map(|(_, b)| b.len()),
            coordination: bonded.map(|(p, b)| b.coordination(p.len())),
            volume: bonded.map(|(p, _)| p.volume()),
            cubic: CubicSummary {
                c11: cp.c11,
                c12: cp.c12,
                c44: cp.c44,
                zener: cp.zener,
                uncertainty: Uncertainty {
                    c11: cp.uncertainty.c11,
                    c12: cp.uncertainty.c12,
                    c44: cp.uncertainty.c44,
                    zero_terms: cp.uncertainty.zero_terms,
                },
            },
            transverse: TransverseSummary {
                c11: tp.c11,
                c33: tp.c33,
                c13: tp.c13,
                c12: tp.c12,
                c44: tp.c44,
            },
        }
    }

    /// The 6×6 tensor as a matrix.
    pub fn tensor(&self) -> Stiffness6 {
        Stiffness6::from_fn(|i, j| self.c[i][j])
    }

    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}
