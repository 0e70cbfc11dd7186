//! Model files (docs/formats.md "Model"): which pairs are bonded, which stiffness scheme, how a
//! magnitude becomes a spring constant, and optionally a strength (`[strength]`), a many-body
//! term (`[manybody]`) or grains (`[grains]`, a polycrystal: docs/polycrystal.md). TOML, or
//! JSON by extension.
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
//!
//! Each `kind` takes only its own keys: a key of another kind (say `euler_zyz_deg` under
//! `isotropic`) is an error naming the key and its line, never silently ignored. Numbers
//! must be finite and admissible (a cross-anisotropic target positive definite) when read.

use crate::bonds::{BondSet, BondingRule};
use crate::keys;
use crate::names::Named;
use crate::packing::Packing;
use crate::schemes::cross_anisotropic::{self, CrossAnisotropic};
use crate::schemes::cubic::{self, CubicModel, CubicSpheroid};
use crate::schemes::isotropic::Isotropic;
use crate::schemes::{Convention, Geometry, SchemeKind, StiffnessScheme};
use crate::{Error, Mat3, Result, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The scheme of a model with its parameters, validated.
#[derive(Clone, Debug, PartialEq)]
pub enum SchemeSpec {
    /// Cubic spheroid scheme (Truszkowska 2018, Eqs. 6–16), as read: its parameters are
    /// checked when the scheme is built ([`CubicSpheroid::checked`]).
    Cubic(CubicSpheroid),
    /// Šmilauer's cross-anisotropic elliptic scheme, given by its target tensor.
    CrossAnisotropic(CrossTarget),
    /// Constant magnitudes.
    Isotropic {
        /// Normal magnitude.
        normal: f64,
        /// Shear magnitude.
        shear: f64,
    },
}

impl SchemeSpec {
    /// The scheme's kind.
    pub fn kind(&self) -> SchemeKind {
        match self {
            SchemeSpec::Cubic(_) => SchemeKind::Cubic,
            SchemeSpec::CrossAnisotropic(_) => SchemeKind::CrossAnisotropic,
            SchemeSpec::Isotropic { .. } => SchemeKind::Isotropic,
        }
    }

    /// The scheme's `kind` in the model file: `cubic`, `cross-anisotropic` or `isotropic`.
    pub fn kind_name(&self) -> &'static str {
        self.kind().name()
    }
}

/// The target of Šmilauer's cross-anisotropic elliptic scheme: the transversely isotropic
/// tensor (Pa) about `axis` that the scheme is made to reproduce.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossTarget {
    /// Target C11 (Pa).
    pub c11: f64,
    /// Target C33 (Pa).
    pub c33: f64,
    /// Target C13 (Pa).
    pub c13: f64,
    /// Target C12 (Pa).
    pub c12: f64,
    /// Unit symmetry axis (lab frame).
    pub axis: Vec3,
}

impl CrossTarget {
    /// The scheme for this target with lattice scaling μ ([`CrossAnisotropic::from_target`]).
    pub fn scheme(&self, mu: f64) -> Result<CrossAnisotropic> {
        CrossAnisotropic::from_target(self.c11, self.c33, self.c13, self.c12, self.axis, mu)
    }
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
    /// The `[strength]` table as read (checked; docs/strength.md), written back unchanged
    /// with the model ([`Model::to_toml_string`]); `None` when the file has none.
    pub strength: Option<crate::strength::spec::StrengthTable>,
    /// The `[manybody]` term (docs/manybody.md), its rotation or axis resolved against the
    /// scheme's; `None` when the file has none (pairwise bonds only).
    pub manybody: Option<crate::manybody::ManyBodySpec>,
    /// The `[grains]` table (docs/polycrystal.md): a polycrystal, each grain the scheme turned
    /// into its own orientation; `None` when the file has none (one crystal).
    pub grains: Option<crate::grains::GrainsSpec>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    #[serde(default)]
    bonding: Option<RawBonding>,
    scheme: RawScheme,
    #[serde(default)]
    geometry: Option<Geometry>,
    /// `[strength]` (src/strength, docs/strength.md): checked as it is read, carried by
    /// [`Model::strength`] and returned as a spec by [`Model::strength_from_str_for`].
    #[serde(
        default,
        deserialize_with = "crate::strength::spec::checked_table",
        skip_serializing_if = "Option::is_none"
    )]
    strength: Option<crate::strength::spec::StrengthTable>,
    /// `[manybody]` (src/manybody/spec.rs, docs/manybody.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    manybody: Option<crate::manybody::spec::RawManyBody>,
    /// `[grains]` (src/grains/spec.rs, docs/polycrystal.md), checked as it is read; its file
    /// paths resolved against the model file's folder by `Model::from_raw`.
    #[serde(
        default,
        deserialize_with = "crate::grains::spec::checked",
        skip_serializing_if = "Option::is_none"
    )]
    grains: Option<crate::grains::spec::RawGrains>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawBonding {
    #[serde(deserialize_with = "keys::rule")]
    rule: String,
    #[serde(deserialize_with = "keys::value")]
    value: f64,
}

