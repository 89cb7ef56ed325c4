//! The CDR encoding ROS 2 messages travel in (OMG XCDR1, little-endian): a 4-byte
//! encapsulation header, then each field aligned to its own size counted from the end of that
//! header; strings as a length with their terminating NUL, sequences as a count then items.

/// One message being encoded.
pub struct Cdr {
    buf: Vec<u8>,
}

impl Default for Cdr {
    fn default() -> Self {
        Self::new()
    }
}

impl Cdr {
    /// An empty little-endian message.
    pub fn new() -> Self {
        Cdr {
            buf: vec![0x00, 0x01, 0x00, 0x00],
        }
    }

    fn align(&mut self, n: usize) {
        while !(self.buf.len() - 4).is_multiple_of(n) {
            self.buf.push(0);
        }
    }

    /// A `uint8`, `bool` or `byte`.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `string`.
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }

    /// The count of an unbounded sequence (its items follow).
    pub fn count(&mut self, n: usize) -> &mut Self {
        self.u32(n as u32)
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self, data: &[u8]) -> &mut Self {
        self.count(data.len());
        self.buf.extend_from_slice(data);
        self
    }

    /// The encoded message.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

#[cfg(test)]
mod tests {
    use super::Cdr;

    #[test]
    fn fields_are_aligned_from_the_end_of_the_header() {
        let mut c = Cdr::new();
        c.u8(1).f64(2.0).string("ab").u8(7).u32(5);
        let b = c.finish();
        assert_eq!(&b[..4], &[0, 1, 0, 0]);
        assert_eq!(b[4], 1);
        // The f64 starts 8 bytes after the header.
        assert_eq!(&b[12..20], &2.0f64.to_le_bytes());
        // "ab" with its NUL: length 3, then the bytes.
        assert_eq!(&b[20..24], &3u32.to_le_bytes());
        assert_eq!(&b[24..27], b"ab\0");
        assert_eq!(b[27], 7);
        assert_eq!(&b[28..32], &5u32.to_le_bytes());
        assert_eq!(b.len(), 32);
    }
}
