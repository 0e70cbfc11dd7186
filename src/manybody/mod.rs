//! A many-body term: every particle's local strain, fitted from its bonds, loads a chosen
//! fourth-order tensor D, so the assembly reaches tensors pairwise springs cannot (C12 > C44
//! beyond the Cauchy line, five independent transversely isotropic constants; issue 33;
//! the "Poisson coupling" Truszkowska 2018 Sec. 5.4 names as missing, and the idea of
//! LAMMPS' `bpm/spring … volume/factor`, Clemmer et al. 2024, made tensorial).
//!
//! Particle p with bonds b (reference branch vectors L_b, current l_b, both from bond i to
//! bond j) fits the local deformation gradient by least squares,
//! F_p = (Σ_b l_b ⊗ L_b)·A_p⁻¹ with A_p = Σ_b L_b ⊗ L_b (the sign of a bond seen from its
//! other end cancels), and carries the energy U = Σ_p ½ V_p E_p : D : E_p, E_p the
//! Green–Lagrange (or small) strain of F_p. Under a uniform strain F_p = F for every particle,
//! so the term adds exactly (Σ_p V_p / V)·D to the Voigt-level tensor. docs/manybody.md
//! gives the derivation; `term.rs` the reference data, energy, forces and Hessian.

pub(crate) mod spec;
pub(crate) mod term;
mod time_step;

pub use spec::ManyBodySpec;
pub use term::{Evaluation, ManyBody, Workspace};

use crate::tensor::{cubic_tensor, rotate, rotation_to_z, transverse_tensor, Stiffness6};
use crate::{Error, Mat3, Result, Vec3};

/// Refuse ([`Error::Model`]) a model with both `[grains]` and `[manybody]` in an engine's
/// export or validation (`engine`) that carries one tensor D (YADE's runner), not one per
/// grain, so the engine would run the single crystal's term on a polycrystal
/// (docs/polycrystal.md "What refuses grains"; LAMMPS' plugin and LIGGGHTS carry a D per
/// grain). Any other model: Ok.
pub fn refuse_polycrystal_term(model: &crate::model::Model, engine: &str) -> Result<()> {
    if model.grains.is_some() && model.manybody.is_some() {
        return Err(Error::Model(format!(
            "{engine}: the model has [grains] and [manybody]; a polycrystal's many-body term \
             loads each grain's own tensor D, which the {engine} files carry only as one \
             tensor; the library's relaxed tensor and integrator (`tensor`, `run`, \
             `stress-test`, `polycrystal`) apply it; or remove one of the tables"
        )));
    }
    Ok(())
}

/// The tensor D a particle's local strain loads (Pa), by its symmetry.
#[derive(Clone, Debug, PartialEq)]
pub enum LocalTensor {
    /// Isotropic: D = 3K·J + 2G·(I − J) (bulk K, shear G); `shear = 0` is the purely
    /// volumetric term (the LAMMPS `volume/factor` special case).
    Isotropic {
        /// Bulk modulus K (Pa).
        bulk: f64,
        /// Shear modulus G (Pa).
        shear: f64,
    },
    /// Cubic with constants in the crystal frame, `rotation` R mapping lab vectors into the
    /// crystal frame (as the cubic scheme's): D_lab = rotate(D_crystal, Rᵀ).
    Cubic {
        /// D11 (Pa).
        c11: f64,
        /// D12 (Pa).
        c12: f64,
        /// D44 (Pa).
        c44: f64,
        /// Lab → crystal rotation R (proper, |RᵀR − I| ≤ 1e-9).
        rotation: Mat3,
    },
    /// Transversely isotropic about `axis` (five constants, D66 = (D11 − D12)/2), the
    /// constants given with the axis along 3.
    TransverselyIsotropic {
        /// D11 (Pa).
        c11: f64,
        /// D33 (Pa), along the axis.
        c33: f64,
        /// D13 (Pa).
        c13: f64,
        /// D12 (Pa).
        c12: f64,
        /// D44 (Pa).
        c44: f64,
        /// Symmetry axis (any non-zero length).
        axis: Vec3,
    },
    /// Any symmetric 6×6 Voigt matrix in the lab frame.
    Voigt(Stiffness6),
}

/// Largest max-entry deviation |RᵀR − I| accepted for a cubic D's rotation.
const ROTATION_TOLERANCE: f64 = 1e-9;