/// The `[scheme]` table, one type per `kind`: each variant refuses the keys of the other
/// kinds by name (`deny_unknown_fields`), so no key is silently ignored. Every value is read
/// by [`crate::keys`], whose refusals name the key.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
enum RawScheme {
    Cubic(RawCubic),
    CrossAnisotropic(RawCross),
    Isotropic(RawIsotropic),
}

/// `kind = "cubic"`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCubic {
    #[serde(deserialize_with = "keys::model")]
    model: CubicModel,
    #[serde(default, deserialize_with = "keys::extended")]
    extended: bool,
    #[serde(deserialize_with = "keys::a_n")]
    a_n: f64,
    #[serde(deserialize_with = "keys::a_s")]
    a_s: f64,
    #[serde(deserialize_with = "keys::normal")]
    normal: f64,
    #[serde(deserialize_with = "keys::shear")]
    shear: f64,
    #[serde(
        default,
        deserialize_with = "keys::rotation",
        skip_serializing_if = "Option::is_none"
    )]
    rotation: Option<[[f64; 3]; 3]>,
    #[serde(
        default,
        deserialize_with = "keys::euler_zyz_deg",
        skip_serializing_if = "Option::is_none"
    )]
    euler_zyz_deg: Option<[f64; 3]>,
}

/// `kind = "cross-anisotropic"`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCross {
    #[serde(rename = "C11", deserialize_with = "keys::c11")]
    c11: f64,
    #[serde(rename = "C33", deserialize_with = "keys::c33")]
    c33: f64,
    #[serde(rename = "C13", deserialize_with = "keys::c13")]
    c13: f64,
    #[serde(rename = "C12", deserialize_with = "keys::c12")]
    c12: f64,
    #[serde(
        default,
        deserialize_with = "keys::axis",
        skip_serializing_if = "Option::is_none"
    )]
    axis: Option<[f64; 3]>,
    #[serde(
        default,
        deserialize_with = "keys::strike_deg",
        skip_serializing_if = "Option::is_none"
    )]
    strike_deg: Option<f64>,
    #[serde(
        default,
        deserialize_with = "keys::dip_deg",
        skip_serializing_if = "Option::is_none"
    )]
    dip_deg: Option<f64>,
    #[serde(
        default,
        deserialize_with = "keys::pi_hat",
        skip_serializing_if = "Option::is_none"
    )]
    pi_hat: Option<f64>,
}

/// `kind = "isotropic"`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawIsotropic {
    #[serde(deserialize_with = "keys::normal")]
    normal: f64,
    #[serde(deserialize_with = "keys::shear")]
    shear: f64,
}

impl RawBonding {
    /// The bonding rule; refuses a value that is not finite and > 0 and an unknown rule.
    fn rule(&self) -> Result<BondingRule> {
        if !self.value.is_finite() || self.value <= 0.0 {
            return Err(Error::Model(format!(
                "[bonding] value must be a finite number > 0, got {}",
                self.value
            )));
        }
        match self.rule.as_str() {
            "gap" => Ok(BondingRule::Gap(self.value)),
            "factor" => Ok(BondingRule::Factor(self.value)),
            "coordination" => Ok(BondingRule::Coordination(self.value)),
            other => Err(Error::Model(format!(
                "[bonding] rule = \"{other}\": expected gap, factor or coordination"
            ))),
        }
    }
}

