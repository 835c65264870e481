//! What [`calibrate_rig`](super::calibrate_rig) can be told, checked before any image is read: the
//! board, the corners' height on a sweep and the projector's size. A refusal names the option as the
//! command line spells it (Python's keyword is the same without `--`).
//!
//! The bounds are those of real boards and rigs, with a wide margin:
//! - a board has 2 to [`MAX_BOARD_CORNERS`] inner corners a side (2×2 fixes a pose; a finer board spans
//!   too few pixels a square on any camera to be found);
//! - its squares measure [`MIN_SQUARE_MM`] to [`MAX_SQUARE_MM`] (a printed board on a desk scanner
//!   has 5–30 mm squares; a metre-wide square is a unit mistake);
//! - the lowest inner corners stand within ±[`MAX_CORNER_HEIGHT_MM`] of the platter;
//! - a projector has 1 to [`rig::camera::MAX_SIDE_PX`] pixels a side.

use super::RigCalibParams;
use rig::limits::ParamError;

/// The most inner corners a side of a chessboard.
pub const MAX_BOARD_CORNERS: usize = 200;
/// The smallest square side (mm): a hundredth of a millimetre, below any printed or etched board.
pub const MIN_SQUARE_MM: f64 = 0.01;
/// The largest square side (mm).
pub const MAX_SQUARE_MM: f64 = 1000.0;
/// The farthest the board's lowest inner corners may stand from the platter (mm).
pub const MAX_CORNER_HEIGHT_MM: f64 = 1000.0;

fn bad(option: &'static str, value: impl std::fmt::Display, why: impl Into<String>) -> ParamError {
    ParamError { option, value: value.to_string(), why: why.into() }
}

impl RigCalibParams {
    /// Checks every value against the bounds above; called first by
    /// [`calibrate_rig`](super::calibrate_rig), and by whoever reads images for it before reading them.
    pub fn validate(&self) -> Result<(), ParamError> {
        let b = &self.board;
        for (side, n) in [("across", b.cols), ("down", b.rows)] {
            if !(2..=MAX_BOARD_CORNERS).contains(&n) {
                return Err(bad(
                    "--board",
                    format!("{}x{}", b.cols, b.rows),
                    format!("{n} inner corners {side}: a board has 2 to {MAX_BOARD_CORNERS} inner corners a side"),
                ));
            }
        }
        if !(MIN_SQUARE_MM..=MAX_SQUARE_MM).contains(&b.square_mm) {
            return Err(bad(
                "--square",
                b.square_mm,
                format!("a square's side must be {MIN_SQUARE_MM} to {MAX_SQUARE_MM} mm"),
            ));
        }
        if let Some(h) = self.corner_height_mm
            && !(h.is_finite() && h.abs() <= MAX_CORNER_HEIGHT_MM)
        {
            return Err(bad(
                "--corner-height",
                h,
                format!("the corners' height above the platter must be finite and within ±{MAX_CORNER_HEIGHT_MM} mm"),
            ));
        }
        if let Some((w, h)) = self.projector_size {
            let max = rig::camera::MAX_SIDE_PX;
            if !((1..=max).contains(&w) && (1..=max).contains(&h)) {
                return Err(bad(
                    "--projector",
                    format!("{w}x{h}"),
                    format!("a projector has 1 to {max} pixels a side"),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workflow::{BoardSpec, Target};

    fn params() -> RigCalibParams {
        RigCalibParams {
            target: Target::All,
            board: BoardSpec { cols: 9, rows: 6, square_mm: 11.0, markers: None },
            orientation: Default::default(),
            lens: Default::default(),
            lens_model: Default::default(),
            corner_height_mm: None,
            projector_size: None,
        }
    }

    #[test]
    fn each_value_no_board_or_rig_has_is_refused_by_its_option() {
        assert_eq!(params().validate(), Ok(()));
        let refused = |p: RigCalibParams| p.validate().unwrap_err().option;
        for square in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e300, 1e-300] {
            assert_eq!(
                refused(RigCalibParams { board: BoardSpec { square_mm: square, ..params().board }, ..params() }),
                "--square"
            );
        }
        for cols in [0, 1, 201, usize::MAX] {
            assert_eq!(refused(RigCalibParams { board: BoardSpec { cols, ..params().board }, ..params() }), "--board");
        }
        for h in [f64::NAN, f64::NEG_INFINITY, 1e9] {
            assert_eq!(refused(RigCalibParams { corner_height_mm: Some(h), ..params() }), "--corner-height");
        }
        assert_eq!(refused(RigCalibParams { projector_size: Some((0, 768)), ..params() }), "--projector");
        assert_eq!(RigCalibParams { corner_height_mm: Some(-5.0), ..params() }.validate(), Ok(()));
    }
}
