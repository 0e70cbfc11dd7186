//! The term's share of an explicit integrator's stability bound: Gershgorin row sums of
//! its Hessian (docs/manybody.md), so an engine that sizes its time step from the springs
//! alone (YADE's route) can add the term's ω².

use super::ManyBody;
use crate::{Error, Result};

impl ManyBody {
    /// Per particle p: max over its three translation rows a of Σ_q Σ_c |K_pq(a, c)| /
    /// √(m_p m_q) (1/s²), K the term's Hessian at the reference state. Added to the
    /// springs' Gershgorin rows it bounds ω²_max of M^-1/2 K M^-1/2, so dt_c = 2/ω_max stays
    /// safe. Refuses masses of the wrong count or not finite and > 0.
    pub fn gershgorin_rows(&self, masses: &[f64]) -> Result<Vec<f64>> {
        if masses.len() != self.len() {
            return Err(Error::Invalid(format!(
                "many-body term: {} masses for {} particles",
                masses.len(),
                self.len()
            )));
        }
        if let Some(p) = masses.iter().position(|m| !(m.is_finite() && *m > 0.0)) {
            return Err(Error::Invalid(format!(
                "many-body term: mass of particle {p} is {}, expected a finite value > 0 (kg)",
                masses[p]
            )));
        }
        let k = self.hessian(self.reference_branches())?;
        Ok((0..k.rows())
            .map(|p| {
                let mut rows = [0.0_f64; 3];
                for (q, block) in k.row(p) {
                    let scale = 1.0 / (masses[p] * masses[q]).sqrt();
                    for (a, row) in rows.iter_mut().enumerate() {
                        *row += (0..3).map(|c| block[(a, c)].abs()).sum::<f64>() * scale;
                    }
                }
                rows.iter().fold(0.0_f64, |m, v| m.max(*v))
            })
            .collect())
    }
}