impl RawCubic {
    /// The cubic scheme (Truszkowska 2018), its parameters finite.
    fn scheme(&self) -> Result<SchemeSpec> {
        let rotation = self.rotation()?;
        Ok(SchemeSpec::Cubic(CubicSpheroid {
            model: self.model,
            extended: self.extended,
            a_n: finite(self.a_n, "a_n")?,
            a_s: finite(self.a_s, "a_s")?,
            normal: finite(self.normal, "normal")?,
            shear: finite(self.shear, "shear")?,
            rotation,
        }))
    }

    /// The crystal rotation, from `rotation` or `euler_zyz_deg` (not both; neither: none).
    fn rotation(&self) -> Result<Mat3> {
        match (self.rotation, self.euler_zyz_deg) {
            (Some(_), Some(_)) => Err(Error::Model(
                "[scheme] give either `rotation` or `euler_zyz_deg`, not both".into(),
            )),
            (Some(r), None) => {
                let m = Mat3::from_fn(|i, j| r[i][j]);
                // A rotation to rounding (as written by to_toml_string) is kept bit for
                // bit, so a written model reads back identically; a matrix printed to a
                // few decimals is re-orthonormalised.
                let exact = m.iter().all(|x| x.is_finite())
                    && (m.transpose() * m - Mat3::identity()).amax() <= 1e-12
                    && m.determinant() > 0.0;
                if exact {
                    Ok(m)
                } else {
                    cubic::orthonormalize_rotation(m)
                }
            }
            (None, Some(e)) => {
                for v in e {
                    finite(v, "euler_zyz_deg")?;
                }
                Ok(cubic::rotation_from_euler_zyz_deg(e[0], e[1], e[2]))
            }
            (None, None) => Ok(Mat3::identity()),
        }
    }
}

impl RawCross {
    /// The cross-anisotropic target (Šmilauer), checked positive definite with non-negative
    /// lattice moduli: that does not depend on the lattice scaling μ > 0 (E′ = A⁻¹C/μ,
    /// Šmilauer Eq. 22), so it is checked here with μ = 1, before any packing is read.
    fn target(&self) -> Result<CrossTarget> {
        let axis = self.axis()?;
        let target = CrossTarget {
            c11: finite(self.c11, "C11")?,
            c33: finite(self.c33, "C33")?,
            c13: finite(self.c13, "C13")?,
            c12: finite(self.c12, "C12")?,
            axis,
        };
        target.scheme(1.0)?;
        Ok(target)
    }

    /// The symmetry axis, from `axis` or from both `strike_deg` and `dip_deg` (neither: z).
    fn axis(&self) -> Result<Vec3> {
        match (self.axis, self.strike_deg, self.dip_deg) {
            (Some(a), None, None) => {
                let v = Vec3::new(a[0], a[1], a[2]);
                let n = v.norm();
                if !n.is_finite() || n == 0.0 {
                    return Err(Error::Model(
                        "[scheme] axis must be a non-zero finite vector".into(),
                    ));
                }
                // A unit vector to rounding (as written) is kept bit for bit, so a
                // written model reads back identically.
                if (n - 1.0).abs() <= 4.0 * f64::EPSILON {
                    Ok(v)
                } else {
                    Ok(v / n)
                }
            }
            (None, Some(st), Some(dp)) => Ok(cross_anisotropic::axis_from_strike_dip(
                finite(st, "strike_deg")?,
                finite(dp, "dip_deg")?,
            )),
            (None, None, None) => Ok(Vec3::z()),
            _ => Err(Error::Model(
                "[scheme] give the axis either as `axis = [x, y, z]` or as both `strike_deg` and `dip_deg`".into(),
            )),
        }
    }
}

