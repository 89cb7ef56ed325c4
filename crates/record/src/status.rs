//! A record's status: one type for what `docs/formats.md` lists as strings, written and read
//! as those strings.

use flexshape_shape::Status;

use crate::strings::documented_strings;

documented_strings! {
    /// How a frame came out (`status` of a [`crate::TrackRecord`]; its `reason` says why).
    RecordStatus, "How the frame came out: `ok` only for a shape that explains every image; otherwise why not (`reason` says more)." {
        /// A right shape.
        Ok => "ok",
        /// Too few voxels carved for an object.
        NoObject => "no_object",
        /// The images allow more than one shape, or do not decide its direction.
        Ambiguous => "ambiguous",
        /// The tube runs out through the volume's boundary: the curve stops there.
        LeavesVolume => "leaves_volume",
        /// The fitted tube does not explain the images, or takes a shape no tube can.
        Inconsistent => "inconsistent",
        /// A camera's silhouette (or the hull carved from them) cannot be the tube's.
        BadSilhouette => "bad_silhouette",
        /// Fewer marker bands than the rig expects.
        BandsMissing => "bands_missing",
        /// The frame could not be read or processed.
        Error => "error",
    }
}

impl RecordStatus {
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
pub const STATUSES: &[&str] = RecordStatus::STRINGS;

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
