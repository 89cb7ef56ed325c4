//! The calibration target.

use nalgebra::Point3;

/// A calibration target: `cols × rows` points (a chessboard's or ChArUco board's inner
/// corners, a circle grid's circles), see [`Board::point`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Points along the board's x direction.
    pub cols: usize,
    /// Points along y.
    pub rows: usize,
    /// Square edge, mm (circle grids: the distance between neighbouring circles of a
    /// symmetric grid; half that between neighbours in a row of an asymmetric one, as OpenCV's
    /// calibration sample has it).
    pub square: f64,
    /// What the board shows.
    pub pattern: Pattern,
}

/// What a [`Board`] shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pattern {
    /// A chessboard: every view must show it whole.
    Chessboard,
    /// A ChArUco board: a chessboard with ArUco markers in its light squares.
    Charuco(Markers),
    /// Dark circles on a light board (OpenCV's circle grids): symmetric, or asymmetric (rows
    /// offset by half a spacing). Every view must show it whole.
    Circles {
        /// OpenCV's asymmetric layout.
        asymmetric: bool,
    },
}

/// The markers in a ChArUco board's light squares, in OpenCV's layout since 4.6 (the
/// top-left square dark; markers numbered row by row over the light squares). Each view
/// identifies the corners it sees, so part of the board is enough.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Markers {
    /// Marker edge, mm.
    pub side: f64,
    /// ArUco dictionary, by OpenCV's name (e.g. `DICT_4X4_50`).
    pub dictionary: &'static str,
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
            pattern: Pattern::Chessboard,
        })
    }

    /// The board `spec` names: `COLSxROWS` inner corners of a chessboard, or
    /// `charuco:SXxSY` squares of a ChArUco board (then `marker`, the marker edge in mm, is
    /// needed, and `dictionary` names its ArUco dictionary); `square` mm squares.
    pub fn from_spec(
        spec: &str,
        square: f64,
        marker: Option<f64>,
        dictionary: &str,
    ) -> Result<Self, String> {
        if let Some(squares) = spec.strip_prefix("charuco:") {
            let marker = marker
                .ok_or_else(|| "a ChArUco board needs its marker size (--marker MM)".to_string())?;
            return Board::charuco(squares, square, marker, dictionary);
        }
        if marker.is_some() {
            return Err(format!(
                "`{spec}` has no markers: give charuco:SXxSY for a ChArUco board"
            ));
        }
        let circles = |size: &str, asymmetric: bool| {
            let mut board = Board::parse(size, square)?;
            board.pattern = Pattern::Circles { asymmetric };
            Ok(board)
        };
        match spec.split_once(':') {
            Some(("circles", size)) => circles(size, false),
            Some(("acircles", size)) => circles(size, true),
            Some((kind, _)) => Err(format!(
                "`{spec}`: unknown board kind `{kind}` (COLSxROWS for a chessboard, charuco:SXxSY, circles:COLSxROWS or acircles:COLSxROWS)"
            )),
            None => Board::parse(spec, square),
        }
    }

    /// A ChArUco board of `squares` (`SXxSY` squares, e.g. `11x8`: OpenCV's and printing
    /// tools' count, one more each way than inner corners), `square` mm squares, markers of
    /// `marker` mm from the ArUco dictionary named `dictionary`.
    pub fn charuco(
        squares: &str,
        square: f64,
        marker: f64,
        dictionary: &str,
    ) -> Result<Self, String> {
        let (sx, sy) = squares.split_once(['x', 'X']).ok_or_else(|| {
            format!("`{squares}`: give the ChArUco board's squares as SXxSY, e.g. 11x8")
        })?;
        let parse = |s: &str| {
            s.trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 3)
                .ok_or_else(|| format!("`{squares}`: square counts must be integers ≥ 3"))
        };
        let (sx, sy) = (parse(sx)?, parse(sy)?);
        let mut board = Board::parse(&format!("{}x{}", sx - 1, sy - 1), square)?;
        if !(marker.is_finite() && marker > 0.0 && marker < square) {
            return Err(format!(
                "marker size {marker} mm must be positive and smaller than the square ({square} mm)"
            ));
        }
        let dict = calib_targets::aruco::resolve_dictionary(dictionary).ok_or_else(|| {
            format!("unknown ArUco dictionary `{dictionary}`: give OpenCV's name, e.g. DICT_4X4_50, DICT_5X5_100, DICT_6X6_250")
        })?;
        let needed = sx * sy / 2;
        if dict.codes().len() < needed {
            return Err(format!(
                "dictionary {} has {} markers; a {sx}×{sy} board needs {needed}",
                dict.name(),
                dict.codes().len()
            ));
        }
        board.pattern = Pattern::Charuco(Markers {
            side: marker,
            dictionary: dict.name(),
        });
        Ok(board)
    }

    /// The half turn about the board's centre that maps its points onto one another in
    /// reverse order (`X ↦ (W − x, H − y, 0)`), for a board that looks the same turned (a
    /// symmetric circle grid); `None` for boards that tell their ends apart.
    pub fn half_turn(&self) -> Option<crate::BoardPose> {
        if self.pattern != (Pattern::Circles { asymmetric: false }) {
            return None;
        }
        let far = self.point(self.cols - 1, self.rows - 1);
        Some(crate::BoardPose {
            rotation: nalgebra::Rotation3::from_axis_angle(
                &nalgebra::Vector3::z_axis(),
                std::f64::consts::PI,
            ),
            translation: far.coords,
        })
    }

    /// Number of inner corners.
    pub fn corners(&self) -> usize {
        self.cols * self.rows
    }

    /// Point `(c, r)` in the board frame, mm: `(c·square, r·square, 0)`; on an asymmetric
    /// circle grid `((2c + r mod 2)·square, r·square, 0)`.
    pub fn point(&self, c: usize, r: usize) -> Point3<f64> {
        let x = match self.pattern {
            Pattern::Circles { asymmetric: true } => 2 * c + r % 2,
            _ => c,
        };
        Point3::new(x as f64 * self.square, r as f64 * self.square, 0.0)
    }

    /// All corners, row by row (`c` fastest), as [`crate::Detection::corners`] orders them.
    pub fn points(&self) -> Vec<Point3<f64>> {
        (0..self.rows)
            .flat_map(|r| (0..self.cols).map(move |c| self.point(c, r)))
            .collect()
    }
}