/// The model's geometry: the file's `[geometry]`, or by default moduli (k = E'·A/l) for the
/// cross-anisotropic scheme and the PFC parallel-bond `area` convention for the others;
/// a cross-anisotropic `pi_hat` overrides π̂. Refuses an invalid geometry and a
/// cross-anisotropic scheme without the modulus convention.
fn model_geometry(
    raw: Option<Geometry>,
    scheme: &SchemeSpec,
    pi_hat: Option<f64>,
) -> Result<Geometry> {
    let mut geometry = match (&raw, scheme) {
        (Some(g), _) => *g,
        (None, SchemeSpec::CrossAnisotropic(_)) => Geometry {
            convention: Convention::Modulus,
            ..Geometry::default()
        },
        (None, _) => Geometry::default(),
    };
    if let Some(p) = pi_hat {
        if !p.is_finite() || p <= 0.0 {
            return Err(Error::Model(format!(
                "[scheme] pi_hat must be finite and > 0, got {p}"
            )));
        }
        geometry.pi_hat = p;
    }
    geometry.validate()?;
    if let SchemeSpec::CrossAnisotropic(_) = scheme {
        if geometry.convention != Convention::Modulus {
            return Err(Error::Model(
                "cross-anisotropic scheme needs [geometry] convention = \"modulus\" (k = E'·π̂r²/(2r'), Šmilauer)".into(),
            ));
        }
    }
    Ok(geometry)
}

/// `[scheme] kind = "other": expected cubic, …` (the kinds of [`SchemeKind`]).
fn unknown_kind<E: serde::de::Error>(other: impl std::fmt::Display) -> E {
    E::custom(format!(
        "[scheme] kind = {other}: expected {}",
        SchemeKind::expected()
    ))
}

impl<'de> Deserialize<'de> for RawScheme {
    /// Reads `kind` and then the rest of the table straight into that kind's struct, so a
    /// wrong or foreign key is reported at its own line. When `kind` is not the first key
    /// the table is buffered first (errors then point at the table).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_map(SchemeVisitor)
    }
}

struct SchemeVisitor;

/// A `kind` value, refused at its own position when it is not one of the kinds.
struct KindName(SchemeKind);

impl<'de> Deserialize<'de> for KindName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let kind: String = keys::read(d, "kind")?;
        SchemeKind::from_name(&kind)
            .map(KindName)
            .map_err(|_| unknown_kind(format!("{kind:?}")))
    }
}

impl SchemeVisitor {
    fn variant<'de, D: serde::Deserializer<'de>>(
        kind: SchemeKind,
        rest: D,
    ) -> std::result::Result<RawScheme, D::Error> {
        Ok(match kind {
            SchemeKind::Cubic => RawScheme::Cubic(RawCubic::deserialize(rest)?),
            SchemeKind::CrossAnisotropic => {
                RawScheme::CrossAnisotropic(RawCross::deserialize(rest)?)
            }
            SchemeKind::Isotropic => RawScheme::Isotropic(RawIsotropic::deserialize(rest)?),
        })
    }
}

impl<'de> serde::de::Visitor<'de> for SchemeVisitor {
    type Value = RawScheme;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "a [scheme] table with kind = {}", SchemeKind::expected())
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(
        self,
        mut map: A,
    ) -> std::result::Result<RawScheme, A::Error> {
        use serde::de::Error as _;
        let first: Option<String> = map.next_key()?;
        match first.as_deref() {
            None => Err(A::Error::missing_field("kind")),
            Some("kind") => {
                let kind: KindName = map.next_value()?;
                Self::variant(kind.0, serde::de::value::MapAccessDeserializer::new(map))
            }
            Some(key) => {
                // `kind` comes later: buffer the table, then read it as that kind.
                let mut table = serde_json::Map::new();
                let value: serde_json::Value = map.next_value()?;
                table.insert(key.to_string(), value);
                while let Some((k, v)) = map.next_entry::<String, serde_json::Value>()? {
                    table.insert(k, v);
                }
                let kind = match table.remove("kind") {
                    Some(serde_json::Value::String(s)) => SchemeKind::from_name(&s)
                        .map_err(|_| unknown_kind::<A::Error>(format!("{s:?}")))?,
                    Some(other) => {
                        return Err(A::Error::custom(format!(
                            "[scheme] kind = {other}: expected {} (a string)",
                            SchemeKind::expected()
                        )))
                    }
                    None => return Err(A::Error::missing_field("kind")),
                };
                // The kind is known: what is refused now is a key or value of the table.
                Self::variant(kind, serde_json::Value::Object(table))
                    .map_err(|e| A::Error::custom(format!("[scheme] {e}")))
            }
        }
    }
}

/// 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())].matches('\n').count() + 1
}

