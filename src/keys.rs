//! The values of a model file's keys, read by type: each reader takes any value, checks its
//! type in Rust and refuses it with its own message naming the key and what was expected
//! (`` `a_s`: invalid type: string "ten", expected a number``). The parsers (TOML, JSON) then
//! only say where: their error's position, never their message text, is looked at.

use serde::de::{self, Deserialize, DeserializeOwned, Deserializer, MapAccess, SeqAccess};
use std::fmt;

/// Any value as a parser gives it, before its key's type is checked.
#[derive(Debug)]
pub enum Raw {
    /// `true` or `false`.
    Bool(bool),
    /// An integer read as signed (TOML: every integer; JSON: a negative one).
    Signed(i64),
    /// An integer read as unsigned (JSON: a non-negative one).
    Unsigned(u64),
    /// A floating-point number (`nan` and `inf` included; finiteness is checked later).
    Float(f64),
    /// A string.
    Str(String),
    /// A TOML date or time (the toml crate hands it over as a one-entry table).
    Datetime(String),
    /// JSON `null`.
    Null,
    /// A list.
    Seq(Vec<Raw>),
    /// A table (its entries are not needed: no key takes one).
    Map,
}

/// toml's key for a date or time handed over as a table (its `Deserialize` protocol).
const TOML_DATETIME: &str = "$__toml_private_datetime";

impl<'de> Deserialize<'de> for Raw {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Raw, D::Error> {
        d.deserialize_any(RawVisitor)
    }
}

struct RawVisitor;

