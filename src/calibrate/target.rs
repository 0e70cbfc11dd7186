//! The calibration target as given on the command line (docs/formats.md `calibrate --target T`).
//!
//! Cubic: `C11=…,C12=…,C44=…` (Pa; a unit suffix Pa, kPa, MPa or GPa is accepted) or the
//! ratios `C12/C11=…,C44/C11=…` (then the overall magnitude is left to the model file).
//! Cross-anisotropic: `C11=…,C33=…,C13=…,C12=…` (Pa, about the model's axis), or with the
//! fifth independent constant `…,C44=…` (then the many-body term carries what the elliptic
//! scheme, whose C44 is dependent, cannot; docs/manybody.md "Calibration").
//! Spaces around `=` and before the unit are allowed (`C11 = 80 GPa`). A target is refused
//! unless finite and positive definite, naming the condition that failed.

use crate::{Error, Result};

/// A cubic target: the two ratios that fix the shape of the tensor, and optionally C11 that
/// fixes its magnitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicTarget {
    /// C12/C11.
    pub c12_over_c11: f64,
    /// C44/C11.
    pub c44_over_c11: f64,
    /// C11 (Pa) when the target was given in absolute terms.
    pub c11: Option<f64>,
}

impl CubicTarget {
    /// A target from absolute constants (Pa).
    pub fn from_constants(c11: f64, c12: f64, c44: f64) -> Result<Self> {
        let t = CubicTarget {
            c12_over_c11: c12 / c11,
            c44_over_c11: c44 / c11,
            c11: Some(c11),
        };
        t.validate()?;
        Ok(t)
    }

    /// A target from the two ratios only.
    pub fn from_ratios(c12_over_c11: f64, c44_over_c11: f64) -> Result<Self> {
        let t = CubicTarget {
            c12_over_c11,
            c44_over_c11,
            c11: None,
        };
        t.validate()?;
        Ok(t)
    }

    /// Zener ratio 2C44/(C11 − C12) = 2·(C44/C11)/(1 − C12/C11).
    pub fn zener(&self) -> f64 {
        2.0 * self.c44_over_c11 / (1.0 - self.c12_over_c11)
    }

    /// Positive definiteness of a cubic tensor: C11 > 0, C44 > 0, −1/2 < C12/C11 < 1
    /// (i.e. C11 − C12 > 0 and C11 + 2·C12 > 0); the message names the condition that
    /// failed and its numbers.
    fn validate(&self) -> Result<()> {
        let (r12, r44) = (self.c12_over_c11, self.c44_over_c11);
        if let Some(c11) = self.c11 {
            if !c11.is_finite() || c11 <= 0.0 {
                return Err(Error::Invalid(format!(
                    "--target: C11 = {c11} Pa: expected a finite value > 0"
                )));
            }
        }
        for (name, v) in [("C12/C11", r12), ("C44/C11", r44)] {
            if !v.is_finite() {
                return Err(Error::Invalid(format!(
                    "--target: {name} = {v} is not finite (C11 too small for the other entries?)"
                )));
            }
        }
        let why = if r44 <= 0.0 {
            Some(format!("C44/C11 = {r44} must be > 0 (C44 > 0)"))
        } else if r12 >= 1.0 {
            Some(format!("C12/C11 = {r12} must be < 1 (C11 − C12 > 0)"))
        } else if r12 <= -0.5 {
            Some(format!("C12/C11 = {r12} must be > −1/2 (C11 + 2·C12 > 0)"))
        } else {
            None
        };
        match why {
            Some(why) => Err(Error::Invalid(format!(
                "--target is not a positive definite cubic stiffness: {why}{}",
                self.c11
                    .map(|c11| format!(
                        " (C11 = {c11:e}, C12 = {:e}, C44 = {:e} Pa)",
                        r12 * c11,
                        r44 * c11
                    ))
                    .unwrap_or_default()
            ))),
            None => Ok(()),
        }
    }

    /// (C11, C12, C44) in Pa with C11 = the target's, or `c11` when the target has none.
    pub fn constants(&self, c11: f64) -> (f64, f64, f64) {
        let c11 = self.c11.unwrap_or(c11);
        (c11, self.c12_over_c11 * c11, self.c44_over_c11 * c11)
    }
}

/// A parsed `--target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// Cubic constants or ratios.
    Cubic(CubicTarget),
    /// Transversely isotropic constants (Pa) about the model's axis.
    CrossAnisotropic {
        /// C11 = C22.
        c11: f64,
        /// C33 (along the axis).
        c33: f64,
        /// C13 = C23.
        c13: f64,
        /// C12.
        c12: f64,
        /// C44 = C55 when given (five independent constants); `None`: the elliptic scheme's
        /// dependent value.
        c44: Option<f64>,
    },
}

