//! NumPy `.npy` arrays of numbers (format versions 1–3): little- or big-endian `f8`/`f4`/`i8`/`i4`,
//! C or Fortran order. Enough for the matrices (and image sizes) labs save with `np.save`.

use std::path::Path;

use crate::RigError;

/// An array: its shape and its values in C (row-major) order.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Array {
    pub shape: Vec<usize>,
    pub data: Vec<f64>,
}

/// Parses the bytes of a `.npy` file (`path` names it in errors).
pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Array, RigError> {
    let bad = |problem: &str| RigError::field(path, "npy header", problem.to_string());
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("not a NumPy .npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(bad(&format!("format version {v} is not 1, 2 or 3"))),
    };
    let header = bytes
        .get(start..start + len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or_else(|| bad("header cut short or not text"))?;
    let descr = value_of(header, "descr").ok_or_else(|| bad("no 'descr'"))?;
    let descr = descr
        .trim_start_matches(['\'', '"'])
        .split(['\'', '"'])
        .next()
        .unwrap_or("");
    // (bytes per element, big-endian, integer): integers for sizes saved as `np.array(size)`.
    let (size, big, int) = match descr {
        "<f8" | "=f8" | "|f8" => (8, false, false),
        ">f8" => (8, true, false),
        "<f4" | "=f4" | "|f4" => (4, false, false),
        ">f4" => (4, true, false),
        "<i8" | "=i8" => (8, false, true),
        ">i8" => (8, true, true),
        "<i4" | "=i4" => (4, false, true),
        ">i4" => (4, true, true),
        other => {
            return Err(bad(&format!(
                "element type {other}: only float64, float32, int64 or int32 arrays are read (save with .astype(np.float64))"
            )));
        }
    };
    let fortran = value_of(header, "fortran_order")
        .ok_or_else(|| bad("no 'fortran_order'"))?
        .starts_with("True");
    let shape_text = value_of(header, "shape").ok_or_else(|| bad("no 'shape'"))?;
    let shape: Vec<usize> = shape_text
        .trim_start_matches('(')
        .split(')')
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| bad("shape is not a tuple of sizes"))
        })
        .collect::<Result<_, _>>()?;
    // In bytes, checked: a shape of 2⁶¹ values of 8 bytes wrapped to 0 and matched an empty
    // body.
    let needed = shape
        .iter()
        .try_fold(size, |a: usize, &d| a.checked_mul(d))
        .ok_or_else(|| bad("shape too large"))?;
    let body = &bytes[start + len..];
    if body.len() != needed {
        return Err(bad(&format!(
            "shape {shape:?} needs {needed} bytes of data, the file has {}",
            body.len()
        )));
    }
    let mut data: Vec<f64> = body
        .chunks_exact(size)
        .map(|c| {
            let b8 = || c.try_into().unwrap_or([0; 8]);
            let b4 = || c.try_into().unwrap_or([0; 4]);
            match (size, big, int) {
                (8, false, false) => f64::from_le_bytes(b8()),
                (8, true, false) => f64::from_be_bytes(b8()),
                (8, false, true) => i64::from_le_bytes(b8()) as f64,
                (8, true, true) => i64::from_be_bytes(b8()) as f64,
                (_, false, false) => f32::from_le_bytes(b4()) as f64,
                (_, true, false) => f32::from_be_bytes(b4()) as f64,
                (_, false, true) => i32::from_le_bytes(b4()) as f64,
                (_, true, true) => i32::from_be_bytes(b4()) as f64,
            }
        })
        .collect();
    if fortran && shape.len() > 1 {
        data = to_c_order(&data, &shape);
    }
    Ok(Array { shape, data })
}

/// The text after `'key':` in a header dictionary, up to the end of the header.
fn value_of<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header
        .find(&format!("'{key}'"))
        .or_else(|| header.find(&format!("\"{key}\"")))?;
    let rest = &header[at + key.len() + 2..];
    Some(rest.trim_start().strip_prefix(':')?.trim_start())
}

/// Column-major values reordered row-major.
fn to_c_order(data: &[f64], shape: &[usize]) -> Vec<f64> {
    let n = shape.len();
    let mut out = vec![0.0; data.len()];
    let mut index = vec![0usize; n];
    for (f, &v) in data.iter().enumerate() {
        // Fortran: the first index runs fastest.
        let mut r = f;
        for (k, i) in index.iter_mut().enumerate() {
            *i = r % shape[k];
            r /= shape[k];
        }
        let c = index.iter().zip(shape).fold(0, |acc, (&i, &d)| acc * d + i);
        out[c] = v;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(descr: &str, fortran: bool, shape: &str, body: &[u8]) -> Vec<u8> {
        let mut header = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
            if fortran { "True" } else { "False" }
        );
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend((header.len() as u16).to_le_bytes());
        out.extend(header.as_bytes());
        out.extend(body);
        out
    }

    #[test]
    fn reads_c_and_fortran_order_doubles_and_floats() {
        let values: Vec<u8> = (0..6).flat_map(|v| (v as f64).to_le_bytes()).collect();
        let a = parse(Path::new("a.npy"), &npy("<f8", false, "(2, 3)", &values)).unwrap();
        assert_eq!(a.shape, vec![2, 3]);
        assert_eq!(a.data, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        // Fortran order: the same bytes are the columns.
        let f = parse(Path::new("f.npy"), &npy("<f8", true, "(2, 3)", &values)).unwrap();
        assert_eq!(f.data, vec![0.0, 2.0, 4.0, 1.0, 3.0, 5.0]);
        let floats: Vec<u8> = [1.5f32, -2.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let g = parse(Path::new("g.npy"), &npy("<f4", false, "(2,)", &floats)).unwrap();
        assert_eq!((g.shape, g.data), (vec![2], vec![1.5, -2.0]));
    }

    #[test]
    fn refuses_what_it_cannot_read_naming_why() {
        let e = parse(Path::new("x.npy"), b"hello").unwrap_err().to_string();
        assert!(e.contains("x.npy") && e.contains("magic"), "{e}");
        let bools = npy("|b1", false, "(1,)", &[0]);
        let e = parse(Path::new("b.npy"), &bools).unwrap_err().to_string();
        assert!(e.contains("float64"), "{e}");
        // Integers are read (an image size saved as np.array((1280, 720))).
        let ints: Vec<u8> = [1280i64, 720]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let i = parse(Path::new("i.npy"), &npy("<i8", false, "(2,)", &ints)).unwrap();
        assert_eq!(i.data, [1280.0, 720.0]);
        let short = npy("<f8", false, "(3, 4)", &[0; 8]);
        let e = parse(Path::new("s.npy"), &short).unwrap_err().to_string();
        assert!(e.contains("96 bytes"), "{e}");
        // 2⁶¹ doubles are 2⁶⁴ bytes: that wrapped to 0 and an empty body passed.
        for shape in ["(2305843009213693952,)", "(1073741824, 2147483648)"] {
            let wrapped = npy("<f8", false, shape, &[]);
            let e = parse(Path::new("w.npy"), &wrapped).unwrap_err().to_string();
            assert!(e.contains("too large"), "{shape}: {e}");
        }
    }
}
