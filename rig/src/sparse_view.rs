//! Sparse views: a scan stored as the points it measured, each with the pixel it was seen at.
//!
//! A laser view is one line per laser: at most one point per image row, a thousandth of the pixels. As a
//! dense [`RangeGrid`] (a cell per pixel) a 1280 × 960 view costs 30 MB whatever it holds, and the 800
//! views of a Horus scan tens of GB; as a sparse view it costs its points (about 20 kB).

use crate::math::Point3;
use crate::range_grid::{RangeGrid, Sensor};

/// The points of one view, each with its pixel (column, row; subpixel) and confidence, and the image
/// size and sensor they were measured with.
///
/// # Conventions
/// Points in the camera frame (mm), pixel (0, 0) the centre of the top-left pixel, as for
/// [`RangeGrid`].
#[derive(Debug, Clone, PartialEq)]
pub struct SparseView {
    /// Image columns.
    pub width: usize,
    /// Image rows.
    pub height: usize,
    /// The measured points.
    pub points: Vec<Point3>,
    /// Per point, the pixel it was seen at: `[column, row]`.
    pub pixels: Vec<[f32; 2]>,
    /// Per point, its confidence (larger is more trusted; a laser line's peak over 255).
    pub confidence: Vec<f32>,
    /// Per point, its 8-bit RGB colour (the view's texture frame), where there is one.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The sensor that measured the view.
    pub sensor: Sensor,
}

impl SparseView {
    /// A view of `width × height` pixels with no points.
    pub fn empty(width: usize, height: usize, sensor: Sensor) -> Self {
        SparseView {
            width,
            height,
            points: Vec::new(),
            pixels: Vec::new(),
            confidence: Vec::new(),
            colors: None,
            sensor,
        }
    }

    /// Adds a point seen at pixel `[column, row]`.
    pub fn push(&mut self, point: Point3, pixel: [f32; 2], confidence: f32) {
        self.points.push(point);
        self.pixels.push(pixel);
        self.confidence.push(confidence);
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Bytes held (what a view costs in memory).
    pub fn heap_bytes(&self) -> usize {
        self.points.capacity() * std::mem::size_of::<Point3>()
            + self.pixels.capacity() * std::mem::size_of::<[f32; 2]>()
            + self.confidence.capacity() * std::mem::size_of::<f32>()
    }

    /// The view on its dense pixel grid: each point in the cell of its nearest pixel (a later point
    /// in the same cell replaces an earlier one), with its confidence. For tools that take range
    /// grids; it costs a cell per pixel.
    pub fn to_range_grid(&self) -> RangeGrid {
        let mut grid = RangeGrid::empty(self.width, self.height, self.sensor.clone());
        let mut conf = vec![0.0f32; self.width * self.height];
        for ((p, px), &c) in self.points.iter().zip(&self.pixels).zip(&self.confidence) {
            let col = (px[0].round().max(0.0) as usize).min(self.width.saturating_sub(1));
            let row = (px[1].round().max(0.0) as usize).min(self.height.saturating_sub(1));
            let i = row * self.width + col;
            if i < grid.points.len() {
                grid.points[i] = *p;
                grid.valid[i] = true;
                conf[i] = c;
            }
        }
        grid.confidence = Some(conf);
        if let Some(colors) = &self.colors {
            let mut rgb = vec![[0u8; 3]; self.width * self.height];
            for (px, c) in self.pixels.iter().zip(colors) {
                let col = (px[0].round().max(0.0) as usize).min(self.width.saturating_sub(1));
                let row = (px[1].round().max(0.0) as usize).min(self.height.saturating_sub(1));
                if let Some(slot) = rgb.get_mut(row * self.width + col) {
                    *slot = *c;
                }
            }
            grid.colors = Some(rgb);
        }
        grid
    }
}
