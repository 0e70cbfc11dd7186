//! The values of a model file's keys, read by type: each reader takes any value, checks its
//! type in Rust and refuses it with its own message naming the key and what was expected
//! (`` `a_s`: invalid type: string "ten", expected a number``). The parsers (TOML, JSON) then
//! only say where: their error's position, never their message text, is looked at.

use serde::de::{self, Deserialize, DeserializeOwned, Deserializer, MapAccess, SeqAccess};
use std::fmt;

/// Any value as a parser gives it, before its key's type is checked.
#[derive(Debug)]
enum Raw {
    Bool(bool),
    Signed(i64),
    Unsigned(u64),
    Float(f64),
    Str(String),
    /// A TOML date or time (the toml crate hands it over as a one-entry table).
    Datetime(String),
    Null,
    Seq(Vec<Raw>),
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

/// The number `raw` is, or the refusal naming `key` (`what`: the words for "a number").
fn number_of<E: de::Error>(key: &str, raw: &Raw, what: &str) -> Result<f64, E> {
    match *raw {
        Raw::Float(x) => Ok(x),
        Raw::Signed(i) => Ok(i as f64),
        Raw::Unsigned(u) => Ok(u as f64),
        _ => Err(invalid_type(key, raw, what)),
    }
}

/// A number (an integer is taken as the float it names).
pub fn number<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<f64, D::Error> {
    number_of(key, &Raw::deserialize(d)?, "a number")
}

/// `true` or `false`.
pub fn boolean<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<bool, D::Error> {
    match Raw::deserialize(d)? {
        Raw::Bool(b) => Ok(b),
        other => Err(invalid_type(key, &other, "a boolean")),
    }
}

/// A string.
pub fn string<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<String, D::Error> {
    match Raw::deserialize(d)? {
        Raw::Str(s) => Ok(s),
        other => Err(invalid_type(key, &other, "a string")),
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
        *o = number_of(key, item, "a number")?;
    }
    Ok(out)
}

/// Exactly three numbers (`axis`, `euler_zyz_deg`).
pub fn triple<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<[f64; 3], D::Error> {
    exactly(key, &Raw::deserialize(d)?, "a list")
}

/// A 3×3 matrix as three rows of three numbers (`rotation`).
pub fn matrix3<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<[[f64; 3]; 3], D::Error> {
    let raw = Raw::deserialize(d)?;
    let Raw::Seq(items) = &raw else {
        return Err(invalid_type(key, &raw, "a sequence"));
    };
    if items.len() != 3 {
        return Err(de::Error::custom(format!(
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
/// passes its key's name to the typed reader.
macro_rules! keyed {
    ($($fn:ident($key:literal) = $reader:ident -> $t:ty;)*) => {$(
        #[doc = concat!("The value of `", $key, "`.")]
        pub fn $fn<'de, D: Deserializer<'de>>(d: D) -> Result<$t, D::Error> {
            $reader(d, $key)
        }
    )*};
}

/// Readers of optional keys (absent: the field's `default`, `None`).
macro_rules! keyed_optional {
    ($($fn:ident($key:literal) = $reader:ident -> $t:ty;)*) => {$(
        #[doc = concat!("The value of `", $key, "`, when given.")]
        pub fn $fn<'de, D: Deserializer<'de>>(d: D) -> Result<Option<$t>, D::Error> {
            $reader(d, $key).map(Some)
        }
    )*};
}

keyed! {
    value("value") = number -> f64;
    rule("rule") = string -> String;
    a_n("a_n") = number -> f64;
    a_s("a_s") = number -> f64;
    normal("normal") = number -> f64;
    shear("shear") = number -> f64;
    extended("extended") = boolean -> bool;
    c11("C11") = number -> f64;
    c33("C33") = number -> f64;
    c13("C13") = number -> f64;
    c12("C12") = number -> f64;
    pi_hat("pi_hat") = number -> f64;
}

keyed_optional! {
    rotation("rotation") = matrix3 -> [[f64; 3]; 3];
    euler_zyz_deg("euler_zyz_deg") = triple -> [f64; 3];
    axis("axis") = triple -> [f64; 3];
    strike_deg("strike_deg") = number -> f64;
    dip_deg("dip_deg") = number -> f64;
    optional_pi_hat("pi_hat") = number -> f64;
}

/// Readers of the keys whose value is one of an enum's names (the enum is the field's type).
macro_rules! keyed_names {
    ($($fn:ident($key:literal);)*) => {$(
        #[doc = concat!("The value of `", $key, "`: one of its enum's names.")]
        pub fn $fn<'de, D: Deserializer<'de>, T: DeserializeOwned>(d: D) -> Result<T, D::Error> {
            name(d, $key)
        }
    )*};
}

keyed_names! {
    model("model");
    convention("convention");
    bond_radius("bond_radius");
    bond_length("bond_length");
    moments("moments");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schemes::{cubic::CubicModel, Convention};

    #[test]
    fn enum_names_are_read_from_their_deserialize() {
        assert_eq!(
            one_of(variants::<Convention>()),
            "one of `area`, `modulus`, `spring`, `kumar`"
        );
        assert_eq!(
            one_of(variants::<CubicModel>()),
            "`zener-above-1` or `zener-below-1`"
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