impl<'de> de::Visitor<'de> for RawVisitor {
    type Value = Raw;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Raw, E> {
        Ok(Raw::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Raw, E> {
        Ok(Raw::Signed(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Raw, E> {
        Ok(Raw::Unsigned(v))
    }
    fn visit_f64<E>(self, v: f64) -> Result<Raw, E> {
        Ok(Raw::Float(v))
    }
    fn visit_str<E>(self, v: &str) -> Result<Raw, E> {
        Ok(Raw::Str(v.to_string()))
    }
    fn visit_unit<E>(self) -> Result<Raw, E> {
        Ok(Raw::Null)
    }
    fn visit_none<E>(self) -> Result<Raw, E> {
        Ok(Raw::Null)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Raw, D::Error> {
        Raw::deserialize(d)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Raw, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element()? {
            items.push(item);
        }
        Ok(Raw::Seq(items))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Raw, A::Error> {
        let mut datetime = None;
        let mut entries = 0;
        while let Some((key, value)) = map.next_entry::<String, Raw>()? {
            entries += 1;
            if let (TOML_DATETIME, Raw::Str(s)) = (key.as_str(), value) {
                datetime = Some(s);
            }
        }
        Ok(match (entries, datetime) {
            (1, Some(s)) => Raw::Datetime(s),
            _ => Raw::Map,
        })
    }
}

impl fmt::Display for Raw {
    /// The value as serde's "invalid type" messages show it.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Raw::Bool(b) => write!(f, "boolean `{b}`"),
            Raw::Signed(i) => write!(f, "integer `{i}`"),
            Raw::Unsigned(u) => write!(f, "integer `{u}`"),
            Raw::Float(x) => write!(f, "floating point `{x}`"),
            Raw::Str(s) => write!(f, "string {s:?}"),
            Raw::Datetime(s) => write!(f, "`{s}`"),
            Raw::Null => f.write_str("null"),
            Raw::Seq(_) => f.write_str("sequence"),
            Raw::Map => f.write_str("map"),
        }
    }
}

/// `` `key`: invalid type: FOUND, expected WHAT ``.
fn invalid_type<E: de::Error>(key: &str, found: &Raw, what: &str) -> E {
    E::custom(format!("`{key}`: invalid type: {found}, expected {what}"))
}

/// The number `raw` is, or the refusal naming `key`.
fn number_of<E: de::Error>(key: &str, raw: &Raw) -> Result<f64, E> {
    match *raw {
        Raw::Float(x) => Ok(x),
        Raw::Signed(i) => Ok(i as f64),
        Raw::Unsigned(u) => Ok(u as f64),
        _ => Err(invalid_type(key, raw, "a number")),
    }
}

/// The numbers of a list of exactly `N`; `what` names the list in the refusal (`a list`,
/// `row 2`).
fn exactly<E: de::Error, const N: usize>(key: &str, raw: &Raw, what: &str) -> Result<[f64; N], E> {
    let Raw::Seq(items) = raw else {
        return Err(invalid_type(key, raw, "a sequence"));
    };
    if items.len() != N {
        return Err(E::custom(format!(
            "`{key}`: expected {what} of exactly {N} numbers, found {}",
            items.len()
        )));
    }
    let mut out = [0.0; N];
    for (o, item) in out.iter_mut().zip(items) {
        *o = number_of(key, item)?;
    }
    Ok(out)
}

/// A type a key's value is read as, refused with a message naming the key.
pub trait Read: Sized {
    /// Whether an optional key of this type given `null` (JSON) counts as absent; the
    /// fixed-size lists refuse it (a present key is a value).
    const NULL_IS_ABSENT: bool = false;

    /// The value of `key` from `raw`.
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<Self, E>;
}

/// A number (an integer is taken as the float it names).
impl Read for f64 {
    const NULL_IS_ABSENT: bool = true;

    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<f64, E> {
        number_of(key, raw)
    }
}

/// `true` or `false`.
impl Read for bool {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<bool, E> {
        match raw {
            Raw::Bool(b) => Ok(*b),
            other => Err(invalid_type(key, other, "a boolean")),
        }
    }
}

/// A string.
impl Read for String {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<String, E> {
        match raw {
            Raw::Str(s) => Ok(s.clone()),
            other => Err(invalid_type(key, other, "a string")),
        }
    }
}

/// A non-negative integer (`count`, `seed`); a float, even a whole one, is refused.
impl Read for u64 {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<u64, E> {
        match *raw {
            Raw::Unsigned(u) => Ok(u),
            Raw::Signed(i) if i >= 0 => Ok(i as u64),
            Raw::Signed(i) => Err(E::custom(format!(
                "`{key}`: {i} is negative, expected a non-negative integer"
            ))),
            _ => Err(invalid_type(key, raw, "a non-negative integer")),
        }
    }
}

/// Exactly three numbers (`axis`, `euler_zyz_deg`).
impl Read for [f64; 3] {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<[f64; 3], E> {
        exactly(key, raw, "a list")
    }
}

/// A 3×3 matrix as three rows of three numbers (`rotation`).
impl Read for [[f64; 3]; 3] {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<[[f64; 3]; 3], E> {
        let Raw::Seq(items) = raw else {
            return Err(invalid_type(key, raw, "a sequence"));
        };
        if items.len() != 3 {
            return Err(E::custom(format!(
                "`{key}`: expected 3 rows of 3 numbers, found {} rows",
                items.len()
            )));
        }
        let mut m = [[0.0; 3]; 3];
        for (k, row) in items.iter().enumerate() {
            m[k] = exactly(key, row, &format!("row {}", k + 1))?;
        }
        Ok(m)
    }
}

/// An optional key, when given: its value (absent keys take the field's `default`).
impl<T: Read> Read for Option<T> {
    fn from_raw<E: de::Error>(key: &str, raw: &Raw) -> Result<Option<T>, E> {
        match raw {
            Raw::Null if T::NULL_IS_ABSENT => Ok(None),
            _ => T::from_raw(key, raw).map(Some),
        }
    }
}

/// The value of `key` as the type `T` of its field.
pub fn read<'de, D: Deserializer<'de>, T: Read>(d: D, key: &str) -> Result<T, D::Error> {
    T::from_raw(key, &Raw::deserialize(d)?)
}

/// One of the names of the enum `T` (its serde names), refused with the list of them.
pub fn name<'de, D: Deserializer<'de>, T: DeserializeOwned>(
    d: D,
    key: &str,
) -> Result<T, D::Error> {
    let names = one_of(variants::<T>());
    match Raw::deserialize(d)? {
        Raw::Str(s) => T::deserialize(de::value::StrDeserializer::<de::value::Error>::new(&s))
            .map_err(|_| {
                de::Error::custom(format!("`{key}`: unknown variant `{s}`, expected {names}"))
            }),
        _ => Err(de::Error::custom(format!("`{key}`: expected {names}"))),
    }
}

/// The names `a`, `` `a` or `b` ``, `` one of `a`, `b`, `c` `` (as serde lists them).
fn one_of(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    match quoted.as_slice() {
        [] => "nothing".to_string(),
        [one] => one.clone(),
        [a, b] => format!("{a} or {b}"),
        many => format!("one of {}", many.join(", ")),
    }
}

/// The serde names of the unit variants of enum `T`, as its `Deserialize` declares them.
fn variants<T: DeserializeOwned>() -> &'static [&'static str] {
    let mut names: &'static [&'static str] = &[];
    let _ = T::deserialize(VariantNames(&mut names));
    names
}

/// A deserializer that only records the variant names an enum's `Deserialize` passes it.
struct VariantNames<'a>(&'a mut &'static [&'static str]);

impl<'de> Deserializer<'de> for VariantNames<'_> {
    type Error = de::value::Error;

    fn deserialize_enum<V: de::Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Self::Error> {
        *self.0 = variants;
        Err(de::Error::custom("names recorded"))
    }

