//! The `[strength]` table of a model file and the checked [`StrengthSpec`] it becomes
//! (docs/strength.md, "The model file").
//!
//! ```toml
//! [strength]
//! strike_deg = 30.0    # cross-anisotropic axis (or axis = [x, y, z]); z when omitted
//! dip_deg = 60.0
//! [strength.bond]      # the bonds' strength (across the axis when [strength.along] is given)
//! tensile = 5.0e6      # Pa
//! cohesion = 1.0e7     # Pa
//! friction = 0.5       # tan φ, optional (0); bending, twisting optional (tensile, cohesion)
//! [strength.along]     # cross-anisotropic: the strengths of a bond along the axis
//! tensile = 2.0e6
//! cohesion = 6.0e6
//! [[strength.planes]]  # planes of weakness (any number of families)
//! strike_deg = 30.0
//! dip_deg = 60.0
//! spacing = 2.0e-3     # m
//! tensile = 0.5e6
//! cohesion = 1.0e6
//! friction = 0.6
//! section = "cut"      # joint stresses on the bond's section cut by the plane (or "bond")
//! [strength.scatter]
//! distribution = "weibull"  # weibull (modulus) | normal (cv)
//! modulus = 5.0
//! seed = 1
//! ```

use super::schemes::{CrossStrength, CubicStrength, StrengthScheme};
use super::{JointSection, PlaneFamily, Scatter, Strength};
use crate::schemes::cross_anisotropic::axis_from_strike_dip;
use crate::schemes::cubic::{self, CubicModel};
use crate::tensor::unit_vector;
use crate::{Error, Mat3, Result, Vec3};
use serde::{Deserialize, Serialize};

/// A model's strength: the scheme by orientation, the planes of weakness (the first family
/// a bond crosses gives its joint strength) and the optional scatter.
#[derive(Clone, Debug, PartialEq)]
pub struct StrengthSpec {
    /// Strength by orientation.
    pub scheme: StrengthScheme,
    /// Plane-of-weakness families, in the order they are tried.
    pub planes: Vec<PlaneFamily>,
    /// Random scatter of the strengths, if any.
    pub scatter: Option<Scatter>,
}

impl StrengthSpec {
    /// An isotropic spec without planes or scatter (checked).
    pub fn isotropic(s: Strength) -> Result<StrengthSpec> {
        Ok(StrengthSpec {
            scheme: StrengthScheme::Isotropic(s).checked()?,
            planes: Vec::new(),
            scatter: None,
        })
    }

    /// The spec of a `[strength]` table, checked (see the module docs for the layout).
    pub fn from_table(t: &StrengthTable) -> Result<StrengthSpec> {
        let base = t.bond.values().checked("[strength.bond]")?;
        let axis = axis_of(t.axis, t.strike_deg, t.dip_deg, "[strength]")?;
        let scheme = match (&t.along, &t.cubic) {
            (Some(_), Some(_)) => {
                return Err(Error::Model(
                    "[strength]: give either [strength.along] (cross-anisotropic) or \
                     [strength.cubic], not both"
                        .into(),
                ))
            }
            (Some(along), None) => StrengthScheme::CrossAnisotropic(CrossStrength {
                along: along.values().checked("[strength.along]")?,
                across: base,
                axis: axis.unwrap_or_else(Vec3::z),
            }),
            (None, cubic) => {
                if axis.is_some() {
                    return Err(Error::Model(
                        "[strength]: an axis (axis or strike_deg/dip_deg) needs \
                         [strength.along], the strengths along it"
                            .into(),
                    ));
                }
                match cubic {
                    Some(c) => StrengthScheme::Cubic(CubicStrength {
                        model: c.model,
                        a_tensile: c.a_tensile,
                        a_shear: c.a_shear,
                        base,
                        rotation: c.rotation()?,
                    }),
                    None => StrengthScheme::Isotropic(base),
                }
            }
        };
        let planes = t
            .planes
            .iter()
            .enumerate()
            .map(|(k, p)| p.family(k))
            .collect::<Result<Vec<_>>>()?;
        let scatter = t.scatter.as_ref().map(ScatterTable::scatter).transpose()?;
        Ok(StrengthSpec {
            scheme: scheme.checked()?,
            planes,
            scatter,
        })
    }
}

