//! The JSON Schema (draft 2020-12) of what `flexshape track` writes, derived from the types
//! that write it: `docs/record.schema.json` is [`json_lines_schema`], and the MCAP file's
//! record channel carries [`record_schema`]. Additive changes to the records keep old readers
//! valid: no object forbids fields it does not list.

use schemars::{Schema, SchemaGenerator, json_schema};

use crate::{SummaryLine, TrackRecord};

/// One line of a `flexshape track` JSON Lines output: a frame's record, or the run's summary
/// (the last line).
pub fn json_lines_schema() -> Schema {
    let mut generator = SchemaGenerator::default();
    let record = generator.subschema_for::<TrackRecord>();
    let summary = generator.subschema_for::<SummaryLine>();
    let definitions = generator.take_definitions(true);
    json_schema!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://example.invalid/flexshape/record.schema.json",
        "title": "flexshape JSON Lines line",
        "description": "A line of `flexshape track`'s output (docs/formats.md): a frame's record, or the run's summary. World frame of the rig, millimetres, radians, seconds.",
        "oneOf": [record, summary],
        "$defs": definitions,
    })
}

/// A frame's record alone (`/flexshape/record` in MCAP files and live connections).
pub fn record_schema() -> Schema {
    schemars::schema_for!(TrackRecord)
}
