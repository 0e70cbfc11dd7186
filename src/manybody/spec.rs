//! `[manybody]` of a model file (docs/manybody.md): the tensor D by its symmetry (one table
//! layout per kind), the strain measure and what to do with particles that cannot fit a
//! strain. Read and checked with the model, written back with it.

use super::{DegenerateParticles, LocalTensor, ManyBody, ManyBodyOptions, StrainMeasure};
use crate::bonds::BondSet;
use crate::grains::Grains;
use crate::packing::Packing;
use crate::tensor::{rotate, Stiffness6};
use crate::{Error, Mat3, Result, Vec3};
use serde::{Deserialize, Serialize};

/// The many-body term of a model: D (lab frame, its rotation or axis resolved against the
/// scheme's when the file leaves it out), the strain measure and the degenerate-particle
/// rule. `ManyBodySpec::build` makes the term of a bonded packing.
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodySpec {
    /// The tensor D a particle's local strain loads (Pa).
    pub tensor: LocalTensor,
    /// Green–Lagrange (default; rotation invariant, what the integrator needs) or small.
    pub measure: StrainMeasure,
    /// Particles with fewer than three non-coplanar bonds (rattlers of a random packing):
    /// excluded by default in a model file, so a gap-bonded packing can carry the term; the
    /// term then adds (Σ_included V_p / V)·D ([`ManyBody::volume_fraction`]).
    pub degenerate: DegenerateParticles,
}

impl ManyBodySpec {
    /// The options [`ManyBody::new`] takes (default conditioning, default volumes).
    pub fn options(&self) -> ManyBodyOptions {
        ManyBodyOptions {
            measure: self.measure,
            degenerate: self.degenerate,
            ..ManyBodyOptions::default()
        }
    }

    /// The term of `bonds` on `packing` (their reference state), as [`ManyBody::new`].
    pub fn build(&self, packing: &Packing, bonds: &BondSet) -> Result<ManyBody> {
        ManyBody::new(packing, bonds, &self.tensor, &self.options())
    }

    /// The term of `bonds` on `packing` with `grains` (a polycrystal, docs/polycrystal.md):
    /// particle p loads its grain's D, the lab tensor turned into the grain,
    /// D_g = rotate(D, gᵀ) (g the Bunge matrix, lab → crystal; the sense of the springs'
    /// magnitudes(g·n), the grain's turn first and the spec's own rotation after it). An
    /// identity grain keeps D as it is (bit for bit the single crystal). `None`: [`build`](Self::build).
    pub fn build_with_grains(
        &self,
        packing: &Packing,
        bonds: &BondSet,
        grains: Option<&Grains>,
    ) -> Result<ManyBody> {
        let Some(grains) = grains else {
            return self.build(packing, bonds);
        };
        if grains.grain.len() != packing.len() {
            return Err(Error::Invalid(format!(
                "many-body term by grain: the grain map has {} particles, the packing {}",
                grains.grain.len(),
                packing.len()
            )));
        }
        let tensors = self.grain_tensors(grains)?;
        ManyBody::per_particle(
            packing,
            bonds,
            tensors,
            grains.grain.clone(),
            &self.options(),
        )
    }

    /// Each grain's lab-frame D (Pa): rotate(D, gᵀ) of the spec's lab D, D itself for an
    /// identity orientation.
    pub fn grain_tensors(&self, grains: &Grains) -> Result<Vec<Stiffness6>> {
        let d = self.voigt()?;
        Ok(grains
            .orientation
            .iter()
            .map(|g| {
                if *g == Mat3::identity() {
                    d
                } else {
                    rotate(&d, &g.transpose())
                }
            })
            .collect())
    }

    /// D's lab-frame Voigt matrix (Pa), checked ([`LocalTensor::voigt`]).
    pub fn voigt(&self) -> Result<Stiffness6> {
        self.tensor.voigt()
    }

    /// The spec of a parsed table: `rotation` of a cubic D defaults to `scheme_rotation`
    /// (the cubic scheme's crystal frame, so D turns with the crystal), `axis` of a
    /// transversely isotropic D to `scheme_axis` (the cross-anisotropic scheme's axis).
    pub(crate) fn from_raw(
        raw: &RawManyBody,
        scheme_rotation: Mat3,
        scheme_axis: Vec3,
    ) -> Result<ManyBodySpec> {
        let (measure, degenerate) = raw.common();
        let tensor = match raw {
            RawManyBody::Isotropic { bulk, shear, .. } => LocalTensor::Isotropic {
                bulk: *bulk,
                shear: *shear,
            },
            RawManyBody::Cubic {
                c11,
                c12,
                c44,
                rotation,
                euler_zyz_deg,
                ..
            } => {
                let rotation = match (rotation, euler_zyz_deg) {
                    (Some(_), Some(_)) => {
                        return Err(Error::Model(
                            "[manybody] give either `rotation` or `euler_zyz_deg`, not both".into(),
                        ))
                    }
                    (Some(r), None) => Mat3::from_fn(|i, j| r[i][j]),
                    (None, Some(e)) => {
                        if e.iter().any(|v| !v.is_finite()) {
                            return Err(Error::Model(format!(
                                "[manybody] euler_zyz_deg = {e:?}: expected finite angles (°)"
                            )));
                        }
                        crate::schemes::cubic::rotation_from_euler_zyz_deg(e[0], e[1], e[2])
                    }
                    (None, None) => scheme_rotation,
                };
                LocalTensor::Cubic {
                    c11: *c11,
                    c12: *c12,
                    c44: *c44,
                    rotation,
                }
            }
            RawManyBody::TransverselyIsotropic {
                c11,
                c33,
                c13,
                c12,
                c44,
                axis,
                ..
            } => LocalTensor::TransverselyIsotropic {
                c11: *c11,
                c33: *c33,
                c13: *c13,
                c12: *c12,
                c44: *c44,
                axis: axis.map_or(scheme_axis, |a| Vec3::new(a[0], a[1], a[2])),
            },
            RawManyBody::Voigt { matrix, .. } => {
                LocalTensor::Voigt(Stiffness6::from_fn(|i, j| matrix[i][j]))
            }
        };
        let spec = ManyBodySpec {
            tensor,
            measure: match measure {
                None | Some(RawMeasure::GreenLagrange) => StrainMeasure::GreenLagrange,
                Some(RawMeasure::Small) => StrainMeasure::Small,
            },
            degenerate: match degenerate {
                None | Some(RawDegenerate::Exclude) => DegenerateParticles::Exclude,
                Some(RawDegenerate::Refuse) => DegenerateParticles::Refuse,
            },
        };
        spec.voigt().map_err(|e| match e {
            Error::Model(m) => Error::Model(format!("[manybody] {m}")),
            other => other,
        })?;
        Ok(spec)
    }