impl StrengthSpec {
    /// Refuses, naming `what` (e.g. `export lammps`), a plane family whose joint stresses are
    /// taken on the cut section ([`JointSection::Cut`]): the engines have no plane criterion
    /// and judge a joint bond by their own law along the bond on its section π̂R_b², so the
    /// cut would be dropped without a word (docs/strength.md, "Planes of weakness").
    pub fn refuse_cut_sections(&self, what: &str) -> Result<()> {
        match self
            .planes
            .iter()
            .position(|p| p.section == JointSection::Cut)
        {
            Some(k) => Err(Error::Model(format!(
                "{what}: [[strength.planes]] #{} has section = \"cut\" (joint stresses on the \
                 bond's section cut by the plane); the engine has no plane criterion and would \
                 judge the joint bonds along the bond on their own section, so it cannot carry \
                 the cut: use section = \"bond\" or the integrator",
                k + 1
            ))),
            None => Ok(()),
        }
    }
}

/// Reads a `[strength]` table and checks it ([`StrengthSpec::from_table`]) as it is read,
/// so that a model file's refusal names the table's line (the model reader's
/// `deserialize_with` for its `strength` key).
pub fn checked_table<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<StrengthTable>, D::Error> {
    let table = StrengthTable::deserialize(d)?;
    match StrengthSpec::from_table(&table) {
        Ok(_) => Ok(Some(table)),
        Err(Error::Model(m)) => Err(serde::de::Error::custom(m)),
        Err(other) => Err(serde::de::Error::custom(other)),
    }
}

/// A unit axis from `axis` or from both `strike_deg` and `dip_deg`, or `None` when none is
/// given; refuses a mixture, a zero or non-finite axis and non-finite angles.
fn axis_of(
    axis: Option<[f64; 3]>,
    strike: Option<f64>,
    dip: Option<f64>,
    table: &str,
) -> Result<Option<Vec3>> {
    match (axis, strike, dip) {
        (None, None, None) => Ok(None),
        (Some(a), None, None) => {
            let unit = unit_vector(&Vec3::new(a[0], a[1], a[2])).ok_or_else(|| {
                Error::Model(format!(
                    "{table}: axis/normal {a:?} must be a finite non-zero vector"
                ))
            })?;
            Ok(Some(unit))
        }
        (None, Some(s), Some(d)) if s.is_finite() && d.is_finite() => {
            Ok(Some(axis_from_strike_dip(s, d)))
        }
        (None, Some(s), Some(d)) => Err(Error::Model(format!(
            "{table}: strike_deg = {s}, dip_deg = {d}: expected finite angles in degrees"
        ))),
        _ => Err(Error::Model(format!(
            "{table}: give the direction either as a vector or as both strike_deg and dip_deg"
        ))),
    }
}

/// Strength values of a table (`[strength.bond]`, `[strength.along]`): tensile and cohesion required, friction (0), bending
/// (= tensile) and twisting (= cohesion) optional.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StrengthValues {
    /// σ_t (Pa).
    pub tensile: f64,
    /// c (Pa).
    pub cohesion: f64,
    /// μ = tan φ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// σ_b (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bending: Option<f64>,
    /// τ_t (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twisting: Option<f64>,
}

impl StrengthValues {
    /// The strength, with friction 0, bending σ_t and twisting c when omitted.
    fn values(&self) -> Strength {
        Strength {
            tensile: self.tensile,
            cohesion: self.cohesion,
            friction: self.friction.unwrap_or(0.0),
            bending: self.bending.unwrap_or(self.tensile),
            twisting: self.twisting.unwrap_or(self.cohesion),
        }
    }
}

/// The `[strength]` table as written (see the module docs).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StrengthTable {
    /// Cross-anisotropic axis as a vector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Cross-anisotropic axis: strike (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strike_deg: Option<f64>,
    /// Cross-anisotropic axis: dip (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dip_deg: Option<f64>,
    /// `[strength.bond]`: the bonds' strength (across the axis when `along` is given).
    pub bond: StrengthValues,
    /// `[strength.along]`: strengths along the axis (makes the scheme cross-anisotropic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub along: Option<StrengthValues>,
    /// Cubic scaling (makes the scheme cubic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cubic: Option<CubicTable>,
    /// Plane-of-weakness families.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<PlaneTable>,
    /// Scatter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scatter: Option<ScatterTable>,
}