/// Positive definiteness of a transversely isotropic target (C11, C33, C13, C12) in Pa,
/// as far as these four constants fix it: C11 > 0, C33 > 0, C66 = (C11 − C12)/2 > 0,
/// C11 + C12 > 0 and (C11 + C12)·C33 > 2·C13² (the eigenvalues of the 6×6 tensor are C44,
/// C44, 2·C66 and those of the 2×2 block [[C11 + C12, √2·C13], [√2·C13, C33]]).
pub fn check_transverse_target(c11: f64, c33: f64, c13: f64, c12: f64) -> Result<()> {
    for (name, v) in [("C11", c11), ("C33", c33), ("C13", c13), ("C12", c12)] {
        if !v.is_finite() {
            return Err(Error::Invalid(format!(
                "--target: {name} = {v} Pa: expected a finite value"
            )));
        }
    }
    let (sum, product, c13_sq) = (c11 + c12, (c11 + c12) * c33, 2.0 * c13 * c13);
    let checks = [
        (c11 > 0.0, format!("C11 = {c11:e} must be > 0")),
        (c33 > 0.0, format!("C33 = {c33:e} must be > 0")),
        (
            c11 > c12,
            format!("C66 = (C11 − C12)/2 = {:e} must be > 0", 0.5 * (c11 - c12)),
        ),
        (sum > 0.0, format!("C11 + C12 = {sum:e} must be > 0")),
        (
            product.is_finite() && c13_sq.is_finite(),
            format!("(C11 + C12)·C33 = {product:e} and 2·C13² = {c13_sq:e} must be finite"),
        ),
        (
            product > c13_sq,
            format!("(C11 + C12)·C33 = {product:e} must exceed 2·C13² = {c13_sq:e}"),
        ),
    ];
    for (ok, why) in checks {
        if !ok {
            return Err(Error::Invalid(format!(
                "--target C11={c11:e}, C33={c33:e}, C13={c13:e}, C12={c12:e} Pa is not a \
                 positive definite transversely isotropic stiffness: {why}"
            )));
        }
    }
    Ok(())
}

/// The fifth condition of a five-constant transversely isotropic target: C44 > 0 (the
/// other eigenvalues are [`check_transverse_target`]'s).
pub fn check_transverse_c44(c11: f64, c33: f64, c13: f64, c12: f64, c44: f64) -> Result<()> {
    if !(c44.is_finite() && c44 > 0.0) {
        return Err(Error::Invalid(format!(
            "--target C11={c11:e}, C33={c33:e}, C13={c13:e}, C12={c12:e}, C44={c44:e} Pa is not \
             a positive definite transversely isotropic stiffness: C44 = {c44:e} must be > 0"
        )));
    }
    Ok(())
}

/// Split a `--target` into `KEY=VALUE` items: separated by commas, semicolons or spaces,
/// with spaces allowed around `=` and before a unit (`C11 = 80 GPa`).
pub(crate) fn target_items(text: &str) -> Vec<String> {
    let is_unit = |t: &str| ["Pa", "kPa", "MPa", "GPa"].contains(&t);
    let mut items = Vec::new();
    for chunk in text.split([',', ';']) {
        let mut current: Option<String> = None;
        for token in chunk.split_whitespace() {
            current = Some(match current {
                Some(prev)
                    if !prev.contains('=')
                        || prev.ends_with('=')
                        || token.starts_with('=')
                        || is_unit(token) =>
                {
                    prev + token
                }
                Some(prev) => {
                    items.push(prev);
                    token.to_string()
                }
                None => token.to_string(),
            });
        }
        items.extend(current);
    }
    items
}

/// A number with an optional unit suffix Pa, kPa, MPa, GPa (case-sensitive SI prefixes).
pub(crate) fn parse_value(text: &str, key: &str, allow_unit: bool) -> Result<f64> {
    let t = text.trim();
    let (number, scale) = if allow_unit {
        [("GPa", 1e9), ("MPa", 1e6), ("kPa", 1e3), ("Pa", 1.0)]
            .iter()
            .find_map(|(suffix, s)| t.strip_suffix(suffix).map(|n| (n.trim(), *s)))
            .unwrap_or((t, 1.0))
    } else {
        (t, 1.0)
    };
    let v: f64 = number.parse().map_err(|_| {
        Error::Invalid(format!(
            "--target: `{key}={text}`: expected a number{}",
            if allow_unit {
                " (Pa, or with a unit suffix kPa, MPa, GPa)"
            } else {
                ""
            }
        ))
    })?;
    if !v.is_finite() || !(v * scale).is_finite() {
        return Err(Error::Invalid(format!(
            "--target: `{key}={text}` is not finite"
        )));
    }
    Ok(v * scale)
}