    /// The table as written back (rotation and axis explicit, so it reads back identically).
    pub(crate) fn to_raw(&self) -> RawManyBody {
        let measure = Some(match self.measure {
            StrainMeasure::GreenLagrange => RawMeasure::GreenLagrange,
            StrainMeasure::Small => RawMeasure::Small,
        });
        let degenerate = Some(match self.degenerate {
            DegenerateParticles::Exclude => RawDegenerate::Exclude,
            DegenerateParticles::Refuse => RawDegenerate::Refuse,
        });
        match &self.tensor {
            LocalTensor::Isotropic { bulk, shear } => RawManyBody::Isotropic {
                bulk: *bulk,
                shear: *shear,
                measure,
                degenerate,
            },
            LocalTensor::Cubic {
                c11,
                c12,
                c44,
                rotation,
            } => RawManyBody::Cubic {
                c11: *c11,
                c12: *c12,
                c44: *c44,
                rotation: Some([0, 1, 2].map(|i| [0, 1, 2].map(|j| rotation[(i, j)]))),
                euler_zyz_deg: None,
                measure,
                degenerate,
            },
            LocalTensor::TransverselyIsotropic {
                c11,
                c33,
                c13,
                c12,
                c44,
                axis,
            } => RawManyBody::TransverselyIsotropic {
                c11: *c11,
                c33: *c33,
                c13: *c13,
                c12: *c12,
                c44: *c44,
                axis: Some([axis.x, axis.y, axis.z]),
                measure,
                degenerate,
            },
            LocalTensor::Voigt(d) => RawManyBody::Voigt {
                matrix: [0, 1, 2, 3, 4, 5].map(|i| [0, 1, 2, 3, 4, 5].map(|j| d[(i, j)])),
                measure,
                degenerate,
            },
        }
    }
}

/// `measure = "green-lagrange" | "small"`.
#[derive(Clone, Copy, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RawMeasure {
    GreenLagrange,
    Small,
}

/// `degenerate = "exclude" | "refuse"`.
#[derive(Clone, Copy, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RawDegenerate {
    Exclude,
    Refuse,
}

impl RawManyBody {
    /// The measure and degenerate rule, as written (any kind).
    fn common(&self) -> (Option<RawMeasure>, Option<RawDegenerate>) {
        match self {
            RawManyBody::Isotropic {
                measure,
                degenerate,
                ..
            }
            | RawManyBody::Cubic {
                measure,
                degenerate,
                ..
            }
            | RawManyBody::TransverselyIsotropic {
                measure,
                degenerate,
                ..
            }
            | RawManyBody::Voigt {
                measure,
                degenerate,
                ..
            } => (*measure, *degenerate),
        }
    }
}

/// `[manybody]` as written: `kind` selects the layout of the other keys.
#[derive(Clone, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub(crate) enum RawManyBody {
    /// `kind = "isotropic"`: `bulk`, `shear` (Pa); `shear = 0` is purely volumetric.
    Isotropic {
        bulk: f64,
        shear: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measure: Option<RawMeasure>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        degenerate: Option<RawDegenerate>,
    },
    /// `kind = "cubic"`: `c11`, `c12`, `c44` (Pa) in the crystal frame; `rotation` or
    /// `euler_zyz_deg` (default: the cubic scheme's).
    Cubic {
        c11: f64,
        c12: f64,
        c44: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        rotation: Option<[[f64; 3]; 3]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        euler_zyz_deg: Option<[f64; 3]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measure: Option<RawMeasure>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        degenerate: Option<RawDegenerate>,
    },
    /// `kind = "transversely-isotropic"`: five constants (Pa) with the axis along 3;
    /// `axis` (default: the cross-anisotropic scheme's, else z).
    TransverselyIsotropic {
        c11: f64,
        c33: f64,
        c13: f64,
        c12: f64,
        c44: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        axis: Option<[f64; 3]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measure: Option<RawMeasure>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        degenerate: Option<RawDegenerate>,
    },
    /// `kind = "voigt"`: `matrix`, a symmetric 6×6 (Pa; order 11 22 33 23 13 12).
    Voigt {
        matrix: [[f64; 6]; 6],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measure: Option<RawMeasure>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        degenerate: Option<RawDegenerate>,
    },
}
