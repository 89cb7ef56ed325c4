//! Camera calibration: chessboard detection, intrinsics and multi-camera extrinsics (issue 7; not yet built).
