//! Which pairs of spheres are bonded (Truszkowska 2018 Eq. 4 gap cutoff; Kumar 2016
//! Eq. 10 interaction range κ; Šmilauer's contact radius I_R; or a target coordination).

use serde::{Deserialize, Serialize};

/// The bonding rule of a model's `[bonding]` table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", content = "value", rename_all = "kebab-case")]
pub enum BondingRule {
    /// Bond when |x_i − x_j| − (R_i + R_j) ≤ value·R̄ (Truszkowska 2018, Eq. 4).
    Gap(f64),
    /// Bond when |x_i − x_j| ≤ value·(R_i + R_j) (κ of Kumar 2016 Eq. 10, I_R of Šmilauer).
    Factor(f64),
    /// Bisect the gap cutoff until the mean bonds per particle equals the value.
    Coordination(f64),
}

impl Default for BondingRule {
    fn default() -> Self {
        BondingRule::Gap(0.17)
    }
}
