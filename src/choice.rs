//! Enums whose values have one spelling each, shared by the command line,
//! the labels of backends and the report. The library names its choices
//! here; the CLI turns them into parsers (`cli::choice`), so no library
//! type carries a command-line derive.

/// A closed set of named values.
pub trait Choice: Copy + PartialEq + 'static {
    /// Every value, in the order help texts list them.
    const ALL: &'static [Self];

    /// The value's spelling (lower case, words joined by `-`).
    fn name(self) -> &'static str;

    /// The value spelled `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|v| v.name() == name)
    }
}

/// Implements [`Choice`] for a fieldless enum: `choice!(Type { Variant =>
/// "name", ... })`.
#[macro_export]
macro_rules! choice {
    ($ty:ty { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $crate::choice::Choice for $ty {
            const ALL: &'static [Self] = &[$(<$ty>::$variant),+];
            fn name(self) -> &'static str {
                match self {
                    $(<$ty>::$variant => $name),+
                }
            }
        }
    };
}