impl LocalTensor {
    /// The lab-frame 6×6 Voigt matrix of D (order 11, 22, 33, 23, 13, 12; engineering
    /// strain). Refuses ([`Error::Model`]) a constant that is not finite, a rotation that is
    /// not proper, a zero axis, a Voigt matrix that is not symmetric. D need not be positive
    /// definite: the stability that matters is that of the pairwise tensor plus D.
    pub fn voigt(&self) -> Result<Stiffness6> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(Error::Model(format!(
                    "many-body tensor: {name} = {v}, expected a finite number (Pa)"
                )))
            }
        };
        match self {
            LocalTensor::Isotropic { bulk, shear } => {
                let (k, g) = (finite("bulk", *bulk)?, finite("shear", *shear)?);
                Ok(cubic_tensor(k + 4.0 * g / 3.0, k - 2.0 * g / 3.0, g))
            }
            LocalTensor::Cubic {
                c11,
                c12,
                c44,
                rotation,
            } => {
                let d = cubic_tensor(
                    finite("c11", *c11)?,
                    finite("c12", *c12)?,
                    finite("c44", *c44)?,
                );
                check_rotation(rotation)?;
                Ok(rotate(&d, &rotation.transpose()))
            }
            LocalTensor::TransverselyIsotropic {
                c11,
                c33,
                c13,
                c12,
                c44,
                axis,
            } => {
                let (c11, c33, c13, c12, c44) = (
                    finite("c11", *c11)?,
                    finite("c33", *c33)?,
                    finite("c13", *c13)?,
                    finite("c12", *c12)?,
                    finite("c44", *c44)?,
                );
                let d = transverse_tensor([c11, c33, c13, c12, c44], 0.5 * (c11 - c12));
                // Q takes the axis to e_z (lab → material frame): D_lab = rotate(D, Qᵀ).
                let q = rotation_to_z(axis)
                    .map_err(|e| Error::Model(format!("many-body tensor: {e}")))?;
                Ok(rotate(&d, &q.transpose()))
            }
            LocalTensor::Voigt(d) => {
                let scale = d.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                if d.iter().any(|v| !v.is_finite()) {
                    return Err(Error::Model(
                        "many-body tensor: the Voigt matrix has a non-finite entry".into(),
                    ));
                }
                for a in 0..6 {
                    for b in a + 1..6 {
                        if (d[(a, b)] - d[(b, a)]).abs() > 1e-12 * scale {
                            return Err(Error::Model(format!(
                                "many-body tensor: the Voigt matrix is not symmetric: D[{a}][{b}] \
                                 = {:e} but D[{b}][{a}] = {:e} (an energy's tensor is symmetric)",
                                d[(a, b)],
                                d[(b, a)]
                            )));
                        }
                    }
                }
                Ok((d + d.transpose()) * 0.5)
            }
        }
    }
}

/// Refuse a matrix that is not a proper rotation (|RᵀR − I| > 1e-9 or det ≤ 0).
fn check_rotation(r: &Mat3) -> Result<()> {
    let dev = (r.transpose() * r - Mat3::identity()).abs().max();
    let proper = dev <= ROTATION_TOLERANCE && r.determinant() > 0.0; // false for NaN too
    if !proper {
        return Err(Error::Model(format!(
            "many-body tensor: the cubic rotation is not a proper rotation (max |RᵀR − I| = \
             {dev:e}, det = {}); expected an orthogonal matrix with det +1 (re-orthonormalise a \
             printed matrix with tensor::orthonormalize_rotation)",
            r.determinant()
        )));
    }
    Ok(())
}

/// Which strain of the fitted gradient F_p the energy is of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StrainMeasure {
    /// Green–Lagrange E = ½(FᵀF − I): a rigid rotation has zero energy (what an integrator
    /// with large rotations needs); the Hessian depends on the state.
    #[default]
    GreenLagrange,
    /// Small strain ε = sym(F) − I: linear in positions, so the Hessian is constant; a rigid
    /// rotation by θ strains it by O(θ²) (not rotation invariant: for static, small-strain
    /// use only).
    Small,
}

/// What to do with a particle whose bonds cannot fit a strain (fewer than three, or all
/// (nearly) in one plane: A_p singular).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DegenerateParticles {
    /// Refuse ([`Error::Degenerate`] naming the first such particle).
    #[default]
    Refuse,
    /// Leave them out of the term (no energy, no force of their own; they still move the
    /// strains of their bonded neighbours). Their volume is not redistributed: the term adds
    /// (Σ_included V_p / V)·D ([`ManyBody::volume_fraction`]).
    Exclude,
}

/// How the term is built from a packing and its bonds.
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodyOptions {
    /// The strain measure.
    pub measure: StrainMeasure,
    /// Particles that cannot fit a strain.
    pub degenerate: DegenerateParticles,
    /// Smallest accepted λ_min/λ_max of A_p = Σ_b L_b ⊗ L_b (a particle below it is
    /// degenerate: its fit would amplify bond displacements by about 1/√ of this).
    pub conditioning: f64,
    /// V_p per particle (m³); `None`: the periodic cell's volume shared in proportion to
    /// the particles' r³ (Σ_p V_p = V, so the term adds D itself).
    pub volumes: Option<Vec<f64>>,
}

impl Default for ManyBodyOptions {
    fn default() -> Self {
        ManyBodyOptions {
            measure: StrainMeasure::default(),
            degenerate: DegenerateParticles::default(),
            conditioning: 1e-6,
            volumes: None,
        }
    }
}