    fn deserialize_any<V: de::Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Self::Error> {
        Err(de::Error::custom("not an enum"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map struct identifier
        ignored_any
    }
}

/// Readers of the named keys, for `#[serde(deserialize_with = "crate::keys::…")]`: each
/// passes its key's name to `read` (the field's type decides how) or to `name` (an enum's
/// names).
macro_rules! keyed {
    ($($fn:ident($key:literal) = $reader:ident: $bound:path;)*) => {$(
        #[doc = concat!("The value of `", $key, "`.")]
        pub fn $fn<'de, D: Deserializer<'de>, T: $bound>(d: D) -> Result<T, D::Error> {
            $reader(d, $key)
        }
    )*};
}

keyed! {
    value("value") = read: Read;
    rule("rule") = read: Read;
    a_n("a_n") = read: Read;
    a_s("a_s") = read: Read;
    normal("normal") = read: Read;
    shear("shear") = read: Read;
    extended("extended") = read: Read;
    rotation("rotation") = read: Read;
    euler_zyz_deg("euler_zyz_deg") = read: Read;
    c11("C11") = read: Read;
    c33("C33") = read: Read;
    c13("C13") = read: Read;
    c12("C12") = read: Read;
    axis("axis") = read: Read;
    strike_deg("strike_deg") = read: Read;
    dip_deg("dip_deg") = read: Read;
    pi_hat("pi_hat") = read: Read;
    count("count") = read: Read;
    mean_size("mean_size") = read: Read;
    file("file") = read: Read;
    direction("direction") = read: Read;
    spread_deg("spread_deg") = read: Read;
    euler_file("euler_file") = read: Read;
    seed("seed") = read: Read;
    boundary_factor("boundary_factor") = read: Read;
    boundary_strength_factor("boundary_strength_factor") = read: Read;
    orientation("orientation") = name: DeserializeOwned;
    boundary("boundary") = name: DeserializeOwned;
    model("model") = name: DeserializeOwned;
    convention("convention") = name: DeserializeOwned;
    bond_radius("bond_radius") = name: DeserializeOwned;
    bond_length("bond_length") = name: DeserializeOwned;
    moments("moments") = name: DeserializeOwned;
}

/// Whether a model-file key is left out when its table is written back: an `Option` when
/// `None`; a key with a default value (an enum's name) is always written.
pub trait Absent {
    /// True when the key is not written.
    fn absent(&self) -> bool {
        false
    }
}

impl<T> Absent for Option<T> {
    fn absent(&self) -> bool {
        self.is_none()
    }
}

/// For `#[serde(skip_serializing_if = "crate::keys::absent")]`: [`Absent::absent`].
pub fn absent<T: Absent>(value: &T) -> bool {
    value.absent()
}

/// A model-file table as written (`Raw*`), one line per key, `name: Type = "reader"`: each
/// field defaults when its key is absent, is read by its [`keyed!`] reader (which names the
/// key in a refusal) and is left out when written back if [`absent`] (a `None`). A field's
/// type other than an `Option` implements [`Absent`] (always written).
macro_rules! table {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $($field:ident: $ty:ty = $reader:literal,)*
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $(
                #[serde(
                    default,
                    deserialize_with = $reader,
                    skip_serializing_if = "crate::keys::absent"
                )]
                $field: $ty,
            )*
        }
    };
}
pub(crate) use table;

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    #[serde(rename_all = "kebab-case")]
    #[allow(dead_code)]
    enum Three {
        Area,
        Modulus,
        SpringRate,
    }

    #[derive(serde::Deserialize)]
    #[allow(dead_code)]
    enum Two {
        #[serde(rename = "above")]
        A,
        #[serde(rename = "below")]
        B,
    }

    #[test]
    fn enum_names_are_read_from_their_deserialize() {
        assert_eq!(
            one_of(variants::<Three>()),
            "one of `area`, `modulus`, `spring-rate`"
        );
        assert_eq!(one_of(variants::<Two>()), "`above` or `below`");
    }

    /// JSON `null` for an optional number is an absent key (as serde's `Option` reads it);
    /// for a fixed-size list it is refused by name.
    #[test]
    fn null_is_absent_for_optional_numbers_only() {
        #[derive(serde::Deserialize, Debug)]
        struct T {
            #[serde(default, deserialize_with = "strike_deg")]
            strike_deg: Option<f64>,
            #[serde(default, deserialize_with = "axis")]
            axis: Option<[f64; 3]>,
        }
        let t: T = serde_json::from_str("{\"strike_deg\": null}").unwrap();
        assert_eq!((t.strike_deg, t.axis), (None, None));
        let e = serde_json::from_str::<T>("{\"axis\": null}").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("`axis`: invalid type: null, expected a sequence"),
            "{e}"
        );
    }

    #[test]
    fn refusals_name_the_key_in_toml_and_json() {
        #[derive(serde::Deserialize, Debug)]
        struct T {
            #[serde(deserialize_with = "a_n")]
            #[allow(dead_code)]
            a_n: f64,
        }
        let toml = toml::from_str::<T>("a_n = true").unwrap_err();
        assert_eq!(
            toml.message(),
            "`a_n`: invalid type: boolean `true`, expected a number"
        );
        let json = serde_json::from_str::<T>("{\"a_n\": [1]}").unwrap_err();
        assert!(
            json.to_string()
                .starts_with("`a_n`: invalid type: sequence, expected a number"),
            "{json}"
        );
    }
}