/// `[strength.cubic]`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CubicTable {
    /// `zener-above-1` or `zener-below-1` (which families scale which strengths).
    pub model: CubicModel,
    /// Aspect ratio of the tensile/bending spheroids.
    pub a_tensile: f64,
    /// Aspect ratio of the cohesion/twisting spheroids.
    pub a_shear: f64,
    /// Lab → crystal rotation (rows), re-orthonormalised when printed to a few decimals.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[[f64; 3]; 3]>,
    /// Euler angles ZYZ in degrees (as the cubic stiffness scheme's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub euler_zyz_deg: Option<[f64; 3]>,
}

impl CubicTable {
    fn rotation(&self) -> Result<Mat3> {
        match (self.rotation, self.euler_zyz_deg) {
            (Some(_), Some(_)) => Err(Error::Model(
                "[strength.cubic]: give either rotation or euler_zyz_deg, not both".into(),
            )),
            (Some(r), None) => cubic::orthonormalize_rotation(Mat3::from_fn(|i, j| r[i][j]))
                .map_err(|e| Error::Model(format!("[strength.cubic] rotation: {e}"))),
            (None, Some(e)) if e.iter().all(|x| x.is_finite()) => {
                Ok(cubic::rotation_from_euler_zyz_deg(e[0], e[1], e[2]))
            }
            (None, Some(e)) => Err(Error::Model(format!(
                "[strength.cubic] euler_zyz_deg = {e:?}: expected finite angles in degrees"
            ))),
            (None, None) => Ok(Mat3::identity()),
        }
    }
}

/// One `[[strength.planes]]` family.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneTable {
    /// Plane normal as a vector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Strike (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strike_deg: Option<f64>,
    /// Dip (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dip_deg: Option<f64>,
    /// Distance between planes (m).
    pub spacing: f64,
    /// Position of plane 0 along the normal (m), 0 when omitted.
    #[serde(default)]
    pub offset: f64,
    /// Joint tensile strength (Pa).
    pub tensile: f64,
    /// Joint cohesion c_w (Pa).
    pub cohesion: f64,
    /// Joint friction μ_w = tan φ_w (0 when omitted).
    #[serde(default)]
    pub friction: f64,
    /// The area the joint's stresses are taken on: `bond` (the bond's section, when
    /// omitted) or `cut` (that section cut by the plane).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section: Option<JointSection>,
}

impl PlaneTable {
    fn family(&self, k: usize) -> Result<PlaneFamily> {
        let table = format!("[[strength.planes]] #{}", k + 1);
        let normal =
            axis_of(self.normal, self.strike_deg, self.dip_deg, &table)?.ok_or_else(|| {
                Error::Model(format!(
                    "{table}: give the plane normal (normal = [x, y, z]) or strike_deg and dip_deg"
                ))
            })?;
        let joint = Strength {
            friction: self.friction,
            ..Strength::new(self.tensile, self.cohesion)
        };
        PlaneFamily::new(normal, self.spacing, self.offset, joint)
            .map(|f| f.with_section(self.section.unwrap_or_default()))
            .map_err(|e| match e {
                Error::Model(m) => Error::Model(format!("{table}: {m}")),
                other => other,
            })
    }
}

/// `[strength.scatter]`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ScatterTable {
    /// `weibull` or `normal`.
    pub distribution: String,
    /// Weibull modulus (weibull only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modulus: Option<f64>,
    /// Coefficient of variation (normal only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cv: Option<f64>,
    /// Seed of the generator.
    pub seed: u64,
}

impl ScatterTable {
    fn scatter(&self) -> Result<Scatter> {
        let seed = self.seed;
        let s =
            match (self.distribution.as_str(), self.modulus, self.cv) {
                ("weibull", Some(modulus), None) => Scatter::Weibull { modulus, seed },
                ("normal", None, Some(cv)) => Scatter::Normal { cv, seed },
                ("weibull", _, _) => return Err(Error::Model(
                    "[strength.scatter] distribution = \"weibull\" takes `modulus` (and not `cv`)"
                        .into(),
                )),
                ("normal", _, _) => return Err(Error::Model(
                    "[strength.scatter] distribution = \"normal\" takes `cv` (and not `modulus`)"
                        .into(),
                )),
                (other, _, _) => {
                    return Err(Error::Model(format!(
                        "[strength.scatter] distribution = {other:?}: expected weibull or normal"
                    )))
                }
            };
        s.checked()
    }
}
