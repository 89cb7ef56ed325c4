//! Messages already encoded (CDR, as [`flexshape_mcap::msgs`] writes them) handed to RustDDS
//! as they are: its serializer adapters expect serde types, ours are bytes.

use bytes::Bytes;
use rustdds::RepresentationIdentifier;
use rustdds::no_key::{Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter};

/// One whole CDR message: the 4-byte encapsulation header (little-endian CDR), then the
/// data, as an MCAP file holds it. Read back, the data may end in up to 3 bytes of padding.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CdrMessage(pub Vec<u8>);

/// The encapsulation header of little-endian CDR, which [`flexshape_mcap::Cdr`] writes.
const CDR_LE_HEADER: [u8; 4] = [0, 1, 0, 0];

/// Carries [`CdrMessage`]s through RustDDS, which writes the encapsulation header itself.
#[derive(Debug, Clone, Copy)]
pub struct CdrAdapter;

/// A message that is not little-endian CDR.
#[derive(Debug, thiserror::Error)]
#[error("not a little-endian CDR message")]
pub struct NotCdr;

impl SerializerAdapter<CdrMessage> for CdrAdapter {
    type Error = NotCdr;

    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    fn to_bytes(value: &CdrMessage) -> Result<Bytes, NotCdr> {
        match value.0.strip_prefix(&CDR_LE_HEADER) {
            Some(data) => Ok(Bytes::copy_from_slice(data)),
            None => Err(NotCdr),
        }
    }
}

impl DeserializerAdapter<CdrMessage> for CdrAdapter {
    type Error = NotCdr;
    type Decoded = CdrMessage;

    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[RepresentationIdentifier::CDR_LE]
    }

    fn transform_decoded(decoded: CdrMessage) -> CdrMessage {
        decoded
    }
}

/// Puts the encapsulation header back in front of a received message's data.
#[derive(Debug, Clone, Copy)]
pub struct CdrDecoder;

impl Decode<'_, CdrMessage> for CdrDecoder {
    type Error = NotCdr;

    fn decode_bytes(
        self,
        input: &[u8],
        encoding: RepresentationIdentifier,
    ) -> Result<CdrMessage, NotCdr> {
        if encoding != RepresentationIdentifier::CDR_LE {
            return Err(NotCdr);
        }
        Ok(CdrMessage([&CDR_LE_HEADER[..], input].concat()))
    }
}

impl DefaultDecoder<CdrMessage> for CdrAdapter {
    type Decoder = CdrDecoder;
    const DECODER: CdrDecoder = CdrDecoder;
}
