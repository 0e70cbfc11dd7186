//! Plane elastic waves in an anisotropic solid: the Christoffel equation.
//!
//! For a propagation direction n the acoustic tensor Γ_ik = C_ijkl n_j n_l is symmetric and,
//! for a positive definite C, positive definite; its eigenvalues are ρv² and its
//! eigenvectors the polarisations (Auld, *Acoustic Fields and Waves in Solids*, Eq. 7.18;
//! Musgrave 1970). With C in Voigt form the entries are Γ = Nᵀ C N with N the 6×3 map
//! of a unit direction into Voigt strain ("Christoffel matrix" form).

use super::{unit_vector, Stiffness6, VOIGT_PAIRS};
use crate::{Error, Mat3, Result, Vec3};

/// One plane-wave mode for a given propagation direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveMode {
    /// Phase velocity v = √(λ/ρ) (m/s), λ an eigenvalue of the acoustic tensor.
    pub speed: f64,
    /// Unit polarisation (particle displacement direction), sign fixed so that its largest
    /// component is positive.
    pub polarisation: Vec3,
}

/// The three plane-wave modes of a direction, slowest first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseVelocities {
    /// Unit propagation direction.
    pub direction: Vec3,
    /// Modes by increasing speed: `modes[2]` is the quasi-longitudinal wave when C is not
    /// pathological.
    pub modes: [WaveMode; 3],
}

impl PhaseVelocities {
    /// Speed of the fastest (quasi-longitudinal) mode (m/s).
    pub fn fastest(&self) -> f64 {
        self.modes[2].speed
    }

    /// The mode whose polarisation is most nearly along the propagation direction
    /// (quasi-longitudinal), whatever its rank by speed.
    pub fn quasi_longitudinal(&self) -> WaveMode {
        *self
            .modes
            .iter()
            .max_by(|a, b| {
                let da = a.polarisation.dot(&self.direction).abs();
                let db = b.polarisation.dot(&self.direction).abs();
                da.total_cmp(&db)
            })
            .expect("three modes")
    }
}

/// The acoustic (Christoffel) tensor Γ_ik = C_ijkl n_j n_l (Pa) of a unit direction n.
pub fn acoustic_tensor(c: &Stiffness6, n: &Vec3) -> Mat3 {
    // N (6×3): Voigt strain of the displacement gradient n ⊗ a for a unit a along axis k:
    // ε_ij = (n_i a_j + n_j a_i)/2, engineering shear doubled.
    let mut nm = nalgebra::Matrix6x3::<f64>::zeros();
    for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
        if i == j {
            nm[(a, i)] = n[i];
        } else {
            nm[(a, i)] += n[j];
            nm[(a, j)] += n[i];
        }
    }
    let g = nm.transpose() * c * nm;
    (g + g.transpose()) * 0.5
}

/// Phase velocities and polarisations along `direction` (normalised here) of a medium with
/// stiffness `c` (Pa, Voigt) and density `density` (kg/m³): the eigen-pairs of Γ/ρ.
/// Errors on a zero or non-finite direction, a non-positive density, or a direction in
/// which Γ is not positive definite (C not positive definite: no real wave speed).
pub fn phase_velocities(c: &Stiffness6, density: f64, direction: &Vec3) -> Result<PhaseVelocities> {
    let n = unit_vector(direction).ok_or_else(|| {
        Error::Invalid(format!(
            "wave direction must be a finite non-zero vector, got {} {} {}",
            direction.x, direction.y, direction.z
        ))
    })?;
    if !(density.is_finite() && density > 0.0) {
        return Err(Error::Invalid(format!(
            "density must be finite and > 0 kg/m³, got {density}"
        )));
    }
    if c.iter().any(|v| !v.is_finite()) {
        return Err(Error::Invalid(
            "stiffness tensor has non-finite entries".into(),
        ));
    }
    let gamma = acoustic_tensor(c, &n);
    let eig = nalgebra::SymmetricEigen::new(gamma);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let scale = gamma.norm();
    let mut modes = [WaveMode {
        speed: 0.0,
        polarisation: Vec3::zeros(),
    }; 3];
    for (slot, &k) in order.iter().enumerate() {
        let lam = eig.eigenvalues[k];
        if lam.is_nan() || lam <= 1e-12 * scale {
            return Err(Error::Degenerate(format!(
                "acoustic tensor along ({:.4}, {:.4}, {:.4}) has eigenvalue {lam:.4e} Pa ≤ 0: \
                 the stiffness is not positive definite, no real wave speed",
                n.x, n.y, n.z
            )));
        }
        let mut p: Vec3 = eig.eigenvectors.column(k).into_owned();
        let big = (0..3)
            .max_by(|&a, &b| p[a].abs().total_cmp(&p[b].abs()))
            .expect("3");
        if p[big] < 0.0 {
            p = -p;
        }
        modes[slot] = WaveMode {
            speed: (lam / density).sqrt(),
            polarisation: p,
        };
    }
    Ok(PhaseVelocities {
        direction: n,
        modes,
    })
}