/// `text` without a leading UTF-8 BOM and with each lone `\r` (classic Mac line end) made a
/// `\n`: same byte offsets, so parser positions still map to the lines an editor shows.
fn normalized(text: &str) -> String {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\r' && chars.peek() != Some(&'\n') {
            out.push('\n');
        } else {
            out.push(c);
        }
    }
    out
}

/// A TOML error as `file:line: message`: the line from the error's span, the message the
/// parser's or, for a value, the one [`crate::keys`] made naming its key. A message left
/// empty (a lone control character) is replaced by what was expected there.
fn toml_error(text: &str, name: &str, e: &toml::de::Error) -> Error {
    let span = e.span();
    let line = span.as_ref().map(|s| line_of(text, s.start)).unwrap_or(0);
    let mut message = e.message().trim().replace('\n', "; ");
    if message.is_empty() {
        let c = span
            .as_ref()
            .and_then(|s| text.get(s.start..))
            .and_then(|t| t.chars().next());
        message = match c {
            Some(c) => format!(
                "unexpected character {c:?}; expected `key = value` lines and `[table]` headers"
            ),
            None => "unexpected end of file; expected `key = value` lines and `[table]` headers"
                .to_string(),
        };
    }
    Error::parse(name, line, message)
}

/// A JSON error as `file:line: message (column C)`: line and column from the error, the
/// message without serde_json's own ` at line L column C` ending.
fn json_error(name: &str, e: &serde_json::Error) -> Error {
    let text = e.to_string();
    let position = format!(" at line {} column {}", e.line(), e.column());
    let message = text.strip_suffix(&position).unwrap_or(&text);
    let message = match e.line() {
        0 => message.to_string(),
        _ => format!("{message} (column {})", e.column()),
    };
    Error::parse(name, e.line(), message)
}

/// `value` of a model key must be finite (TOML accepts `inf` and `nan`).
fn finite(value: f64, key: &str) -> Result<f64> {
    if !value.is_finite() {
        return Err(Error::Model(format!(
            "[scheme] {key} must be finite, got {value}"
        )));
    }
    Ok(value)
}

impl Model {
    /// Truszkowska 2018's MRV model (Sec. 5.1): zener-above-1, a_n = 4.31, a_s = 10.0,
    /// normal 1e13, shear 3.55e12 (PFC parallel-bond magnitudes, Pa/m, `area`
    /// convention), gap cutoff 0.17 R̄ (Eq. 4).
    pub fn truszkowska_mrv() -> Model {
        Model {
            bonding: BondingRule::Gap(0.17),
            scheme: SchemeSpec::Cubic(CubicSpheroid {
                model: CubicModel::ZenerAbove1,
                extended: false,
                a_n: 4.31,
                a_s: 10.0,
                normal: 1.0e13,
                shear: 3.55e12,
                rotation: Mat3::identity(),
            }),
            geometry: Geometry::default(),
            strength: None,
            manybody: None,
            grains: None,
        }
    }

    /// Read a model file: TOML, or JSON when the extension is `.json`.
    pub fn from_path(path: &Path) -> Result<Model> {
        Model::from_str_for(&crate::io::read_to_string(path)?, path)
    }

