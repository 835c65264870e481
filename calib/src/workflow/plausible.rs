//! The plausibility check of a calibration: figures that no working rig gives, found in the report
//! and the rig. A calibration can converge and still be wrong — a `--board` that counts a sub-grid of
//! the real board matches corners to the wrong squares in some views, too few corners let the lens
//! terms run away — and a wrong rig costs every scan made with it. Each finding is one sentence
//! naming the figure and its limit; `scanrig calibrate` warns with them and refuses to write the rig
//! unless forced.

use super::report::CalibReport;
use rig::{PinholeCamera, Rig};

/// Reprojection error beyond which corners were matched to the wrong squares or the images are
/// unusable: sub-pixel corners give a good calibration well under 0.5 px, a poor one about 1 px.
pub const MAX_RMS_PX: f64 = 2.0;
/// How far the principal point may lie from the image centre, as a fraction of the image size: lenses
/// are centred on their sensors to within a few per cent.
pub const MAX_CENTRE_OFFSET: f64 = 0.3;
/// Largest radial distortion term (k1, k2, k3) a lens that the pinhole-with-distortion model suits
/// has; beyond it the terms fit noise (too few corners, or too little of the image covered).
pub const MAX_RADIAL: f64 = 5.0;
/// Largest tangential term (p1, p2): a lens tilted on its sensor by a degree gives about 0.01.
pub const MAX_TANGENTIAL: f64 = 0.1;
/// Pixels are square to within a few per cent on every camera made for machine vision.
pub const MAX_ASPECT_ERROR: f64 = 0.2;
/// Spread of a fitted plane or circle beyond which the laser or turntable fit is not one plane or one
/// turn (mm).
pub const MAX_SPREAD_MM: f64 = 2.0;

/// Over the limit, or not a number.
fn beyond(v: f64, limit: f64) -> bool {
    v.is_nan() || v > limit
}

/// The findings for `rig` as calibrated, with `report` as [`crate::calibrate_rig`] wrote it.
pub fn findings(rig: &Rig, report: &CalibReport) -> Vec<String> {
    let mut out = Vec::new();
    let mut rms = |what: &str, value: Option<f64>| {
        if let Some(v) = value
            && beyond(v, MAX_RMS_PX)
        {
            out.push(format!(
                "{what} RMS reprojection error {v:.2} px is over {MAX_RMS_PX} px: corners were matched to the \
                 wrong squares (does --board count the board's inner corners?) or the images are blurred"
            ));
        }
    };
    rms("camera", report.camera.as_ref().map(|c| c.rms_px));
    rms("turntable sweep", report.turntable.as_ref().and_then(|t| t.rms_px));
    rms("projector–camera stereo", report.projector.as_ref().map(|p| p.stereo_rms_px));
    if let Some(v) = report.turntable.as_ref().and_then(|t| t.circle_rms_mm)
        && beyond(v, MAX_SPREAD_MM)
    {
        out.push(format!("the board's corners lie {v:.2} mm RMS off circles about one axis (over {MAX_SPREAD_MM} mm)"));
    }
    for l in report.lasers.iter().flatten() {
        if beyond(l.spread_rms_mm, MAX_SPREAD_MM) {
            out.push(format!(
                "laser {}'s points lie {:.2} mm RMS off one plane (over {MAX_SPREAD_MM} mm)",
                l.laser, l.spread_rms_mm
            ));
        }
    }
    if report.camera.is_some() {
        out.extend(lens_findings("camera", &rig.camera));
    }
    // The rules every rig reader holds a rig to (rig::limits): a calibration that breaks one would
    // be refused by the next command that reads the file, so it is not written as a success.
    if let Err(p) = rig.validate() {
        out.push(format!("the calibrated rig would not be readable: {p}"));
    }
    out
}

/// The findings on a camera's lens: principal point, aspect and distortion.
pub fn lens_findings(what: &str, c: &PinholeCamera) -> Vec<String> {
    let mut out = Vec::new();
    let (w, h) = (c.width as f64, c.height as f64);
    let off = |p: f64, size: f64| (p - (size - 1.0) / 2.0).abs() / size;
    if !(off(c.cx, w) <= MAX_CENTRE_OFFSET && off(c.cy, h) <= MAX_CENTRE_OFFSET) {
        out.push(format!(
            "{what} principal point ({:.1}, {:.1}) px is far from the centre of the {}x{} image (more than {} % \
             of its size): too few corners, or too little of the image covered by the board",
            c.cx,
            c.cy,
            c.width,
            c.height,
            100.0 * MAX_CENTRE_OFFSET
        ));
    }
    if beyond((c.fx / c.fy - 1.0).abs(), MAX_ASPECT_ERROR) {
        out.push(format!("{what} focal lengths fx {:.1} and fy {:.1} px describe pixels far from square", c.fx, c.fy));
    }
    let d = c.distortion.to_opencv();
    for (name, &k) in ["k1", "k2", "p1", "p2", "k3"].iter().zip(&d) {
        let limit = if name.starts_with('p') { MAX_TANGENTIAL } else { MAX_RADIAL };
        if beyond(k.abs(), limit) {
            out.push(format!(
                "{what} distortion {name} = {k:.3} is beyond any lens this model suits (|{name}| ≤ {limit}): \
                 the terms fit noise; more board poses over the whole image, or --fix-k3"
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> PinholeCamera {
        PinholeCamera::ideal(320, 256, 300.0)
    }

    #[test]
    fn a_good_camera_passes_and_each_bad_figure_is_named() {
        assert!(lens_findings("camera", &camera()).is_empty());
        let mut c = camera();
        c.cy = 268.9;
        let f = lens_findings("camera", &c);
        assert!(f.len() == 1 && f[0].contains("principal point (159.5, 268.9)"), "{f:?}");
        let mut c = camera();
        c.fy = 200.0;
        assert!(lens_findings("camera", &c)[0].contains("far from square"));
        let mut c = camera();
        c.distortion.k3 = -22.4;
        let f = lens_findings("camera", &c);
        assert!(f.len() == 1 && f[0].contains("k3 = -22.400"), "{f:?}");
    }

    #[test]
    fn a_large_reprojection_error_is_named_with_its_step() {
        let rig = crate::workflow::camera_only("r", camera());
        let sweep = |rms: f64| super::super::report::TurntableReport { rms_px: Some(rms), ..Default::default() };
        let mut report = CalibReport { turntable: Some(sweep(8.3)), ..Default::default() };
        let f = findings(&rig, &report);
        assert!(f.len() == 1 && f[0].starts_with("turntable sweep RMS reprojection error 8.30 px"), "{f:?}");
        report.turntable = Some(sweep(f64::NAN));
        assert_eq!(findings(&rig, &report).len(), 1, "NaN (null in JSON) is not plausible");
    }

    #[test]
    fn a_rig_no_reader_would_take_is_a_finding() {
        let mut rig = crate::workflow::camera_only("r", camera());
        assert!(findings(&rig, &CalibReport::default()).is_empty());
        rig.platter_radius_mm = Some(-3.0);
        let f = findings(&rig, &CalibReport::default());
        assert!(f.len() == 1 && f[0].contains("platter_radius_mm"), "{f:?}");
    }
}