impl Target {
    /// Parse `C11=…,C12=…,C44=…`, `C12/C11=…,C44/C11=…` or `C11=…,C33=…,C13=…,C12=…[,C44=…]`
    /// (keys case-insensitive, separated by commas or whitespace; `C11 = 80 GPa` is fine).
    /// The tensor is refused unless finite and positive definite, before anything is
    /// computed.
    pub fn parse(text: &str) -> Result<Target> {
        let mut c11 = None;
        let mut c12 = None;
        let mut c13 = None;
        let mut c33 = None;
        let mut c44 = None;
        let mut r12 = None;
        let mut r44 = None;
        let items = target_items(text);
        if items.is_empty() {
            return Err(Error::Invalid(
                "--target is empty: expected C11=…,C12=…,C44=… (Pa), C12/C11=…,C44/C11=…, or C11=…,C33=…,C13=…,C12=…[,C44=…]".into(),
            ));
        }
        for item in &items {
            let (key, value) = item.split_once('=').ok_or_else(|| {
                Error::Invalid(format!("--target: `{item}` is not of the form KEY=VALUE"))
            })?;
            let k = key.trim().to_ascii_uppercase().replace(' ', "");
            let slot = match k.as_str() {
                "C11" => &mut c11,
                "C12" => &mut c12,
                "C13" => &mut c13,
                "C33" => &mut c33,
                "C44" => &mut c44,
                "C12/C11" => &mut r12,
                "C44/C11" => &mut r44,
                _ => {
                    return Err(Error::Invalid(format!(
                        "--target: unknown key `{key}` (expected C11, C12, C13, C33, C44, C12/C11 or C44/C11)"
                    )))
                }
            };
            if slot.is_some() {
                return Err(Error::Invalid(format!("--target: `{key}` given twice")));
            }
            *slot = Some(parse_value(value, key, !k.contains('/'))?);
        }
        match (c11, c12, c13, c33, c44, r12, r44) {
            (Some(a), Some(b), None, None, Some(d), None, None) => {
                Ok(Target::Cubic(CubicTarget::from_constants(a, b, d)?))
            }
            (None, None, None, None, None, Some(a), Some(b)) => {
                Ok(Target::Cubic(CubicTarget::from_ratios(a, b)?))
            }
            (Some(c11), Some(c12), Some(c13), Some(c33), c44, None, None) => {
                check_transverse_target(c11, c33, c13, c12)?;
                if let Some(c44) = c44 {
                    check_transverse_c44(c11, c33, c13, c12, c44)?;
                }
                Ok(Target::CrossAnisotropic {
                    c11,
                    c33,
                    c13,
                    c12,
                    c44,
                })
            }
            _ => Err(Error::Invalid(format!(
                "--target `{text}`: give exactly C11, C12, C44 (cubic, Pa), or C12/C11 and C44/C11 (cubic ratios), or C11, C33, C13, C12[, C44] (cross-anisotropic, Pa)"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_three_forms_and_units() {
        let t = Target::parse("C11=246.5GPa, C12=147.3GPa, C44=124.7GPa").unwrap();
        let Target::Cubic(c) = t else { panic!() };
        assert_eq!(c.c11, Some(246.5e9));
        assert!((c.c12_over_c11 - 147.3 / 246.5).abs() < 1e-15);
        let t = Target::parse("c12/c11=0.30,C44/C11=0.43").unwrap();
        let Target::Cubic(c) = t else { panic!() };
        assert_eq!((c.c12_over_c11, c.c44_over_c11, c.c11), (0.30, 0.43, None));
        // Zener = 2·0.43/0.7.
        assert!((c.zener() - 0.86 / 0.7).abs() < 1e-15);
        let t = Target::parse("C11=130e6 C33=55e6 C13=28e6 C12=40e6").unwrap();
        assert_eq!(
            t,
            Target::CrossAnisotropic {
                c11: 130e6,
                c33: 55e6,
                c13: 28e6,
                c12: 40e6,
                c44: None
            }
        );
        let t = Target::parse("C11=130e6 C33=55e6 C13=28e6 C12=40e6 C44=20e6").unwrap();
        assert!(matches!(t, Target::CrossAnisotropic { c44: Some(v), .. } if v == 20e6));
        let e = refusal("C11=130e6 C33=55e6 C13=28e6 C12=40e6 C44=-1e6");
        assert!(e.contains("C44 = -1e6 must be > 0"), "{e}");
    }

    #[test]
    fn refuses_bad_targets() {
        for bad in [
            "",
            "C11=1",
            "C11=1,C12=2,C44=1",
            "C12/C11=0.3",
            "C12/C11=0.3,C44/C11=-1",
            "C11=x,C12=1,C44=1",
            "C11=1,C11=1,C12=0,C44=1",
            "C99=1",
        ] {
            assert!(Target::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn spaces_around_equals_and_before_the_unit() {
        for text in [
            "C11=80 GPa, C12=30 GPa, C44=40 GPa",
            "C11 = 80 GPa C12 = 30GPa C44=40 GPa",
            "C11=80e3 MPa;C12=30e9 Pa;C44=40e6 kPa",
        ] {
            let Target::Cubic(c) = Target::parse(text).unwrap() else {
                panic!("{text}")
            };
            assert_eq!(
                c.constants(0.0),
                (80e9, 80e9 * (30.0 / 80.0), 80e9 * 0.5),
                "{text}"
            );
        }
        let t = Target::parse("C11=130 MPa C33=55 MPa C13 = 28 MPa C12=40 MPa").unwrap();
        assert!(matches!(t, Target::CrossAnisotropic { c11, .. } if c11 == 130e6));
    }

    fn refusal(text: &str) -> String {
        Target::parse(text).unwrap_err().to_string()
    }

    #[test]
    fn entries_must_be_finite_after_the_unit() {
        let e = refusal("C11=1e308 GPa,C12=1,C44=1");
        assert!(e.contains("`C11=1e308GPa` is not finite"), "{e}");
        for text in [
            "C11=inf,C12=1,C44=1",
            "C11=1,C12=nan,C44=1",
            "C12/C11=nan,C44/C11=0.3",
        ] {
            assert!(refusal(text).contains("not finite"), "{text}");
        }
        // C11 so small that a ratio overflows.
        let e = refusal("C11=1e-300,C12=1e300,C44=1");
        assert!(e.contains("C12/C11 = inf is not finite"), "{e}");
    }

    #[test]
    fn cubic_targets_must_be_positive_definite_with_the_failed_condition() {
        for (text, why) in [
            (
                "C11=100,C12=100,C44=10",
                "C12/C11 = 1 must be < 1 (C11 − C12 > 0)",
            ),
            (
                "C11=100,C12=-60,C44=10",
                "C12/C11 = -0.6 must be > −1/2 (C11 + 2·C12 > 0)",
            ),
            ("C11=100,C12=30,C44=0", "C44/C11 = 0 must be > 0"),
            ("C11=100,C12=30,C44=-5", "C44/C11 = -0.05 must be > 0"),
            (
                "C11=0,C12=30,C44=5",
                "C11 = 0 Pa: expected a finite value > 0",
            ),
            ("C11=-100,C12=30,C44=5", "C11 = -100 Pa"),
            ("C12/C11=0.3,C44/C11=0", "C44/C11 = 0 must be > 0"),
            ("C12/C11=-0.5,C44/C11=0.3", "must be > −1/2"),
        ] {
            let e = refusal(text);
            assert!(e.contains(why), "{text}: {e}");
        }
        let e = refusal("C11=100,C12=100,C44=10");
        assert!(e.contains("C11 = 1e2, C12 = 1e2, C44 = 1e1 Pa"), "{e}");
    }

    #[test]
    fn cross_targets_must_be_positive_definite_with_the_failed_condition() {
        for (text, why) in [
            (
                "C11=40e9,C33=30e9,C13=40e9,C12=10e9",
                "(C11 + C12)·C33 = 1.5e21 must exceed 2·C13² = 3.2e21",
            ),
            ("C11=0,C33=30e9,C13=1e9,C12=-1e9", "C11 = 0e0 must be > 0"),
            (
                "C11=40e9,C33=-30e9,C13=1e9,C12=10e9",
                "C33 = -3e10 must be > 0",
            ),
            ("C11=40e9,C33=0,C13=1e9,C12=10e9", "C33 = 0e0 must be > 0"),
            (
                "C11=40e9,C33=30e9,C13=1e9,C12=50e9",
                "C66 = (C11 − C12)/2 = -5e9 must be > 0",
            ),
            (
                "C11=40e9,C33=30e9,C13=1e9,C12=-45e9",
                "C11 + C12 = -5e9 must be > 0",
            ),
            ("C11=1e300,C33=1e300,C13=1,C12=1", "must be finite"),
        ] {
            let e = refusal(text);
            assert!(
                e.contains("not a positive definite") && e.contains(why),
                "{text}: {e}"
            );
        }
        // Negative C13 and C12 are admissible while positive definite.
        assert!(Target::parse("C11=40e9,C33=30e9,C13=-5e9,C12=-10e9").is_ok());
    }
}
