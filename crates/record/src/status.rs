//! A record's status: one type for what `docs/formats.md` lists as strings, written and read
//! as those strings.

use std::fmt;
use std::str::FromStr;

use flexshape_shape::Status;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// How a frame came out (`status` of a [`crate::TrackRecord`]; its `reason` says why).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum RecordStatus {
    /// A right shape.
    Ok,
    /// Too few voxels carved for an object.
    NoObject,
    /// The images allow more than one shape, or do not decide its direction.
    Ambiguous,
    /// The tube runs out through the volume's boundary: the curve stops there.
    LeavesVolume,
    /// The fitted tube does not explain the images, or takes a shape no tube can.
    Inconsistent,
    /// A camera's silhouette (or the hull carved from them) cannot be the tube's.
    BadSilhouette,
    /// Fewer marker bands than the rig expects.
    BandsMissing,
    /// The frame could not be read or processed.
    Error,
    /// A status this version does not know (a newer writer's), kept as written.
    Other(String),
}

impl RecordStatus {
    /// The documented string.
    pub fn as_str(&self) -> &str {
        match self {
            RecordStatus::Ok => "ok",
            RecordStatus::NoObject => "no_object",
            RecordStatus::Ambiguous => "ambiguous",
            RecordStatus::LeavesVolume => "leaves_volume",
            RecordStatus::Inconsistent => "inconsistent",
            RecordStatus::BadSilhouette => "bad_silhouette",
            RecordStatus::BandsMissing => "bands_missing",
            RecordStatus::Error => "error",
            RecordStatus::Other(s) => s,
        }
    }

    /// Whether the frame's shape is right.
    pub fn is_ok(&self) -> bool {
        *self == RecordStatus::Ok
    }

    /// Whether the status vouches for the record's shape: `ok`, `bands_missing` (a band is
    /// not seen) or `leaves_volume` (right up to the volume's boundary), as
    /// [`Status::is_right`] says; every other status says it must not be trusted.
    pub fn vouches_for_shape(&self) -> bool {
        matches!(
            self,
            RecordStatus::Ok | RecordStatus::BandsMissing | RecordStatus::LeavesVolume
        )
    }
}

/// The statuses this version writes, in the order [`RecordStatus`] lists them.
pub const STATUSES: [&str; 8] = [
    "ok",
    "no_object",
    "ambiguous",
    "leaves_volume",
    "inconsistent",
    "bad_silhouette",
    "bands_missing",
    "error",
];

impl schemars::JsonSchema for RecordStatus {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "RecordStatus".into()
    }

    /// The documented strings (a reader of a newer writer's file keeps an unknown one as
    /// written; this version writes only these).
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "type": "string",
            "enum": STATUSES,
            "description": "How the frame came out: `ok` only for a shape that explains every image; otherwise why not (`reason` says more)."
        })
    }
}

impl From<&Status> for RecordStatus {
    fn from(s: &Status) -> Self {
        match s {
            Status::Ok => RecordStatus::Ok,
            Status::NoObject { .. } => RecordStatus::NoObject,
            Status::Ambiguous { .. } => RecordStatus::Ambiguous,
            Status::LeavesVolume => RecordStatus::LeavesVolume,
            Status::Inconsistent { .. } => RecordStatus::Inconsistent,
            Status::BadSilhouette { .. } => RecordStatus::BadSilhouette,
            Status::BandsMissing { .. } => RecordStatus::BandsMissing,
        }
    }
}

impl FromStr for RecordStatus {
    type Err = std::convert::Infallible;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "ok" => RecordStatus::Ok,
            "no_object" => RecordStatus::NoObject,
            "ambiguous" => RecordStatus::Ambiguous,
            "leaves_volume" => RecordStatus::LeavesVolume,
            "inconsistent" => RecordStatus::Inconsistent,
            "bad_silhouette" => RecordStatus::BadSilhouette,
            "bands_missing" => RecordStatus::BandsMissing,
            "error" => RecordStatus::Error,
            other => RecordStatus::Other(other.to_string()),
        })
    }
}

impl fmt::Display for RecordStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

impl PartialEq<str> for RecordStatus {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for RecordStatus {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl Serialize for RecordStatus {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for RecordStatus {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let s = String::deserialize(deserializer)?;
        Ok(s.parse().unwrap_or(RecordStatus::Other(s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_are_written_and_read_as_the_documented_strings() {
        let all = [
            (RecordStatus::Ok, "ok"),
            (RecordStatus::NoObject, "no_object"),
            (RecordStatus::Ambiguous, "ambiguous"),
            (RecordStatus::LeavesVolume, "leaves_volume"),
            (RecordStatus::Inconsistent, "inconsistent"),
            (RecordStatus::BadSilhouette, "bad_silhouette"),
            (RecordStatus::BandsMissing, "bands_missing"),
            (RecordStatus::Error, "error"),
        ];
        for (status, text) in all {
            let json = serde_json::to_string(&status).unwrap();
            assert_eq!(json, format!("\"{text}\""));
            assert_eq!(serde_json::from_str::<RecordStatus>(&json).unwrap(), status);
            assert_eq!(status, text);
            assert_eq!(format!("{status:>4}"), format!("{text:>4}"));
        }
        let newer: RecordStatus = serde_json::from_str("\"occluded\"").unwrap();
        assert_eq!(newer, RecordStatus::Other("occluded".into()));
        assert_eq!(serde_json::to_string(&newer).unwrap(), "\"occluded\"");
        assert!(RecordStatus::Ok.is_ok() && !newer.is_ok());
    }
}
