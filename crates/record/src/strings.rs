//! Values the records write as documented strings (`docs/formats.md`): each one type, written
//! and read as its strings, a string this version does not know (a newer writer's) kept as
//! written (`Other`), so a reader never fails on a file a later flexshape wrote.

/// An enum of documented strings: `Name { Variant => "string", … }` with a doc line for the
/// JSON Schema. Gives the enum (with `Other(String)`), `as_str`, `STRINGS` (what this
/// version writes, in order), `FromStr` (never fails), `Display` (padded as a `str`),
/// comparison with `str`, serde as the string and a JSON Schema listing the strings.
macro_rules! documented_strings {
    (
        $(#[$meta:meta])*
        $name:ident, $schema:literal {
            $($(#[$vmeta:meta])* $variant:ident => $text:literal,)+
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq, Eq, Hash)]
        pub enum $name {
            $($(#[$vmeta])* $variant,)+
            /// A string this version does not know (a newer writer's), kept as written.
            Other(String),
        }

        impl $name {
            /// What this version writes, in the order the type lists them.
            pub const STRINGS: &'static [&'static str] = &[$($text,)+];

            /// The documented string.
            pub fn as_str(&self) -> &str {
                match self {
                    $($name::$variant => $text,)+
                    $name::Other(s) => s,
                }
            }
        }

        impl std::str::FromStr for $name {
            type Err = std::convert::Infallible;

            fn from_str(s: &str) -> Result<Self, Self::Err> {
                Ok(match s {
                    $($text => $name::$variant,)+
                    other => $name::Other(other.to_string()),
                })
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.pad(self.as_str())
            }
        }

        impl PartialEq<str> for $name {
            fn eq(&self, other: &str) -> bool {
                self.as_str() == other
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, other: &&str) -> bool {
                self.as_str() == *other
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                serializer.serialize_str(self.as_str())
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                let s = <String as serde::Deserialize>::deserialize(deserializer)?;
                Ok(s.parse().unwrap_or($name::Other(s)))
            }
        }

        impl schemars::JsonSchema for $name {
            fn schema_name() -> std::borrow::Cow<'static, str> {
                stringify!($name).into()
            }

            /// The documented strings (a reader of a newer writer's file keeps an unknown one
            /// as written; this version writes only these).
            fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
                schemars::json_schema!({
                    "type": "string",
                    "enum": $name::STRINGS,
                    "description": $schema
                })
            }
        }
    };
}

pub(crate) use documented_strings;

documented_strings! {
    /// How a record's centerline was found (`method`).
    Method, "How the centerline was found: `fit` (the tube fitted to every camera's outline) or `hull` (the visual hull's centerline alone)." {
        /// The tube fitted to every camera's outline, started from the hull or an earlier
        /// frame, and checked against the images.
        Fit => "fit",
        /// The visual hull's centerline alone (the paper's method), not checked against the
        /// images.
        Hull => "hull",
    }
}

documented_strings! {
    /// Where a record's fit started (`start`).
    Start, "Where the fit started: `hull` (this frame's visual hull), `previous` (an earlier frame's shape, nothing carved) or `views` (two cameras' silhouettes matched along epipolar lines)." {
        /// This frame's visual hull, carved.
        Hull => "hull",
        /// An earlier frame's fitted shape (tracking; nothing carved).
        Previous => "previous",
        /// The two cameras' silhouettes matched along epipolar lines (two-camera rigs, when
        /// the hull's start gave no right shape).
        Views => "views",
    }
}

documented_strings! {
    /// Where a record's capture time comes from (`captured_from`).
    CapturedFrom, "Where `captured_s` comes from: `clock`, `timestamps`, `file_time`, `stream` or `given`." {
        /// The wall clock when the frame arrived (live network cameras, the simulator).
        Clock => "clock",
        /// The recording's `timestamps.csv`.
        Timestamps => "timestamps",
        /// The first camera's image file's modification time (nothing else gave one).
        FileTime => "file_time",
        /// The cameras' streams: videos' own timelines, live devices' driver timestamps.
        Stream => "stream",
        /// The caller's (the Python `Tracker`'s `time=`).
        Given => "given",
    }
}

impl From<flexshape_fit::Method> for Method {
    fn from(m: flexshape_fit::Method) -> Self {
        match m {
            flexshape_fit::Method::Fit => Method::Fit,
            flexshape_fit::Method::Hull => Method::Hull,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_value_is_written_and_read_as_its_documented_string_and_unknown_ones_are_kept() {
        for (value, text) in [
            (Start::Hull, "hull"),
            (Start::Previous, "previous"),
            (Start::Views, "views"),
        ] {
            let json = serde_json::to_string(&value).unwrap();
            assert_eq!(json, format!("\"{text}\""));
            assert_eq!(serde_json::from_str::<Start>(&json).unwrap(), value);
            assert_eq!(value, text);
        }
        assert_eq!(CapturedFrom::FileTime.to_string(), "file_time");
        assert_eq!(Method::STRINGS, ["fit", "hull"]);
        let newer: CapturedFrom = serde_json::from_str("\"ptp\"").unwrap();
        assert_eq!(newer, CapturedFrom::Other("ptp".into()));
        assert_eq!(serde_json::to_string(&newer).unwrap(), "\"ptp\"");
        assert_eq!(format!("{:>6}", Method::Hull), "  hull");
    }
}
