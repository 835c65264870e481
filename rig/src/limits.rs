//! The bounds scanrig holds rigs and scan manifests to, in one place. Whatever reads or imports a rig
//! ([`Rig::validate`](crate::Rig::validate): rig.toml, Horus and FabScanPi configurations, OpenCV YAML,
//! a simulator's `[rig]`) or a scan manifest ([`Manifest::from_json`](crate::Manifest::from_json))
//! refuses a value outside them, naming the file and the field.
//!
//! The bounds are chosen from real lenses and scanners, with a wide margin, so that a real calibration is
//! never refused and a value no lens can have (a mistyped exponent, a failed fit) never reaches a stage:
//! - Radial distortion: webcams and Raspberry Pi cameras calibrate to |k1| < 1, |k2| < 5, and OpenCV's
//!   five-term fit of a wide-angle lens gives |k3| of a few tens at most (the FabScanPi sample: k1 0.145,
//!   k2 0.154, k3 −1.15). [`MAX_RADIAL_DISTORTION`] allows a thousand.
//! - Tangential distortion: a decentred lens gives |p1|, |p2| of 10⁻³ to 10⁻²; [`MAX_TANGENTIAL_DISTORTION`]
//!   allows one.
//! - The distortion is *not* required to be invertible out to the image's corners: real five-term fits
//!   often fold over there (the FabScanPi sample's does beyond r² ≈ 0.5), and are used inside that radius.
//! - A camera's principal point lies inside its image (pixel centres run from 0 to size − 1, so
//!   [−0.5, size − 0.5]); a projector's lens is often shifted (its principal point near or past the
//!   bottom edge), so it may lie up to [`PROJECTOR_PRINCIPAL_POINT_MARGIN`] image sizes beyond.
//! - Laser planes and the turntable's platter lie in front of the camera (positive depth); a plane is in
//!   front when some ray through the image meets it at positive depth, and a plane through the camera's
//!   centre is refused (it cannot triangulate).
//! - The platter's radius and the working height are positive and finite; every number is finite.
//! - A scan view's `angle_deg` is finite and within ±[`MAX_ABS_ANGLE_DEG`] (ten turns: a multi-turn
//!   capture numbers its angles on, nothing real goes further).

/// The largest |k1|, |k2|, |k3| a rig may have.
pub const MAX_RADIAL_DISTORTION: f64 = 1e3;
/// The largest |p1|, |p2| a rig may have.
pub const MAX_TANGENTIAL_DISTORTION: f64 = 1.0;
/// How far (in image widths and heights) beyond its image a projector's principal point may lie.
pub const PROJECTOR_PRINCIPAL_POINT_MARGIN: f64 = 1.0;
/// The largest |angle_deg| a scan view may have: ten turns.
pub const MAX_ABS_ANGLE_DEG: f64 = 3600.0;

/// A parameter outside what its stage can use, as every crate refuses one: names the option (as the
/// command line spells it; Python's keyword is the same without `--` and with `_`), the value and what
/// it must be. Decoding, processing and the simulator each check their own parameters and return this.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{option} {value}: {why}")]
pub struct ParamError {
    /// The option (`--k`), or the field where no option sets it.
    pub option: &'static str,
    /// The value given.
    pub value: String,
    /// What it must be.
    pub why: String,
}
