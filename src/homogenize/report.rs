//! The tensor report of docs/formats.md (`--json`): the 6×6 tensor in Pa with its symmetrised cubic
//! and transversely isotropic projections (Truszkowska 2018 Sec. 4.4 / Eq. 30).

use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::tensor::{
    kelvin_moduli, CubicProjection, CubicUncertainty, Stiffness6, TransverseProjection,
};
use crate::{Error, Result};
use serde::Serialize;

/// Cubic projection: C11, C12, C44 (Pa), Zener ratio and the paper's uncertainty
/// (Truszkowska 2018 Sec. 5.3), as [`CubicProjection`] serialises it.
pub type CubicSummary = CubicProjection;

/// Uncertainty of the cubic projection (Pa), Truszkowska 2018 Sec. 5.3: the tensor
/// module's [`CubicUncertainty`] as the report serialises it.
pub type Uncertainty = CubicUncertainty;

/// Transversely isotropic projection about z (Pa): C11, C33, C13, C12, C44 of
/// [`TransverseProjection`].
pub type TransverseSummary = TransverseProjection;

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
    /// LAF stress-based estimate: its departure from major symmetry max|C − Cᵀ| / max|C|
    /// (Kruyt 2014 Sec. 4: C_σ = (H − GᵀQ)/V is not symmetric unless the shells are exact).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub asymmetry: Option<f64>,
    /// A model with a many-body term (`[manybody]`, docs/manybody.md): Σ_p V_p / V, the share
    /// of D the term adds under a uniform strain (below 1 when degenerate particles are
    /// excluded).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub manybody_volume_fraction: Option<f64>,
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
    /// tensor that is not a result (see `check_result_tensor`) is refused.
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
            cubic: cp,
            transverse: tp,
            relative_residual: None,
            asymmetry: None,
            manybody_volume_fraction: None,
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
            (
                "manybody_volume_fraction",
                self.manybody_volume_fraction.unwrap_or(0.0),
            ),
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
