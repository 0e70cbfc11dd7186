//! The studies: computations with options, a run and a report that is their one output
//! schema. The command line and Python only parse, call [`run`](buckling::run) and print
//! or convert the report; the defaults live in each study's options, once.
//!
//! - [`buckling`]: Kumar 2016 Sec. 5's clamped round bars (`anisobond buckle`,
//!   `anisobond.buckle_bar`).
//! - [`cavity`]: Šmilauer's pressurised cavity (`anisobond cavity`, `Assembly.cavity`).
//! - [`demo`]: Truszkowska 2018's assembly by every method (`anisobond demo`).
//! - [`domain`]: the accessible cubic domain (`anisobond domain`).
//! - [`polycrystal`]: a polycrystal's relaxed tensor beside its single crystal's bounds and
//!   estimates, and each grain's stress against its orientation (`anisobond polycrystal`,
//!   `anisobond.polycrystal`).
//! - [`strength_test`]: the virtual laboratory — UCS, direct tension and the Brazilian disc
//!   to failure at a bedding angle (`anisobond strength-test`, `anisobond.strength_test`).
//! - [`strength_sweep`]: UCS and Brazilian disc over a list of bedding angles
//!   (`anisobond strength-test --bedding-sweep`, `anisobond.strength_sweep`).

pub mod buckling;
pub mod cavity;
pub mod demo;
pub mod domain;
pub mod polycrystal;
pub mod strength_sweep;
pub mod strength_test;

/// How a study's checks name its options: as the command line's flags (`--dem-steps`) or as
/// the keyword arguments of Python (`dem_steps`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionNames {
    /// `--kebab-case` flags.
    Flags,
    /// `snake_case` keywords.
    Keywords,
}

impl OptionNames {
    /// The option of field `field` (snake_case) as the client calls it.
    pub fn name(self, field: &str) -> String {
        match self {
            OptionNames::Flags => format!("--{}", field.replace('_', "-")),
            OptionNames::Keywords => field.to_owned(),
        }
    }

    /// Refuse the first of `values` (field, value) that is not finite and > 0, naming its
    /// option.
    pub fn require_positive(self, values: &[(&str, f64)]) -> crate::Result<()> {
        match values.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            Some((field, v)) => Err(crate::Error::Invalid(format!(
                "{} {v}: expected a finite value > 0",
                self.name(field)
            ))),
            None => Ok(()),
        }
    }
}

/// `Some(x)` when `x` is finite; `None` (JSON `null`, Python `None`) for a value that has no
/// finite value by its definition (Mazzilli below l/r = 2π, κGA of a shear-rigid bar).
pub fn finite(x: f64) -> Option<f64> {
    Some(x).filter(|x| x.is_finite())
}

/// `x`, or [`crate::Error::Degenerate`] naming `what` when it is not finite: a report holds
/// finite numbers or refuses.
pub fn require_finite(x: f64, what: &str) -> crate::Result<f64> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(crate::Error::Degenerate(format!(
            "{what} = {x} is not a finite number (overflow or a degenerate result)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn require_positive_names_the_first_bad_option_as_the_client_calls_it() {
        let values = [
            ("width_particles", 6.0),
            ("max_strain", 0.0),
            ("end_layer", -1.0),
        ];
        for (names, option) in [
            (OptionNames::Flags, "--max-strain"),
            (OptionNames::Keywords, "max_strain"),
        ] {
            let e = names.require_positive(&values).unwrap_err();
            assert!(matches!(e, crate::Error::Invalid(_)));
            assert_eq!(
                e.to_string(),
                format!("{option} 0: expected a finite value > 0")
            );
        }
        for bad in [f64::NAN, f64::INFINITY] {
            let e = OptionNames::Flags
                .require_positive(&[("kappa", bad)])
                .unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("--kappa {bad}: expected a finite value > 0")
            );
        }
        OptionNames::Flags
            .require_positive(&[("kappa", 1.0), ("sigma_n", 1e-300)])
            .unwrap();
    }
}
