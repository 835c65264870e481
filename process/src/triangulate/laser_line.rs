//! Laser lines into geometry: the stripe centres [`decode::laser_line`] finds in each row, each
//! camera ray through one against the laser's plane (eq. 2.3's general form).

pub use decode::laser_line::*;

use crate::triangulate::camera_ray_plane;
use rig::math::{Point2, Point3, Real};
use rig::{LaserPlane, PinholeCamera, RangeGrid, Sensor};

/// Triangulates stripe centres against a laser plane into a range grid (camera frame): each point sits in
/// the cell of its row and nearest column; confidence is the peak height over 255.
pub fn triangulate_line(peaks: &[LinePeak], camera: &PinholeCamera, plane: &LaserPlane) -> RangeGrid {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut grid = RangeGrid::empty(w, h, Sensor::Center(Point3::origin()));
    let mut conf = vec![0.0f32; w * h];
    for pk in peaks {
        let Some(p) = camera_ray_plane(camera, Point2::new(pk.col, pk.row as Real), plane) else { continue };
        let c = (pk.col.round() as usize).min(w - 1);
        let i = pk.row * w + c;
        grid.points[i] = p;
        grid.valid[i] = true;
        conf[i] = (pk.peak / 255.0) as f32;
    }
    grid.confidence = Some(conf);
    grid
}
