//! Laser lines into geometry: the stripe centres [`decode::laser_line`] finds in each row, each
//! camera ray through one against the laser's plane (eq. 2.3's general form).

pub use decode::laser_line::*;

use crate::triangulate::camera_ray_plane;
use rig::math::{Point2, Point3, Real};
use rig::{LaserPlane, PinholeCamera, Sensor, SparseView};

/// Triangulates stripe centres against a laser plane into a sparse view (camera frame): one point per
/// centre whose ray meets the plane, with its subpixel pixel; confidence is the peak height over 255.
pub fn triangulate_line(peaks: &[LinePeak], camera: &PinholeCamera, plane: &LaserPlane) -> SparseView {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut view = SparseView::empty(w, h, Sensor::Center(Point3::origin()));
    for pk in peaks {
        let Some(p) = camera_ray_plane(camera, Point2::new(pk.col, pk.row as Real), plane) else { continue };
        view.push(p, [pk.col as f32, pk.row as f32], (pk.peak / 255.0) as f32);
    }
    view
}
