//! The tensor report of docs/formats.md (`--json`): the 6×6 tensor in Pa with its symmetrised cubic
//! and transversely isotropic projections (Truszkowska 2018 Sec. 4.4 / Eq. 30).

use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::tensor::{kelvin_moduli, CubicProjection, Stiffness6, TransverseProjection};
use crate::{Error, Result};
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
    /// Relaxed method: the relative residual ‖f − K u‖/‖f‖ the linear solver reached (the
    /// tensor's relative error is of the order of its square).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relative_residual: Option<f64>,
}

/// Refuse a computed tensor that is not a result: non-finite entries (an overflow in the
/// inputs' magnitudes), all zeros (a network that carries no load), or not positive definite
/// (a mechanism: some strain costs no energy). `method` names the tensor in the message.
pub fn check_result_tensor(c: &Stiffness6, method: &str) -> Result<()> {
    if c.iter().any(|x| !x.is_finite()) {
        return Err(Error::Degenerate(format!(
            "the {method} tensor overflows (non-finite entries): the magnitudes of the inputs \
             (model stiffness, radii, cell) are out of the range of double precision; scale them \
             to SI values"
        )));
    }
    let scale = c.amax();
    if scale > 0.0 && scale < 1e-280 {
        return Err(Error::Degenerate(format!(
            "the {method} tensor underflows (largest entry {scale:e} Pa): the magnitudes of \
             the inputs are out of the range of double precision; scale them to SI values"
        )));
    }
    if scale == 0.0 {
        return Err(Error::Degenerate(format!(
            "the bond network carries no load: the {method} tensor is zero (no bond with a \
             non-zero spring takes part in the load-bearing network)"
        )));
    }
    let sym = 0.5 * (c + c.transpose());
    let moduli = kelvin_moduli(&sym);
    let (smallest, largest) = (moduli[0], moduli[5]);
    let positive = smallest > 1e-9 * largest;
    if !positive {
        return Err(Error::Degenerate(format!(
            "the bond network is a mechanism: the {method} tensor is not positive definite \
             (smallest Kelvin modulus {smallest:.4e} Pa, largest {largest:.4e} Pa), so some \
             homogeneous strain costs no energy; too few bonds or springs that are zero"
        )));
    }
    Ok(())
}

impl TensorReport {
    /// Build the report of tensor `c` computed by `method`, with the packing's counts; a
    /// tensor that is not a result (see [`check_result_tensor`]) is refused.
    pub fn new(method: &str, c: Stiffness6, bonded: Option<(&Packing, &BondSet)>) -> Result<Self> {
        check_result_tensor(&c, method)?;
        let cp = CubicProjection::from_stiffness(&c);
        let tp = TransverseProjection::from_stiffness(&c);
        let report = TensorReport {
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
            relative_residual: None,
        };
        report.check_finite()?;
        Ok(report)
    }

    /// Refuse a report holding a non-finite number anywhere (JSON would write `null`).
    pub fn check_finite(&self) -> Result<()> {
        let (cu, un, tr) = (&self.cubic, &self.cubic.uncertainty, &self.transverse);
        let named = [
            ("coordination", self.coordination.unwrap_or(0.0)),
            ("volume", self.volume.unwrap_or(0.0)),
            ("relative_residual", self.relative_residual.unwrap_or(0.0)),
            ("cubic.C11", cu.c11),
            ("cubic.C12", cu.c12),
            ("cubic.C44", cu.c44),
            ("cubic.zener", cu.zener),
            ("cubic.uncertainty.C11", un.c11),
            ("cubic.uncertainty.C12", un.c12),
            ("cubic.uncertainty.C44", un.c44),
            ("cubic.uncertainty.zero_terms", un.zero_terms),
            ("transverse.C11", tr.c11),
            ("transverse.C33", tr.c33),
            ("transverse.C13", tr.c13),
            ("transverse.C12", tr.c12),
            ("transverse.C44", tr.c44),
        ];
        let entries = (0..36).map(|k| ("C", self.c[k / 6][k % 6]));
        if let Some((name, v)) = named
            .into_iter()
            .chain(entries)
            .find(|(_, v)| !v.is_finite())
        {
            return Err(Error::Degenerate(format!(
                "the {} tensor report has a non-finite {name} ({v}): an overflow in the \
                 inputs' magnitudes (model stiffness, radii, cell) or a degenerate packing",
                self.method
            )));
        }
        Ok(())
    }

    /// The 6×6 tensor as a matrix.
    pub fn tensor(&self) -> Stiffness6 {
        Stiffness6::from_fn(|i, j| self.c[i][j])
    }

    /// Pretty JSON (the report holds only finite numbers: see [`TensorReport::check_finite`]).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}
