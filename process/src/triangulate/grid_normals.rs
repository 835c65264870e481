//! Normals of a range grid from its grid neighbours: the cross product of the horizontal and vertical
//! differences (central where both neighbours are valid, one-sided otherwise), turned toward the sensor.
//! Neighbours across a depth jump are not neighbours: a step longer than `max_step` times the distance to
//! the left or right neighbour pair's typical spacing breaks the surface there.

use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Point3, Real, Vector3};

/// Fills `grid.normals` (zero vectors where no normal can be estimated) and returns how many cells got one.
/// `max_jump_mm` is the largest neighbour step treated as the same surface.
pub fn estimate_normals(grid: &mut RangeGrid, max_jump_mm: Real) -> usize {
    let (w, h) = (grid.width, grid.height);
    let at = |c: usize, r: usize| -> Option<Point3> { grid.valid[r * w + c].then(|| grid.points[r * w + c]) };
    let normals: Vec<Vector3> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (c, r) = (i % w, i / w);
            let Some(p) = at(c, r) else { return Vector3::zeros() };
            let near = |q: Option<Point3>| q.filter(|q| (q - p).norm() <= max_jump_mm);
            let diff = |a: Option<Point3>, b: Option<Point3>| match (near(a), near(b)) {
                (Some(a), Some(b)) => Some(b - a),
                (Some(a), None) => Some(p - a),
                (None, Some(b)) => Some(b - p),
                (None, None) => None,
            };
            let dx = diff((c > 0).then(|| at(c - 1, r)).flatten(), (c + 1 < w).then(|| at(c + 1, r)).flatten());
            let dy = diff((r > 0).then(|| at(c, r - 1)).flatten(), (r + 1 < h).then(|| at(c, r + 1)).flatten());
            let (Some(dx), Some(dy)) = (dx, dy) else { return Vector3::zeros() };
            let Some(n) = dx.cross(&dy).try_normalize(1e-12) else { return Vector3::zeros() };
            if n.dot(&grid.line_of_sight(i)) < 0.0 { -n } else { n }
        })
        .collect();
    let count = normals.iter().filter(|n| n.norm_squared() > 0.0).count();
    grid.normals = Some(normals);
    count
}
