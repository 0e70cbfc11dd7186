//! The term's share of an explicit integrator's stability bound: Gershgorin row sums of
//! its Hessian (docs/manybody.md), so an engine that sizes its time step from the springs
//! alone (YADE's route) can add the term's ω².

use super::ManyBody;
use crate::{Error, Result, Vec3};

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
        let mut rows = vec![[0.0_f64; 6]; self.len()];
        self.add_gershgorin_rows(self.reference_branches(), masses, &mut rows)?;
        Ok(rows
            .iter()
            .map(|r| r[..3].iter().fold(0.0_f64, |m, v| m.max(*v)))
            .collect())
    }

    /// Add to each particle's translation rows of `rows` (an integrator's Gershgorin rows,
    /// translations then rotations) Σ_q Σ_c |K_pq(a, c)| / √(m_p m_q), K the term's Hessian
    /// at branch vectors `branch` (the term applies no torque, so rotation rows get nothing).
    pub(crate) fn add_gershgorin_rows(
        &self,
        branch: &[Vec3],
        masses: &[f64],
        rows: &mut [[f64; 6]],
    ) -> Result<()> {
        let k = self.hessian(branch)?;
        for (r, row) in rows.iter_mut().enumerate() {
            for (c, blk) in k.row(r) {
                for a in 0..3 {
                    for d in 0..3 {
                        row[a] += blk[(a, d)].abs() / (masses[r] * masses[c]).sqrt();
                    }
                }
            }
        }
        Ok(())
    }
}
