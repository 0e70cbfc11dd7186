//! One registry of the names users type: each set of names (the tensor methods, the scheme
//! kinds) is an enum that lists its members once, with the name, a one-line description and
//! the one parser the CLI, its help texts, Python and the C++ bridge all use.

use crate::{Error, Result};

/// A set of names: its members, each member's name and description, and the parser.
pub trait Named: Copy + PartialEq + Sized + 'static {
    /// Every member, in the order lists show them.
    const ALL: &'static [Self];
    /// What a member is, as an error message names it (`method`, `[scheme] kind`).
    const WHAT: &'static str;

    /// The name users type and reports print.
    fn name(self) -> &'static str;

    /// What the member is, in one line (the CLI's help of the value).
    fn description(self) -> &'static str;

    /// The names joined as `a, b or c`, for "expected …" messages.
    fn expected() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
        match names.split_last() {
            Some((last, [])) => last.to_string(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => "nothing".to_string(),
        }
    }

    /// The member called `name`, or [`Error::Invalid`] naming it and every allowed name.
    fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "{} `{name}`: expected {}",
                    Self::WHAT,
                    Self::expected()
                ))
            })
    }
}

/// Declares a set of names from one table: the enum, its inherent `ALL`, `name` and
/// `description` (usable without importing [`Named`]), [`Named`], `Display` and `FromStr`.
macro_rules! named {
    (
        $(#[$meta:meta])*
        pub enum $t:ident ($what:literal) {
            $($(#[$vmeta:meta])* $v:ident = $name:literal, $desc:literal;)*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $t {
            $($(#[$vmeta])* $v,)*
        }

        impl $t {
            /// Every member, in the order lists show them.
            pub const ALL: &'static [$t] = &[$($t::$v),*];

            /// The name users type and reports print.
            pub fn name(self) -> &'static str {
                match self {
                    $($t::$v => $name,)*
                }
            }

            /// What it is, in one line (the help of the value).
            pub fn description(self) -> &'static str {
                match self {
                    $($t::$v => $desc,)*
                }
            }
        }

        impl $crate::names::Named for $t {
            const ALL: &'static [$t] = $t::ALL;
            const WHAT: &'static str = $what;

            fn name(self) -> &'static str {
                $t::name(self)
            }

            fn description(self) -> &'static str {
                $t::description(self)
            }
        }

        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str($t::name(*self))
            }
        }

        impl std::str::FromStr for $t {
            type Err = $crate::Error;

            fn from_str(s: &str) -> $crate::Result<Self> {
                <$t as $crate::names::Named>::from_name(s)
            }
        }
    };
}
pub(crate) use named;