    /// Parse model text in the format `path`'s extension names (JSON for `.json`, TOML
    /// otherwise); `path` is used in error messages.
    ///
    /// Relative file paths in the model (`[grains] file`, `euler_file`) resolve against
    /// `path`'s folder.
    pub fn from_str_for(text: &str, path: &Path) -> Result<Model> {
        let name = path.display().to_string();
        let base = match path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => Some(dir),
            _ => Some(Path::new(".")),
        };
        if is_json(path) {
            Model::from_json_in(text, &name, base)
        } else {
            Model::from_toml_in(text, &name, base)
        }
    }

    /// The model file text in the format `path`'s extension names (JSON for `.json`, TOML
    /// otherwise), so that a written model reads back through [`Model::from_path`].
    pub fn to_string_for(&self, path: &Path) -> String {
        if is_json(path) {
            self.to_json_string()
        } else {
            self.to_toml_string()
        }
    }

    /// Parse a TOML model; `name` is used in error messages. A UTF-8 BOM and classic-Mac
    /// `\r` line ends are accepted.
    ///
    /// ```
    /// use anisobond::model::Model;
    /// let text = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    ///             [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    ///             [geometry]\nconvention = \"spring\"\n";
    /// let model = Model::from_toml_str(text, "model.toml")?;
    /// assert_eq!(model.scheme.kind_name(), "isotropic");
    /// // A key of another scheme kind is refused by name and line, never ignored.
    /// let bad = text.replace("shear = 7e5", "shear = 7e5\neuler_zyz_deg = [0, 0, 0]");
    /// let e = Model::from_toml_str(&bad, "model.toml").unwrap_err().to_string();
    /// assert!(e.contains("euler_zyz_deg") && e.contains("model.toml:"), "{e}");
    /// # Ok::<(), anisobond::Error>(())
    /// ```
    ///
    /// Relative file paths in the model are kept as written (relative to the working
    /// folder); [`Model::from_path`] resolves them against the model file's folder.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Model> {
        Model::from_toml_in(text, name, None)
    }

    /// Parse a JSON model; `name` is used in error messages. A UTF-8 BOM is accepted.
    /// Relative file paths are kept as written ([`Model::from_toml_str`]).
    pub fn from_json_str(text: &str, name: &str) -> Result<Model> {
        Model::from_json_in(text, name, None)
    }

    /// [`Model::from_toml_str`] with relative file paths resolved against `base`.
    fn from_toml_in(text: &str, name: &str, base: Option<&Path>) -> Result<Model> {
        let text = normalized(text);
        let raw: RawModel = toml::from_str(&text).map_err(|e| toml_error(&text, name, &e))?;
        Model::from_raw(raw, base).map_err(|e| prefix(name, e))
    }

    /// [`Model::from_json_str`] with relative file paths resolved against `base`.
    fn from_json_in(text: &str, name: &str, base: Option<&Path>) -> Result<Model> {
        let text = normalized(text);
        let raw: RawModel = serde_json::from_str(&text).map_err(|e| json_error(name, &e))?;
        Model::from_raw(raw, base).map_err(|e| prefix(name, e))
    }

    /// The `[strength]` table of the model file at `path`, checked; `None` when it has none.
    pub fn strength_from_path(path: &Path) -> Result<Option<crate::strength::StrengthSpec>> {
        Model::strength_from_str_for(&crate::io::read_to_string(path)?, path)
    }

    /// The `[strength]` table of a model file's text (format by `path`'s extension, `path`
    /// named in refusals), checked; `None` when it has none (docs/strength.md).
    pub fn strength_from_str_for(
        text: &str,
        path: &Path,
    ) -> Result<Option<crate::strength::StrengthSpec>> {
        let name = path.display().to_string();
        let text = normalized(text);
        let raw: RawModel = if is_json(path) {
            serde_json::from_str(&text).map_err(|e| json_error(&name, &e))?
        } else {
            toml::from_str(&text).map_err(|e| toml_error(&text, &name, &e))?
        };
        let table = raw.strength.as_ref();
        let spec = table.map(crate::strength::StrengthSpec::from_table);
        spec.transpose().map_err(|e| prefix(&name, e))
    }

    /// The checked model of a parsed file: bonding rule, scheme and geometry, each refused
    /// with the key at fault; scheme parameters checked where that needs no packing.
    fn from_raw(raw: RawModel, base: Option<&Path>) -> Result<Model> {
        let bonding = match raw.bonding {
            None => BondingRule::default(),
            Some(b) => b.rule()?,
        };
        let mut scheme_pi_hat = None;
        let scheme = match raw.scheme {
            RawScheme::Cubic(s) => s.scheme()?,
            RawScheme::CrossAnisotropic(s) => {
                let target = s.target()?;
                scheme_pi_hat = s.pi_hat;
                SchemeSpec::CrossAnisotropic(target)
            }
            RawScheme::Isotropic(s) => SchemeSpec::Isotropic {
                normal: finite(s.normal, "normal")?,
                shear: finite(s.shear, "shear")?,
            },
        };
        let geometry = model_geometry(raw.geometry, &scheme, scheme_pi_hat)?;
        let manybody = match &raw.manybody {
            None => None,
            Some(m) => {
                let (rotation, axis) = match &scheme {
                    SchemeSpec::Cubic(c) => (c.rotation, Vec3::z()),
                    SchemeSpec::CrossAnisotropic(t) => (Mat3::identity(), t.axis),
                    SchemeSpec::Isotropic { .. } => (Mat3::identity(), Vec3::z()),
                };
                Some(crate::manybody::ManyBodySpec::from_raw(m, rotation, axis)?)
            }
        };
        let grains = raw
            .grains
            .as_ref()
            .map(|g| crate::grains::GrainsSpec::from_raw(g, base))
            .transpose()?;
        let model = Model {
            bonding,
            scheme,
            geometry,
            strength: raw.strength,
            manybody,
            grains,
        };
        // Validate the scheme parameters now (negative stiffness, a ≤ 0, …) where that
        // needs no packing.
        if !matches!(model.scheme, SchemeSpec::CrossAnisotropic(_)) {
            model.crystal_scheme(None)?;
        }
        Ok(model)
    }

    /// True when the scheme needs the bonded packing to be built (cross-anisotropic: μ).
    pub fn needs_packing(&self) -> bool {
        matches!(self.scheme, SchemeSpec::CrossAnisotropic(_))
    }

    /// Build the stiffness scheme. The cross-anisotropic scheme needs the bonded packing
    /// (for the lattice scaling μ, Šmilauer); the others ignore it.
    /// Refuses a model with `[grains]` ([`Error::Model`]): one scheme is one orientation, so
    /// springs from it would silently be the single crystal's; a polycrystal's springs come
    /// from its [`crate::Assembly`], and [`Self::crystal_scheme`] is the one crystal's scheme
    /// when that is what is meant.
    pub fn build_scheme(
        &self,
        bonded: Option<(&Packing, &BondSet)>,
    ) -> Result<Box<dyn StiffnessScheme>> {
        self.refuse_grains("one stiffness scheme")?;
        self.crystal_scheme_of(bonded)
    }

    /// [`Self::build_scheme`] of a polycrystal's crystal (the scheme in the model's own
    /// orientation, before any grain's turn), or of a single crystal.
    pub fn crystal_scheme_of(
        &self,
        bonded: Option<(&Packing, &BondSet)>,
    ) -> Result<Box<dyn StiffnessScheme>> {
        let mu = match (&self.scheme, bonded) {
            (SchemeSpec::CrossAnisotropic(_), Some((packing, bonds))) => Some(
                crate::bonds::lattice_scaling(packing, bonds, self.geometry.pi_hat)?,
            ),
            (SchemeSpec::CrossAnisotropic(_), None) => {
                return Err(Error::Model(
                    "the cross-anisotropic scheme needs a bonded packing (its lattice scaling μ comes from the bonds)".into(),
                ))
            }
            _ => None,
        };
        self.crystal_scheme(mu)
    }

    /// Refuse ([`Error::Model`]) a model with `[grains]` in `what`, which takes one crystal
    /// orientation (docs/polycrystal.md "What refuses grains"). Without the table: Ok.
    pub fn refuse_grains(&self, what: &str) -> Result<()> {
        if self.grains.is_some() {
            return Err(Error::Model(format!(
                "the model has [grains] (a polycrystal, each grain its own orientation), and \
                 {what} takes one crystal orientation; build an Assembly (its springs are by \
                 grain), or remove [grains] for the single crystal"
            )));
        }
        Ok(())
    }

    /// The springs of arbitrary bonds: unit `normals` (lab frame), sphere radii `r_i`, `r_j`
    /// (m) and bond lengths (m), by the scheme's magnitudes (Truszkowska 2018 Eq. 6,
    /// Šmilauer's k_n = E′_N(θ)·π̂r²/(2r′)) and the model's geometry, exactly as
    /// [`crate::bonds::assign_stiffness`] gives a packing's bonds. The cross-anisotropic
    /// scheme needs its packing's lattice scaling μ (`lattice_scaling`); the others ignore it.
    /// Refuses, naming the bond, a normal not of unit length (within 1e-9), a radius or
    /// length not finite and > 0, or columns of different lengths.
    pub fn springs_for(
        &self,
        normals: &[Vec3],
        r_i: &[f64],
        r_j: &[f64],
        lengths: &[f64],
        lattice_scaling: Option<f64>,
    ) -> Result<crate::bonds::BondStiffness> {
        self.refuse_grains("springs of bonds given by columns (no particles, so no grains)")?;
        crate::bonds::stiffness::check_bond_columns(normals, r_i, r_j, lengths)?;
        let scheme = self.scheme_for(lattice_scaling)?;
        crate::bonds::stiffness::springs_along(
            scheme.as_ref(),
            &self.geometry,
            normals,
            r_i,
            r_j,
            lengths,
            &|b| format!("bond {b}"),
        )
    }

    /// The stiffness scheme with a given lattice scaling μ (needed by, and only by, the
    /// cross-anisotropic scheme; [`Self::build_scheme`] takes μ from a bonded packing).
    /// Refuses a model with `[grains]`, as [`Self::build_scheme`] does.
    pub fn scheme_for(&self, lattice_scaling: Option<f64>) -> Result<Box<dyn StiffnessScheme>> {
        self.refuse_grains("one stiffness scheme")?;
        self.crystal_scheme(lattice_scaling)
    }

    /// [`Self::scheme_for`] of the crystal, with or without `[grains]`: the scheme in the
    /// model's own orientation (a grain's springs turn it by the grain's, docs/polycrystal.md).
    pub fn crystal_scheme(&self, lattice_scaling: Option<f64>) -> Result<Box<dyn StiffnessScheme>> {
        Ok(match &self.scheme {
            SchemeSpec::Cubic(cubic) => Box::new(cubic.checked()?),
            SchemeSpec::Isotropic { normal, shear } => Box::new(Isotropic::new(*normal, *shear)?),
            SchemeSpec::CrossAnisotropic(target) => {
                let mu = lattice_scaling.ok_or_else(|| {
                    Error::Model(
                        "the cross-anisotropic scheme's springs depend on the packing's lattice \
                         scaling μ (Šmilauer): give it, or take the springs of an assembly"
                            .into(),
                    )
                })?;
                if !(mu.is_finite() && mu > 0.0) {
                    return Err(Error::Invalid(format!(
                        "springs: lattice scaling μ = {mu}, expected a finite value > 0"
                    )));
                }
                Box::new(target.scheme(mu)?)
            }
        })
    }

    /// The model in the file layout of the SPEC (both formats serialise this).
    fn to_raw(&self) -> RawModel {
        let (rule, value) = match self.bonding {
            BondingRule::Gap(v) => ("gap", v),
            BondingRule::Factor(v) => ("factor", v),
            BondingRule::Coordination(v) => ("coordination", v),
        };
        let s = match &self.scheme {
            SchemeSpec::Cubic(c) => RawScheme::Cubic(RawCubic {
                model: c.model,
                extended: c.extended,
                a_n: c.a_n,
                a_s: c.a_s,
                normal: c.normal,
                shear: c.shear,
                rotation: Some([0, 1, 2].map(|i| [0, 1, 2].map(|j| c.rotation[(i, j)]))),
                euler_zyz_deg: None,
            }),
            SchemeSpec::CrossAnisotropic(t) => RawScheme::CrossAnisotropic(RawCross {
                c11: t.c11,
                c33: t.c33,
                c13: t.c13,
                c12: t.c12,
                axis: Some([t.axis.x, t.axis.y, t.axis.z]),
                strike_deg: None,
                dip_deg: None,
                pi_hat: None,
            }),
            SchemeSpec::Isotropic { normal, shear } => RawScheme::Isotropic(RawIsotropic {
                normal: *normal,
                shear: *shear,
            }),
        };
        RawModel {
            bonding: Some(RawBonding {
                rule: rule.into(),
                value,
            }),
            scheme: s,
            geometry: Some(self.geometry),
            strength: self.strength.clone(),
            manybody: self.manybody.as_ref().map(|m| m.to_raw()),
            grains: self.grains.as_ref().map(|g| g.to_raw()),
        }
    }

    /// Serialise as TOML in the SPEC layout (used for calibrated models and exports).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(&self.to_raw()).unwrap_or_default()
    }

    /// Serialise as JSON (the same tables and keys as the TOML file), with a final newline.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string_pretty(&self.to_raw()).unwrap_or_default() + "\n"
    }
}

/// A model path in JSON (extension `.json`, any case); TOML otherwise.
fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

fn prefix(name: &str, e: Error) -> Error {
    match e {
        Error::Model(m) => Error::Model(format!("{name}: {m}")),
        other => other,
    }
}
