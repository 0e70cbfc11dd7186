//! The many-body term (issue 33, docs/manybody.md "Integrator") in the reference integrator:
//! every step, after the bond law, each particle's fitted Green–Lagrange strain gives the
//! term's energy and its pair of forces ±g_b on every bond ([`ManyBody::gradients_into`], no
//! allocation); the particle update adds ±g_b to each particle's resultant as it gathers the
//! bond loads (no pass of its own), the energy joins the ledger
//! ([`super::Energies::manybody`]) and Σ g_b ⊗ l_b the Love stress. Built once from the
//! intact bonds; refused with breakage.

use super::state::{deterministic_sum_mat3, BondTopology, Particles};
use crate::manybody::{ManyBody, StrainMeasure, Workspace};
use crate::{Error, Mat3, Result, Vec3};

/// The term and its per-step buffers.
#[derive(Clone, Debug)]
pub(crate) struct ManyBodyForces {
    term: ManyBody,
    ws: Workspace,
}

/// Branch vector of bond `b`, x_j + H·c − x_i, as [`super::Simulation::branch`] (the same
/// operations, so the term sees the bits the bond laws see; H·c is skipped for the bonds
/// inside the cell, c = 0, where adding it changes no bit but a zero's sign).
#[inline(always)]
fn branch(p: &[Vec3], t: &BondTopology, h: &Mat3, periodic: bool, b: usize) -> Vec3 {
    let (i, j) = (t.i[b] as usize, t.j[b] as usize);
    let c = t.cell_dist[b];
    if periodic && (c.x != 0.0 || c.y != 0.0 || c.z != 0.0) {
        p[j] + h * c - p[i]
    } else {
        p[j] - p[i]
    }
}

impl ManyBodyForces {
    /// The term of an integrator whose particles, bonds and cell are `particles`,
    /// `topology`, `h` (`None`: free). Refuses ([`Error::Invalid`]) the small-strain
    /// measure (not rotation invariant: a rigidly turning particle would store energy of
    /// order θ⁴ and feel spurious forces), a term of other particles or bonds, and a term
    /// whose reference is not this state (the bonds are stress-free here, so must it be).
    pub(crate) fn new(
        term: ManyBody,
        particles: &Particles,
        topology: &BondTopology,
        h: Option<&Mat3>,
    ) -> Result<Self> {
        if term.measure() == StrainMeasure::Small {
            return Err(Error::Invalid(
                "many-body term in the integrator: the small-strain measure is not rotation \
                 invariant (a rigid rotation by θ strains every particle by O(θ²) and stores \
                 energy); particles and cell rotate in a dynamic run, so use the Green–Lagrange \
                 measure (`measure = \"green-lagrange\"` in [manybody])"
                    .into(),
            ));
        }
        if term.len() != particles.len() || term.bond_count() != topology.len() {
            return Err(Error::Invalid(format!(
                "many-body term in the integrator: the term has {} particles and {} bonds, the \
                 assembly {} and {}",
                term.len(),
                term.bond_count(),
                particles.len(),
                topology.len()
            )));
        }
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        for b in 0..topology.len() {
            let (i, j, image) = term.bond(b);
            let d = topology.cell_dist[b];
            let same_image = (0..3).all(|k| image[k] as f64 == d[k]);
            if i != topology.i[b] || j != topology.j[b] || !same_image {
                return Err(Error::Invalid(format!(
                    "many-body term in the integrator: bond {b} joins {i}–{j} (image {image:?}) \
                     in the term but {}–{} in the assembly: build the term from the same bonds",
                    topology.i[b], topology.j[b]
                )));
            }
            let l = branch(&particles.position, topology, &hm, periodic, b);
            let r = term.reference_branches()[b];
            if (l - r).norm() > 1e-9 * r.norm() {
                return Err(Error::Invalid(format!(
                    "many-body term in the integrator: bond {b}'s branch vector differs from the \
                     term's reference by {:.3e} m: the term must be built on the state the \
                     integrator starts from (where its bonds are stress-free)",
                    (l - r).norm()
                )));
            }
        }
        let ws = term.workspace();
        Ok(ManyBodyForces { term, ws })
    }

    /// The term.
    pub(crate) fn term(&self) -> &ManyBody {
        &self.term
    }

    /// Energy and bond gradients g_b at the current positions and cell `h` (`None`: free).
    pub(crate) fn compute(&mut self, p: &Particles, t: &BondTopology, h: Option<&Mat3>) {
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        let x = &p.position[..];
        self.term
            .gradients_into(|b| branch(x, t, &hm, periodic, b), &mut self.ws);
    }

    /// g_b = ∂U/∂l_b of every bond at the last [`compute`](Self::compute) (N): the term's
    /// force on particle p is Σ_b (+g_b at i_b, −g_b at j_b).
    pub(crate) fn bond_gradients(&self) -> &[Vec3] {
        &self.ws.gradient
    }

    /// g_b = ∂U/∂l_b of bond `b` at the last [`compute`](Self::compute) (N): the term's force
    /// on the bond's i end (−g_b on its j end).
    pub(crate) fn bond_force(&self, b: usize) -> Vec3 {
        self.term.bond_gradient(b, &self.ws)
    }

    /// U of the last [`compute`](Self::compute) (J).
    pub(crate) fn energy(&self) -> f64 {
        self.ws.energy()
    }

    /// Σ_b g_b ⊗ l_b (N·m) with g_b of the last evaluation and the current branch vectors:
    /// the term's share of the Love stress times V, as the bonds' Σ f_i ⊗ l (the virial of
    /// the pair of forces ±g_b; at the reference it is the nominal stress V·∂U/∂H).
    pub(crate) fn stress_sum(&self, p: &Particles, t: &BondTopology, h: Option<&Mat3>) -> Mat3 {
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        deterministic_sum_mat3(t.len(), |b| {
            self.term.bond_gradient(b, &self.ws)
                * branch(&p.position, t, &hm, periodic, b).transpose()
        })
    }

    /// Add the term's Gershgorin row sums of its Hessian at the current state, mass-scaled
    /// as the bonds' (translation rows only: the term applies no torque), to `rows`.
    pub(crate) fn add_gershgorin(
        &self,
        rows: &mut [[f64; 6]],
        p: &Particles,
        t: &BondTopology,
        h: Option<&Mat3>,
    ) -> Result<()> {
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        let l: Vec<Vec3> = (0..t.len())
            .map(|b| branch(&p.position, t, &hm, periodic, b))
            .collect();
        self.term.add_gershgorin_rows(&l, &p.mass, rows)
    }
}
