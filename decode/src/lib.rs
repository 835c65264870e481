//! # decode — from frames to correspondences
//!
//! What a scanner's frames say before any geometry: which projector pixel lit each camera pixel
//! (structured light), and where in each row the laser stripe lies (laser lines). Both the geometry
//! pipeline (`process`) and calibration (`calib`) start here, so this crate depends on the
//! vocabulary crate alone.
//!
//! - [`structured_light::decode_view`]: Gray code with inverses ([`gray_code`]), shadow and contrast
//!   masks, N-step phase shift unwrapped by the Gray code ([`phase_shift`]), into a
//!   [`ProjectorMap`]; without phase shift, Gray-code coordinates refined to sub-pixel by local plane
//!   fits ([`gray_subpixel`]); the frames checked against each other on the way ([`frame_checks`]:
//!   complementary pairs, white over black, no dark frame, continuous and unmirrored codes);
//! - [`laser_line::detect_line`]: sub-pixel stripe centres (Gaussian fit or centre of mass) with
//!   faint, saturated and doubled rows rejected;
//! - [`colormap::turbo`]: the colour map of preview images.
//!
//! ```
//! use decode::gray_code::decode_pixel;
//! // Column 5 on 3 bits is Gray 0b111: every pattern frame brighter than its inverse.
//! let (column, weakest) = decode_pixel([(200, 40), (180, 60), (150, 90)].into_iter());
//! assert_eq!(column, 5);
//! assert_eq!(weakest, 60);
//! ```
#![deny(missing_docs)]

pub mod colormap;
pub mod frame_checks;
pub mod gray_code;
pub mod gray_subpixel;
pub mod laser_line;
pub mod phase_shift;
pub mod projector_map;
pub mod structured_light;

pub use frame_checks::{FrameIssue, IssueKind};
pub use laser_line::{LaserParams, LineReport, detect_line};
pub use projector_map::ProjectorMap;
pub use structured_light::{DecodeError, DecodeParams, DecodeReport, MAX_GRAY_FIT_RADIUS, decode_view};
