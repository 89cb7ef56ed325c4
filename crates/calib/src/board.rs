//! The calibration target.

use nalgebra::Point3;

/// A chessboard: `cols × rows` inner corners, `square` mm apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Inner corners along the board's x direction.
    pub cols: usize,
    /// Inner corners along y.
    pub rows: usize,
    /// Square edge, mm.
    pub square: f64,
}

impl Board {
    /// Parses `COLSxROWS` (e.g. `9x6`) with the square size in mm.
    pub fn parse(size: &str, square: f64) -> Result<Self, String> {
        let (c, r) = size
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("`{size}`: give inner corners as COLSxROWS, e.g. 9x6"))?;
        let parse = |s: &str| {
            s.trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 2)
                .ok_or_else(|| format!("`{size}`: inner corner counts must be integers ≥ 2"))
        };
        if !(square.is_finite() && square > 0.0) {
            return Err(format!(
                "square size {square} must be a positive length in mm"
            ));
        }
        Ok(Board {
            cols: parse(c)?,
            rows: parse(r)?,
            square,
        })
    }

    /// Number of inner corners.
    pub fn corners(&self) -> usize {
        self.cols * self.rows
    }

    /// Corner `(c, r)` in the board frame, mm: `(c·square, r·square, 0)`.
    pub fn point(&self, c: usize, r: usize) -> Point3<f64> {
        Point3::new(c as f64 * self.square, r as f64 * self.square, 0.0)
    }

    /// All corners, row by row (`c` fastest), as [`crate::Detection::corners`] orders them.
    pub fn points(&self) -> Vec<Point3<f64>> {
        (0..self.rows)
            .flat_map(|r| (0..self.cols).map(move |c| self.point(c, r)))
            .collect()
    }
}
