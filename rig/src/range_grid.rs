//! Range grids: one scan's points on its sensor's pixel grid.
//!
//! ```text
//!   width = 4, height = 3, row-major, row 0 at the top of the image
//!   cell (col, row) is index row·width + col
//!        col 0   1   2   3
//!   row 0    0   1   2   3
//!   row 1    4   5   6   7      valid[i] = false where nothing was measured;
//!   row 2    8   9  10  11      points[i] is then meaningless (NaN by convention)
//! ```

use crate::math::{Point3, UnitVector3, Vector3};
use crate::point_cloud::PointCloud;

/// Where the sensor looked from, which fixes each point's line of sight.
#[derive(Debug, Clone, PartialEq)]
pub enum Sensor {
    /// A perspective sensor at this centre (a camera; the origin for grids in the camera frame).
    Center(Point3),
    /// A parallel-projection sensor looking along `-direction` (`direction` points toward the sensor),
    /// as for the Cyberware scans, whose sensor lies toward +z.
    Direction(UnitVector3),
    /// One unit direction toward the sensor per cell.
    PerCell(Vec<UnitVector3>),
}

/// A scan on its pixel grid: positions, validity, optional normals and confidence, and the sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct RangeGrid {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width · height` positions, row-major (see the module doc).
    pub points: Vec<Point3>,
    /// Whether each cell holds a measurement.
    pub valid: Vec<bool>,
    /// Optional unit normals per cell, oriented toward the sensor.
    pub normals: Option<Vec<Vector3>>,
    /// Optional confidence per cell.
    pub confidence: Option<Vec<f32>>,
    /// Optional 8-bit RGB colour per cell (the view's texture frame).
    pub colors: Option<Vec<[u8; 3]>>,
    /// The sensor that measured the grid.
    pub sensor: Sensor,
}

impl RangeGrid {
    /// An all-invalid grid.
    pub fn empty(width: usize, height: usize, sensor: Sensor) -> Self {
        let n = width * height;
        RangeGrid {
            width,
            height,
            points: vec![Point3::new(f64::NAN, f64::NAN, f64::NAN); n],
            valid: vec![false; n],
            normals: None,
            confidence: None,
            colors: None,
            sensor,
        }
    }

    /// The cell index of (col, row).
    pub fn index(&self, col: usize, row: usize) -> usize {
        row * self.width + col
    }

    /// The point at (col, row), if valid.
    pub fn get(&self, col: usize, row: usize) -> Option<Point3> {
        (col < self.width && row < self.height)
            .then(|| self.index(col, row))
            .filter(|&i| self.valid[i])
            .map(|i| self.points[i])
    }

    /// Number of valid cells.
    pub fn valid_count(&self) -> usize {
        self.valid.iter().filter(|&&v| v).count()
    }

    /// The unit direction from cell `i`'s point toward the sensor.
    pub fn line_of_sight(&self, i: usize) -> UnitVector3 {
        match &self.sensor {
            Sensor::Center(c) => UnitVector3::new_normalize(c - self.points[i]),
            Sensor::Direction(d) => *d,
            Sensor::PerCell(d) => d[i],
        }
    }

    /// The valid cells as a point cloud (with normals and confidence where the grid has them).
    pub fn to_point_cloud(&self) -> PointCloud {
        let keep: Vec<usize> = (0..self.valid.len()).filter(|&i| self.valid[i]).collect();
        PointCloud {
            positions: keep.iter().map(|&i| self.points[i]).collect(),
            normals: self.normals.as_ref().map(|n| keep.iter().map(|&i| n[i]).collect()),
            confidence: self.confidence.as_ref().map(|c| keep.iter().map(|&i| c[i]).collect()),
            ..Default::default()
        }
    }
}
