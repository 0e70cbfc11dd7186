//! Model files (docs/formats.md "Model"): which pairs are bonded, which stiffness scheme, and how a
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
//!
//! Each `kind` takes only its own keys: a key of another kind (say `euler_zyz_deg` under
//! `isotropic`) is an error naming the key and its line, never silently ignored. Numbers
//! must be finite and admissible (a cross-anisotropic target positive definite) when read.

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
    /// The scheme's `kind` in the model file: `cubic`, `cross-anisotropic` or `isotropic`.
    pub fn kind_name(&self) -> &'static str {
        match self {
            SchemeSpec::Cubic(_) => "cubic",
            SchemeSpec::CrossAnisotropic(_) => "cross-anisotropic",
            SchemeSpec::Isotropic { .. } => "isotropic",
        }
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

/// The `[scheme]` table, one type per `kind`: each variant refuses the keys of the other
/// kinds by name (`deny_unknown_fields`), so no key is silently ignored.
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
    model: CubicModel,
    #[serde(default)]
    extended: bool,
    a_n: f64,
    a_s: f64,
    normal: f64,
    shear: f64,
    #[serde(
        default,
        deserialize_with = "exact::matrix3",
        skip_serializing_if = "Option::is_none"
    )]
    rotation: Option<[[f64; 3]; 3]>,
    #[serde(
        default,
        deserialize_with = "exact::triple",
        skip_serializing_if = "Option::is_none"
    )]
    euler_zyz_deg: Option<[f64; 3]>,
}

/// `kind = "cross-anisotropic"`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCross {
    #[serde(rename = "C11")]
    c11: f64,
    #[serde(rename = "C33")]
    c33: f64,
    #[serde(rename = "C13")]
    c13: f64,
    #[serde(rename = "C12")]
    c12: f64,
    #[serde(
        default,
        deserialize_with = "exact::triple",
        skip_serializing_if = "Option::is_none"
    )]
    axis: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    strike_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    dip_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pi_hat: Option<f64>,
}

/// Readers of the keys that hold three numbers or a 3×3 matrix: exactly that many, no `null`
/// (a present key is always read as a value; absent keys take the field's default).
mod exact {
    use serde::{de::Error as _, Deserialize, Deserializer};

    fn three<E: serde::de::Error>(v: Vec<f64>, what: &str) -> Result<[f64; 3], E> {
        <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
            E::custom(format!(
                "expected {what} of exactly 3 numbers, found {}",
                v.len()
            ))
        })
    }

    /// Three numbers (`axis`, `euler_zyz_deg`).
    pub fn triple<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
        three(Vec::<f64>::deserialize(d)?, "a list").map(Some)
    }

    /// A 3×3 matrix as three rows of three numbers (`rotation`).
    pub fn matrix3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[[f64; 3]; 3]>, D::Error> {
        let rows = Vec::<Vec<f64>>::deserialize(d)?;
        if rows.len() != 3 {
            return Err(D::Error::custom(format!(
                "expected 3 rows of 3 numbers, found {} rows",
                rows.len()
            )));
        }
        let mut m = [[0.0; 3]; 3];
        for (k, row) in rows.into_iter().enumerate() {
            m[k] = three(row, &format!("row {}", k + 1))?;
        }
        Ok(Some(m))
    }
}

/// `kind = "isotropic"`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawIsotropic {
    normal: f64,
    shear: f64,
}

/// The kinds, in the words of the model file.
const KINDS: &str = "expected cubic, cross-anisotropic or isotropic";

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
struct KindName(String);

impl<'de> Deserialize<'de> for KindName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let kind = String::deserialize(d)?;
        match kind.as_str() {
            "cubic" | "cross-anisotropic" | "isotropic" => Ok(KindName(kind)),
            other => Err(serde::de::Error::custom(format!(
                "[scheme] kind = \"{other}\": {KINDS}"
            ))),
        }
    }
}

impl SchemeVisitor {
    fn variant<'de, D: serde::Deserializer<'de>>(
        kind: &str,
        rest: D,
    ) -> std::result::Result<RawScheme, D::Error> {
        Ok(match kind {
            "cubic" => RawScheme::Cubic(RawCubic::deserialize(rest)?),
            "cross-anisotropic" => RawScheme::CrossAnisotropic(RawCross::deserialize(rest)?),
            "isotropic" => RawScheme::Isotropic(RawIsotropic::deserialize(rest)?),
            other => {
                return Err(serde::de::Error::custom(format!(
                    "[scheme] kind = \"{other}\": {KINDS}"
                )))
            }
        })
    }
}

