//! Model files (SPEC.md "Model"): which pairs are bonded, which stiffness scheme, and how a
//! magnitude becomes a spring constant. TOML, or JSON by extension.
//!
//! ```toml
//! [bonding]
//! rule = "gap"          # gap | factor | coordination
//! value = 0.17
//! [scheme]
//! kind = "cubic"        # cubic | cross-anisotropic | isotropic
//! model = "zener-above-1"
//! a_n = 4.31
//! a_s = 10.0
//! normal = 1.0e13
//! shear = 3.55e12
//! [geometry]
//! convention = "area"
//! ```

use crate::bonds::{BondSet, BondingRule};
use crate::packing::Packing;
use crate::schemes::cross_anisotropic::{self, CrossAnisotropic};
use crate::schemes::cubic::{self, CubicModel, CubicSpheroid};
use crate::schemes::isotropic::Isotropic;
use crate::schemes::{Convention, Geometry, StiffnessScheme};
use crate::{Error, Mat3, Result, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The scheme of a model with its parameters, validated.
#[derive(Clone, Debug, PartialEq)]
pub enum SchemeSpec {
    /// Cubic spheroid scheme (Truszkowska 2018, Eqs. 6–16).
    Cubic {
        /// Which family carries k_n and which k_s.
        model: CubicModel,
        /// Add the ±0.5·r<110> terms (Sec. 6.1).
        extended: bool,
        /// Aspect ratio of the normal-stiffness spheroids.
        a_n: f64,
        /// Aspect ratio of the shear-stiffness spheroids.
        a_s: f64,
        /// Normal magnitude (unit of the geometry convention).
        normal: f64,
        /// Shear magnitude.
        shear: f64,
        /// Crystal orientation R: functions are evaluated at R·n.
        rotation: Mat3,
    },
    /// Šmilauer's cross-anisotropic elliptic scheme, given by its target tensor.
    CrossAnisotropic {
        /// Target C11 (Pa).
        c11: f64,
        /// Target C33 (Pa).
        c33: f64,
        /// Target C13 (Pa).
        c13: f64,
        /// Target C12 (Pa).
        c12: f64,
        /// Unit symmetry axis (lab frame).
        axis: Vec3,
    },
    /// Constant magnitudes.
    Isotropic {
        /// Normal magnitude.
        normal: f64,
        /// Shear magnitude.
        shear: f64,
    },
}

/// A complete model: bonding rule, scheme and geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// Which pairs get a bond.
    pub bonding: BondingRule,
    /// The stiffness scheme.
    pub scheme: SchemeSpec,
    /// Magnitude → spring constant.
    pub geometry: Geometry,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    #[serde(default)]
    bonding: Option<RawBonding>,
    scheme: RawScheme,
    #[serde(default)]
    geometry: Option<Geometry>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawBonding {
    rule: String,
    value: f64,
}

#[derive(Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
struct RawScheme {
    kind: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    model: Option<CubicModel>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extended: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    a_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    a_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    normal: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    shear: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rotation: Option<[[f64; 3]; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    euler_zyz_deg: Option<[f64; 3]>,
    #[serde(rename = "C11", skip_serializing_if = "Option::is_none")]
    c11: Option<f64>,
    #[serde(rename = "C33", skip_serializing_if = "Option::is_none")]
    c33: Option<f64>,
    #[serde(rename = "C13", skip_serializing_if = "Option::is_none")]
    c13: Option<f64>,
    #[serde(rename = "C12", skip_serializing_if = "Option::is_none")]
    c12: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    axis: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    strike_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    dip_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pi_hat: Option<f64>,
}

/// 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())].matches('\n').count() + 1
}

fn need(v: Option<f64>, key: &str, kind: &str) -> Result<f64> {
    let x = v.ok_or_else(|| {
        Error::Model(format!(
            "[scheme] kind = \"{kind}\" needs `{key}` (a number)"
        ))
    })?;
    if !x.is_finite() {
        return Err(Error::Model(format!(
            "[scheme] {key} must be finite, got {x}"
        )));
    }
    Ok(x)
}

fn forbid(present: bool, key: &str, kind: &str) -> Result<()> {
    if present {
        return Err(Error::Model(format!(
            "[scheme] `{key}` does not apply to kind = \"{kind}\""
        )));
    }
    Ok(())
}

impl Model {
    /// Truszkowska 2018's MRV model (Sec. 5.1): zener-above-1, a_n = 4.31, a_s = 10.0,
    /// normal 1e13, shear 3.55e12 (PFC parallel-bond magnitudes, Pa/m, `area`
    /// convention), gap cutoff 0.17 R̄ (Eq. 4).
    pub fn truszkowska_mrv() -> Model {
        Model {
            bonding: BondingRule::Gap(0.17),
            scheme: SchemeSpec::Cubic {
                model: CubicModel::ZenerAbove1,
                extended: false,
                a_n: 4.31,
                a_s: 10.0,
                normal: 1.0e13,
                shear: 3.55e12,
                rotation: Mat3::identity(),
            },
            geometry: Geometry::default(),
        }
    }

    /// Read a model file: TOML, or JSON when the extension is `.json`.
    pub fn from_path(path: &Path) -> Result<Model> {
        let text = crate::io::read_to_string(path)?;
        let name = path.display().to_string();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            Model::from_json_str(&text, &name)
        } else {
            Model::from_toml_str(&text, &name)
        }
    }

    /// Parse a TOML model; `name` is used in error messages.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Model> {
        let raw: RawModel = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of(text, s.start)).unwrap_or(0);
            Error::parse(name, line, e.message().trim().to_string())
        })?;
        Model::from_raw(raw).map_err(|e| prefix(name, e))
    }

    /// Parse a JSON model; `name` is used in error messages.
    pub fn from_json_str(text: &str, name: &str) -> Result<Model> {
        let raw: RawModel =
            serde_json::from_str(text).map_err(|e| Error::parse(name, e.line(), e.to_string()))?;
        Model::from_raw(raw).map_err(|e| prefix(name, e))
    }

    fn from_raw(raw: RawModel) -> Result<Model> {
        let bonding = match raw.bonding {
            None => BondingRule::default(),
            Some(b) => {
                if !b.value.is_finite() || b.value < 0.0 {
                    return Err(Error::Model(format!(
                        "[bonding] value must be a finite number ≥ 0, got {}",
                        b.value
                    )));
                }
                match b.rule.as_str() {
                    "gap" => BondingRule::Gap(b.value),
                    "factor" => BondingRule::Factor(b.value),
                    "coordination" => BondingRule::Coordination(b.value),
                    other => {
                        return Err(Error::Model(format!(
                            "[bonding] rule = \"{other}\": expected gap, factor or coordination"
                        )))
                    }
                }
            }
        };
        let s = raw.scheme;
        let kind = s.kind.as_str();
        let scheme = match kind {
            "cubic" => {
                for (present, key) in [
                    (s.c11.is_some(), "C11"),
                    (s.c33.is_some(), "C33"),
                    (s.c13.is_some(), "C13"),
                    (s.c12.is_some(), "C12"),
                    (s.axis.is_some(), "axis"),
                    (s.strike_deg.is_some(), "strike_deg"),
                    (s.dip_deg.is_some(), "dip_deg"),
                ] {
                    forbid(present, key, kind)?;
                }
                let rotation = match (s.rotation, s.euler_zyz_deg) {
                    (Some(_), Some(_)) => {
                        return Err(Error::Model(
                            "[scheme] give either `rotation` or `euler_zyz_deg`, not both".into(),
                        ))
                    }
                    (Some(r), None) => {
                        let m = Mat3::from_fn(|i, j| r[i][j]);
                        cubic::orthonormalize_rotation(m)?
                    }
                    (None, Some(e)) => cubic::rotation_from_euler_zyz_deg(e[0], e[1], e[2]),
                    (None, None) => Mat3::identity(),
                };
                SchemeSpec::Cubic {
                    model: s.model.ok_or_else(|| {
                        Error::Model(
                            "[scheme] kind = \"cubic\" needs `model` = \"zener-above-1\" or \"zener-below-1\"".into(),
                        )
                    })?,
                    extended: s.extended.unwrap_or(false),
                    a_n: need(s.a_n, "a_n", kind)?,
                    a_s: need(s.a_s, "a_s", kind)?,
                    normal: need(s.normal, "normal", kind)?,
                    shear: need(s.shear, "shear", kind)?,
                    rotation,
                }
            }
            "cross-anisotropic" => {
                for (present, key) in [
                    (s.model.is_some(), "model"),
                    (s.extended.is_some(), "extended"),
                    (s.a_n.is_some(), "a_n"),
                    (s.a_s.is_some(), "a_s"),
                    (s.normal.is_some(), "normal"),
                    (s.shear.is_some(), "shear"),
                    (s.rotation.is_some(), "rotation"),
                    (s.euler_zyz_deg.is_some(), "euler_zyz_deg"),
                ] {
                    forbid(present, key, kind)?;
                }
                let axis = match (s.axis, s.strike_deg, s.dip_deg) {
                    (Some(a), None, None) => {
                        let v = Vec3::new(a[0], a[1], a[2]);
                        let n = v.norm();
                        if !n.is_finite() || n == 0.0 {
                            return Err(Error::Model(
                                "[scheme] axis must be a non-zero finite vector".into(),
                            ));
                        }
                        v / n
                    }
                    (None, Some(st), Some(dp)) => {
                        cross_anisotropic::axis_from_strike_dip(st, dp)
                    }
                    (None, None, None) => Vec3::z(),
                    _ => {
                        return Err(Error::Model(
                            "[scheme] give the axis either as `axis = [x, y, z]` or as both `strike_deg` and `dip_deg`".into(),
                        ))
                    }
                };
                SchemeSpec::CrossAnisotropic {
                    c11: need(s.c11, "C11", kind)?,
                    c33: need(s.c33, "C33", kind)?,
                    c13: need(s.c13, "C13", kind)?,
                    c12: need(s.c12, "C12", kind)?,
                    axis,
                }
            }
            "isotropic" => {
                for (present, key) in [
                    (s.model.is_some(), "model"),
                    (s.a_n.is_some(), "a_n"),
                    (s.a_s.is_some(), "a_s"),
                    (s.c11.is_some(), "C11"),
                    (s.axis.is_some(), "axis"),
                    (s.rotation.is_some(), "rotation"),
                ] {
                    forbid(present, key, kind)?;
                }
                SchemeSpec::Isotropic {
                    normal: need(s.normal, "normal", kind)?,
                    shear: need(s.shear, "shear", kind)?,
                }
            }
            other => {
                return Err(Error::Model(format!(
                    "[scheme] kind = \"{other}\": expected cubic, cross-anisotropic or isotropic"
                )))
            }
        };
        // Geometry: the cross-anisotropic scheme is defined with moduli (k = E'·A/l), the
        // others default to the PFC parallel-bond `area` convention.
        let mut geometry = match (&raw.geometry, &scheme) {
            (Some(g), _) => *g,
            (None, SchemeSpec::CrossAnisotropic { .. }) => Geometry {
                convention: Convention::Modulus,
                ..Geometry::default()
            },
            (None, _) => Geometry::default(),
        };
        if let Some(p) = s.pi_hat {
            if !matches!(scheme, SchemeSpec::CrossAnisotropic { .. }) {
                return Err(Error::Model(
                    "[scheme] pi_hat applies to cross-anisotropic only; use [geometry] pi_hat"
                        .into(),
                ));
            }
            geometry.pi_hat = p;
        }
        geometry.validate()?;
        if let SchemeSpec::CrossAnisotropic { .. } = scheme {
            if geometry.convention != Convention::Modulus {
                return Err(Error::Model(
                    "cross-anisotropic scheme needs [geometry] convention = \"modulus\" (k = E'·π̂r²/(2r'), Šmilauer)".into(),
                ));
            }
        }
        let model = Model {
            bonding,
            scheme,
            geometry,
        };
        // Validate the scheme parameters now (negative stiffness, a ≤ 0, …) where that
        // needs no packing.
        if !matches!(model.scheme, SchemeSpec::CrossAnisotropic { .. }) {
            model.build_scheme(None)?;
        }
        Ok(model)
    }

    /// True when the scheme needs the bonded packing to be built (cross-anisotropic: μ).
    pub fn needs_packing(&self) -> bool {
        matches!(self.scheme, SchemeSpec::CrossAnisotropic { .. })
    }

    /// Build the stiffness scheme. The cross-anisotropic scheme needs the bonded packing
    /// (for the lattice scaling μ, Šmilauer); the others ignore it.
    pub fn build_scheme(
        &self,
        bonded: Option<(&Packing, &BondSet)>,
    ) -> Result<Box<dyn StiffnessScheme>> {
        Ok(match &self.scheme {
            SchemeSpec::Cubic {
                model,
                extended,
                a_n,
                a_s,
                normal,
                shear,
                rotation,
            } => Box::new(CubicSpheroid::new(
                *model, *extended, *a_n, *a_s, *normal, *shear, *rotation,
            )?),
            SchemeSpec::Isotropic { normal, shear } => Box::new(Isotropic::new(*normal, *shear)?),
            SchemeSpec::CrossAnisotropic {
                c11,
                c33,
                c13,
                c12,
                axis,
            } => {
                let (packing, bonds) = bonded.ok_or_else(|| {
                    Error::Model(
                        "the cross-anisotropic scheme needs a bonded packing (its lattice scaling μ comes from the bonds)".into(),
                    )
                })?;
                let mu = cross_anisotropic::lattice_scaling(packing, bonds, self.geometry.pi_hat)?;
                Box::new(CrossAnisotropic::from_target(
                    *c11, *c33, *c13, *c12, *axis, mu,
                )?)
            }
        })
    }

    /// Serialise as TOML in the SPEC layout (used for calibrated models and exports).
    pub fn to_toml_string(&self) -> String {
        let (rule, value) = match self.bonding {
            BondingRule::Gap(v) => ("gap", v),
            BondingRule::Factor(v) => ("factor", v),
            BondingRule::Coordination(v) => ("coordination", v),
        };
        let mut s = RawScheme::default();
        match &self.scheme {
            SchemeSpec::Cubic {
                model,
                extended,
                a_n,
                a_s,
                normal,
                shear,
                rotation,
            } => {
                s.kind = "cubic".into();
                s.model = Some(*model);
                s.extended = Some(*extended);
                s.a_n = Some(*a_n);
                s.a_s = Some(*a_s);
                s.normal = Some(*normal);
                s.shear = Some(*shear);
                s.rotation = Some([0, 1, 2].map(|i| [0, 1, 2].map(|j| rotation[(i, j)])));
            }
            SchemeSpec::CrossAnisotropic {
                c11,
                c33,
                c13,
                c12,
                axis,
            } => {
                s.kind = "cross-anisotropic".into();
                s.c11 = Some(*c11);
                s.c33 = Some(*c33);
                s.c13 = Some(*c13);
                s.c12 = Some(*c12);
                s.axis = Some([axis.x, axis.y, axis.z]);
            }
            SchemeSpec::Isotropic { normal, shear } => {
                s.kind = "isotropic".into();
                s.normal = Some(*normal);
                s.shear = Some(*shear);
            }
        }
        let raw = RawModel {
            bonding: Some(RawBonding {
                rule: rule.into(),
                value,
            }),
            scheme: s,
            geometry: Some(self.geometry),
        };
        toml::to_string(&raw).unwrap_or_default()
    }
}

fn prefix(name: &str, e: Error) -> Error {
    match e {
        Error::Model(m) => Error::Model(format!("{name}: {m}")),
        other => other,
    }
}
