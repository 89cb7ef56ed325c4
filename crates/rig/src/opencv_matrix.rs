//! The `!!opencv-matrix` node of `cv::FileStorage` (`rows`, `cols`, `dt`, `data`, row-major), in
//! YAML and in OpenCV's JSON (`"type_id": "opencv-matrix"`); plain JSON arrays are accepted too.

use serde::{Deserialize, Serialize};

/// A matrix as it appears in a camera file.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub(crate) enum RawMatrix {
    /// OpenCV's node; `type_id` (JSON) is ignored on read.
    OpenCv {
        rows: usize,
        cols: usize,
        #[serde(default)]
        dt: Option<String>,
        data: Vec<f64>,
    },
    /// Nested rows, `[[a, b, c], [d, e, f], …]`.
    Nested(Vec<Vec<f64>>),
    /// A flat list (vectors).
    Flat(Vec<f64>),
}

impl RawMatrix {
    /// Row-major elements and shape, or a description of the inconsistency.
    pub(crate) fn elements(&self) -> Result<(usize, usize, Vec<f64>), String> {
        match self {
            RawMatrix::OpenCv {
                rows,
                cols,
                dt,
                data,
            } => {
                if let Some(dt) = dt
                    && !matches!(dt.as_str(), "d" | "f" | "i" | "u" | "s" | "w" | "c")
                {
                    return Err(format!("unsupported element type dt: {dt}"));
                }
                if rows * cols != data.len() {
                    return Err(format!(
                        "rows × cols = {rows} × {cols} but data has {} values",
                        data.len()
                    ));
                }
                Ok((*rows, *cols, data.clone()))
            }
            RawMatrix::Nested(rows) => {
                let cols = rows.first().map_or(0, Vec::len);
                if rows.iter().any(|r| r.len() != cols) {
                    return Err("rows have different lengths".into());
                }
                Ok((rows.len(), cols, rows.concat()))
            }
            RawMatrix::Flat(v) => Ok((v.len(), 1, v.clone())),
        }
    }
}

/// OpenCV's JSON form of a matrix (what `cv::FileStorage` writes to `.json`).
#[derive(Debug, Serialize)]
pub(crate) struct JsonMatrix {
    pub type_id: &'static str,
    pub rows: usize,
    pub cols: usize,
    pub dt: &'static str,
    pub data: Vec<f64>,
}

impl JsonMatrix {
    pub(crate) fn new(rows: usize, cols: usize, data: Vec<f64>) -> Self {
        JsonMatrix {
            type_id: "opencv-matrix",
            rows,
            cols,
            dt: "d",
            data,
        }
    }
}

/// Formats a double so that it reads back exactly, in a form OpenCV's and YAML's float parsers
/// accept (`612.0`, `-0.0091`, `1.5e-7`).
pub(crate) fn format_f64(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-4..1e15).contains(&a) {
        let s = format!("{v}");
        if s.contains('.') { s } else { format!("{s}.0") }
    } else {
        format!("{v:e}")
    }
}

/// Writes one `!!opencv-matrix` node in OpenCV's YAML layout.
pub(crate) fn yaml_matrix(out: &mut String, key: &str, rows: usize, cols: usize, data: &[f64]) {
    let values: Vec<String> = data.iter().map(|&v| format_f64(v)).collect();
    out.push_str(&format!(
        "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        values.join(", ")
    ));
}

#[cfg(test)]
mod tests {
    use super::format_f64;

    #[test]
    fn formatted_doubles_read_back_exactly() {
        for v in [0.0, 612.0, -0.0091, 1.5e-7, 0.0456, 1e300, -3.0e-12, 0.5] {
            let s = format_f64(v);
            assert_eq!(s.parse::<f64>().unwrap(), v, "{s}");
            assert!(
                s.contains('.') || s.contains('e'),
                "{s} must read as a float"
            );
        }
    }
}