impl<'de> serde::de::Visitor<'de> for SchemeVisitor {
    type Value = RawScheme;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(
            "a [scheme] table with kind = \"cubic\", \"cross-anisotropic\" or \"isotropic\"",
        )
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
                Self::variant(&kind.0, serde::de::value::MapAccessDeserializer::new(map))
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
                    Some(serde_json::Value::String(s)) => s,
                    Some(other) => {
                        return Err(A::Error::custom(format!(
                            "[scheme] kind = {other}: {KINDS} (a string)"
                        )))
                    }
                    None => return Err(A::Error::missing_field("kind")),
                };
                Self::variant(&kind, serde_json::Value::Object(table)).map_err(|e| {
                    let e = e.to_string();
                    match e.starts_with("[scheme]") {
                        true => A::Error::custom(e),
                        false => A::Error::custom(format!("[scheme] {e}")),
                    }
                })
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

/// The `key` whose value starts at byte `pos` (`key = value` in TOML), if any.
fn key_before(text: &str, pos: usize) -> Option<&str> {
    let before = text.get(..pos)?.trim_end().strip_suffix('=')?.trim_end();
    let start = before
        .char_indices()
        .rev()
        .find(|(_, c)| !(c.is_ascii_alphanumeric() || *c == '_' || *c == '-'))
        .map_or(0, |(k, c)| k + c.len_utf8());
    let key = &before[start..];
    (!key.is_empty()).then_some(key)
}

/// The JSON key whose value ends before column `column` of line `line` (both 1-based, as
/// serde_json reports a type error), if it is on that line: `"key": value`.
fn json_key_before(text: &str, line: usize, column: usize) -> Option<&str> {
    let l = text.split('\n').nth(line.checked_sub(1)?)?;
    let end = (0..=column.min(l.len()))
        .rev()
        .find(|&k| l.is_char_boundary(k))?;
    let before = &l[..end];
    let colon = before.rfind(':')?;
    let quoted = before[..colon].trim_end().strip_suffix('"')?;
    let start = quoted.rfind('"')?;
    Some(&quoted[start + 1..])
}

/// The allowed names of the `[scheme]`/`[geometry]` keys whose value is one of a fixed
/// list, from serde's own "unknown variant" message (so the list cannot go stale).
fn allowed_names(key: &str) -> Option<String> {
    fn names<T: serde::de::DeserializeOwned>() -> Option<String> {
        let e = serde_json::from_str::<T>("\"\"").err()?.to_string();
        let list = e.split("expected ").nth(1)?;
        Some(list.split(" at line").next()?.to_string())
    }
    use crate::schemes::{BondLength, BondRadius, Moments};
    match key {
        "model" => names::<CubicModel>(),
        "convention" => names::<Convention>(),
        "bond_radius" => names::<BondRadius>(),
        "bond_length" => names::<BondLength>(),
        "moments" => names::<Moments>(),
        _ => None,
    }
}

/// A TOML error as `file:line: message`, the message made to say what was expected where
/// the parser's does not: a lone `\r` gets an empty message, an enum key given a number
/// gets "wanted string or table", a date a "map".
fn toml_error(text: &str, name: &str, e: &toml::de::Error) -> Error {
    let span = e.span();
    let line = span.as_ref().map(|s| line_of(text, s.start)).unwrap_or(0);
    let found = span
        .as_ref()
        .and_then(|s| text.get(s.clone()))
        .filter(|f| !f.contains('\n') && f.len() <= 60);
    let key = span.as_ref().and_then(|s| key_before(text, s.start));
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
    if message == "wanted string or table" {
        message = match key.and_then(allowed_names) {
            Some(list) => format!("expected {list}"),
            None => "expected a string".to_string(),
        };
    }
    if message.starts_with("invalid type: map") && !found.is_some_and(|f| f.starts_with('{')) {
        if let Some(f) = found {
            message = message.replacen("map", &format!("`{f}`"), 1);
        }
    }
    message = message.replace("expected f64", "expected a number");
    if let Some(k) = key {
        if !message.contains(&format!("`{k}`")) && !message.contains(&format!("{k} =")) {
            message = format!("`{k}`: {message}");
        }
    }
    if let (Some(f), true) = (found, message.starts_with("invalid type")) {
        if !message.contains(f) {
            message.push_str(&format!(" (found `{f}`)"));
        }
    }
    Error::parse(name, line, message)
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
        }
    }

    /// Read a model file: TOML, or JSON when the extension is `.json`.
    pub fn from_path(path: &Path) -> Result<Model> {
        Model::from_str_for(&crate::io::read_to_string(path)?, path)
    }

    /// Parse model text in the format `path`'s extension names (JSON for `.json`, TOML
    /// otherwise); `path` is used in error messages.
    pub fn from_str_for(text: &str, path: &Path) -> Result<Model> {
        let name = path.display().to_string();
        if is_json(path) {
            Model::from_json_str(text, &name)
        } else {
            Model::from_toml_str(text, &name)
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
    pub fn from_toml_str(text: &str, name: &str) -> Result<Model> {
        let text = normalized(text);
        let raw: RawModel = toml::from_str(&text).map_err(|e| toml_error(&text, name, &e))?;
        Model::from_raw(raw).map_err(|e| prefix(name, e))
    }

    /// Parse a JSON model; `name` is used in error messages. A UTF-8 BOM is accepted.
    pub fn from_json_str(text: &str, name: &str) -> Result<Model> {
        let text = normalized(text);
        let raw: RawModel = serde_json::from_str(&text).map_err(|e| {
            let message = e.to_string();
            // serde_json appends " at line L column C"; the line is in the prefix already.
            let mut message = match message.rfind(" at line ") {
                Some(k) => format!("{} (column {})", &message[..k], e.column()),
                None => message,
            };
            let key = json_key_before(&text, e.line(), e.column());
            if message.starts_with("invalid type") || message.starts_with("unknown variant") {
                if let Some(key) = key {
                    message = format!("`{key}`: {message}");
                }
            } else if message.starts_with("expected value") {
                // serde_json's word for a name-list key given a number or array.
                if let Some((key, list)) = key.and_then(|k| Some((k, allowed_names(k)?))) {
                    message = format!("`{key}`: expected {list} (column {})", e.column());
                }
            }
            Error::parse(
                name,
                e.line(),
                message.replace("expected f64", "expected a number"),
            )
        })?;
        Model::from_raw(raw).map_err(|e| prefix(name, e))
    }

    fn from_raw(raw: RawModel) -> Result<Model> {
        let bonding = match raw.bonding {
            None => BondingRule::default(),
            Some(b) => {
                if !b.value.is_finite() || b.value <= 0.0 {
                    return Err(Error::Model(format!(
                        "[bonding] value must be a finite number > 0, got {}",
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
        let mut scheme_pi_hat = None;
        let scheme = match raw.scheme {
            RawScheme::Cubic(s) => {
                let rotation = match (s.rotation, s.euler_zyz_deg) {
                    (Some(_), Some(_)) => {
                        return Err(Error::Model(
                            "[scheme] give either `rotation` or `euler_zyz_deg`, not both".into(),
                        ))
                    }
                    (Some(r), None) => {
                        let m = Mat3::from_fn(|i, j| r[i][j]);
                        // A rotation to rounding (as written by to_toml_string) is kept bit for
                        // bit, so a written model reads back identically; a matrix printed to a
                        // few decimals is re-orthonormalised.
                        let exact = m.iter().all(|x| x.is_finite())
                            && (m.transpose() * m - Mat3::identity()).amax() <= 1e-12
                            && m.determinant() > 0.0;
                        if exact {
                            m
                        } else {
                            cubic::orthonormalize_rotation(m)?
                        }
                    }
                    (None, Some(e)) => {
                        for v in e {
                            finite(v, "euler_zyz_deg")?;
                        }
                        cubic::rotation_from_euler_zyz_deg(e[0], e[1], e[2])
                    }
                    (None, None) => Mat3::identity(),
                };
                SchemeSpec::Cubic(CubicSpheroid {
                    model: s.model,
                    extended: s.extended,
                    a_n: finite(s.a_n, "a_n")?,
                    a_s: finite(s.a_s, "a_s")?,
                    normal: finite(s.normal, "normal")?,
                    shear: finite(s.shear, "shear")?,
                    rotation,
                })
            }
            RawScheme::CrossAnisotropic(s) => {
                let axis = match (s.axis, s.strike_deg, s.dip_deg) {
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
                            v
                        } else {
                            v / n
                        }
                    }
                    (None, Some(st), Some(dp)) => cross_anisotropic::axis_from_strike_dip(
                        finite(st, "strike_deg")?,
                        finite(dp, "dip_deg")?,
                    ),
                    (None, None, None) => Vec3::z(),
                    _ => {
                        return Err(Error::Model(
                            "[scheme] give the axis either as `axis = [x, y, z]` or as both `strike_deg` and `dip_deg`".into(),
                        ))
                    }
                };
                let target = CrossTarget {
                    c11: finite(s.c11, "C11")?,
                    c33: finite(s.c33, "C33")?,
                    c13: finite(s.c13, "C13")?,
                    c12: finite(s.c12, "C12")?,
                    axis,
                };
                // Positive definiteness and non-negative lattice moduli do not depend on the
                // lattice scaling μ > 0 (E′ = A⁻¹C/μ), so they are checked here with μ = 1,
                // before any packing is read.
                target.scheme(1.0)?;
                scheme_pi_hat = s.pi_hat;
                SchemeSpec::CrossAnisotropic(target)
            }
            RawScheme::Isotropic(s) => SchemeSpec::Isotropic {
                normal: finite(s.normal, "normal")?,
                shear: finite(s.shear, "shear")?,
            },
        };
        // Geometry: the cross-anisotropic scheme is defined with moduli (k = E'·A/l), the
        // others default to the PFC parallel-bond `area` convention.
        let mut geometry = match (&raw.geometry, &scheme) {
            (Some(g), _) => *g,
            (None, SchemeSpec::CrossAnisotropic(_)) => Geometry {
                convention: Convention::Modulus,
                ..Geometry::default()
            },
            (None, _) => Geometry::default(),
        };
        if let Some(p) = scheme_pi_hat {
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
        let model = Model {
            bonding,
            scheme,
            geometry,
        };
        // Validate the scheme parameters now (negative stiffness, a ≤ 0, …) where that
        // needs no packing.
        if !matches!(model.scheme, SchemeSpec::CrossAnisotropic(_)) {
            model.build_scheme(None)?;
        }
        Ok(model)
    }

    /// True when the scheme needs the bonded packing to be built (cross-anisotropic: μ).
    pub fn needs_packing(&self) -> bool {
        matches!(self.scheme, SchemeSpec::CrossAnisotropic(_))
    }

    /// Build the stiffness scheme. The cross-anisotropic scheme needs the bonded packing
    /// (for the lattice scaling μ, Šmilauer); the others ignore it.
    pub fn build_scheme(
        &self,
        bonded: Option<(&Packing, &BondSet)>,
    ) -> Result<Box<dyn StiffnessScheme>> {
        let mu = match (&self.scheme, bonded) {
            (SchemeSpec::CrossAnisotropic(_), Some((packing, bonds))) => Some(
                cross_anisotropic::lattice_scaling(packing, bonds, self.geometry.pi_hat)?,
            ),
            (SchemeSpec::CrossAnisotropic(_), None) => {
                return Err(Error::Model(
                    "the cross-anisotropic scheme needs a bonded packing (its lattice scaling μ comes from the bonds)".into(),
                ))
            }
            _ => None,
        };
        self.scheme_for(mu)
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
    pub fn scheme_for(&self, lattice_scaling: Option<f64>) -> Result<Box<dyn StiffnessScheme>> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_before_handles_multibyte_text() {
        // "Ⱥ" is two bytes: the key search must step over it whole (the fuzz test found a
        // slice inside it).
        assert_eq!(key_before("Ⱥ= 1", 4), None);
        assert_eq!(key_before("éa_n = 1", 8), Some("a_n"));
        assert_eq!(key_before("x = { convention = 3 }", 19), Some("convention"));
        assert_eq!(
            json_key_before("{\"a\": {\"normal\": \"x\",", 1, 21),
            Some("normal")
        );
        assert_eq!(json_key_before("é\"Ⱥ\": 1", 1, 3), None);
        assert_eq!(json_key_before("", 7, 3), None);
    }
}
