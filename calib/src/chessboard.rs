//! Chessboard inner corners in pure Rust: saddle points of the blurred image (where the Hessian's
//! determinant is strongly negative, as only X-junctions make it), kept if a ring around them
//! alternates dark and light four times (not an L-corner or an edge), then a grid grown from a seed
//! by predicting each next corner from the ones already found, so perspective and lens bending are
//! followed step by step. The grid is ordered as the board frame says (origin on the first inner
//! corner, the square diagonally outside it dark, x along a row, y down a column as seen on the
//! printed side) and refined to sub-pixel accuracy: the gradient-orthogonality condition of
//! OpenCV's `cornerSubPix` to settle on the junction, then the saddle point of a quadratic fitted to
//! the blurred image around it.

use crate::gray::Gray;
use rig::math::{Point2, Vector2};
use std::collections::{HashMap, VecDeque};

/// Why a board was not found in an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotFound {
    /// Too few corner-like points.
    #[error("only {0} corner-like points, the board has {1}")]
    TooFewCorners(usize, usize),
    /// A grid was found but not the whole board (cut off, occluded or too oblique).
    #[error("the best grid of corners has {found} of the board's {expected}")]
    Partial {
        /// Corners in the best grid.
        found: usize,
        /// Corners the board has.
        expected: usize,
    },
}

/// Saddle-point candidates: position and strength.
fn saddles(blurred: &Gray, radius: usize) -> Vec<(Point2, f32)> {
    let (w, h) = (blurred.width, blurred.height);
    let mut resp = vec![0f32; w * h];
    let at = |x: usize, y: usize| blurred.data[y * w + x];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let ixx = at(x + 1, y) - 2.0 * at(x, y) + at(x - 1, y);
            let iyy = at(x, y + 1) - 2.0 * at(x, y) + at(x, y - 1);
            let ixy = (at(x + 1, y + 1) - at(x - 1, y + 1) - at(x + 1, y - 1) + at(x - 1, y - 1)) / 4.0;
            resp[y * w + x] = (ixy * ixy - ixx * iyy).max(0.0);
        }
    }
    let max = resp.iter().copied().fold(0.0, f32::max);
    if max <= 0.0 {
        return Vec::new();
    }
    let threshold = 0.01 * max;
    let r = radius as isize;
    let mut out = Vec::new();
    for y in radius..h.saturating_sub(radius) {
        for x in radius..w.saturating_sub(radius) {
            let v = resp[y * w + x];
            if v < threshold {
                continue;
            }
            // Non-maximum suppression; ties go to the first in raster order.
            let mut best = true;
            'win: for dy in -r..=r {
                for dx in -r..=r {
                    let (xx, yy) = ((x as isize + dx) as usize, (y as isize + dy) as usize);
                    let u = resp[yy * w + xx];
                    if u > v || (u == v && (dy < 0 || (dy == 0 && dx < 0))) {
                        best = false;
                        break 'win;
                    }
                }
            }
            if best {
                // Sub-pixel peak of a parabola through the response's neighbours.
                let fit = |a: f32, b: f32, c: f32| {
                    let d = a - 2.0 * b + c;
                    if d.abs() > 1e-12 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) as f64 } else { 0.0 }
                };
                let ox = fit(resp[y * w + x - 1], v, resp[y * w + x + 1]);
                let oy = fit(resp[(y - 1) * w + x], v, resp[(y + 1) * w + x]);
                out.push((Point2::new(x as f64 + ox, y as f64 + oy), v));
            }
        }
    }
    out
}

/// Whether a ring of `radius` around `p` changes between darker and lighter than its mean four times.
fn is_x_junction(img: &Gray, p: &Point2, radius: f64) -> bool {
    let n = 32;
    let ring: Vec<f32> = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            img.sample(p.x + radius * a.cos(), p.y + radius * a.sin())
        })
        .collect();
    let mean = ring.iter().sum::<f32>() / n as f32;
    let spread = ring.iter().map(|v| (v - mean).abs()).sum::<f32>() / n as f32;
    if spread < 0.02 {
        return false;
    }
    // Signs with hysteresis: values near the mean keep the previous sign.
    let start = ring.iter().position(|v| (v - mean).abs() > 0.3 * spread).unwrap_or(0);
    let mut sign = ring[start] > mean;
    let mut changes = 0;
    for k in 1..=n {
        let v = ring[(start + k) % n];
        if (v - mean).abs() > 0.3 * spread && (v > mean) != sign {
            sign = !sign;
            changes += 1;
        }
    }
    changes == 4
}

/// A grid grown from a seed: cell → candidate index.
type Grid = HashMap<(i32, i32), usize>;

fn grow(points: &[Point2], seed: usize) -> Option<Grid> {
    let p = points[seed];
    let mut near: Vec<(f64, usize)> =
        points.iter().enumerate().filter(|&(i, _)| i != seed).map(|(i, q)| ((q - p).norm(), i)).collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate(8);
    let &(du, iu) = near.first()?;
    let u = points[iu] - p;
    // The second direction: the nearest neighbour well off the first one's line; up to 5 times as
    // far, since an oblique board's squares are foreshortened along one axis.
    let &(_, iv) = near.iter().find(|&&(d, i)| {
        let v = points[i] - p;
        d < 5.0 * du && (u.dot(&v) / (u.norm() * v.norm())).abs() < 0.7
    })?;
    let mut grid: Grid = HashMap::new();
    let mut used = vec![false; points.len()];
    for (cell, i) in [((0, 0), seed), ((1, 0), iu), ((0, 1), iv)] {
        grid.insert(cell, i);
        used[i] = true;
    }
    let mut queue: VecDeque<(i32, i32)> = VecDeque::new();
    let push_around = |q: &mut VecDeque<(i32, i32)>, (i, j): (i32, i32)| {
        for c in [(i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)] {
            q.push_back(c);
        }
    };
    for c in [(0, 0), (1, 0), (0, 1)] {
        push_around(&mut queue, c);
    }
    let mut guard = 0;
    while let Some(cell) = queue.pop_front() {
        guard += 1;
        if guard > 100_000 || grid.len() > 4000 {
            break;
        }
        if grid.contains_key(&cell) {
            continue;
        }
        let Some((pred, step)) = predict(points, &grid, cell) else { continue };
        let tol = 0.3 * step;
        let best = points
            .iter()
            .enumerate()
            .filter(|&(i, q)| !used[i] && (q - pred).norm() < tol)
            .min_by(|a, b| (a.1 - pred).norm().total_cmp(&(b.1 - pred).norm()));
        if let Some((i, _)) = best {
            grid.insert(cell, i);
            used[i] = true;
            push_around(&mut queue, cell);
        }
    }
    Some(grid)
}

/// Where cell `(i, j)` should be, from the found cells around it, and the local step length.
fn predict(points: &[Point2], grid: &Grid, (i, j): (i32, i32)) -> Option<(Point2, f64)> {
    let at = |c: (i32, i32)| grid.get(&c).map(|&k| points[k]);
    let mut sum = Vector2::zeros();
    let mut steps = 0.0;
    let mut n = 0.0;
    for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
        // Straight on from two cells behind.
        if let (Some(a), Some(b)) = (at((i - di, j - dj)), at((i - 2 * di, j - 2 * dj))) {
            sum += (a + (a - b)).coords;
            steps += (a - b).norm();
            n += 1.0;
            continue;
        }
        // Or across a parallelogram with a side neighbour.
        for (si, sj) in [(dj, di), (-dj, -di)] {
            if let (Some(a), Some(s), Some(d)) =
                (at((i - di, j - dj)), at((i + si, j + sj)), at((i - di + si, j - dj + sj)))
            {
                sum += (a + (s - d)).coords;
                steps += (s - d).norm();
                n += 1.0;
                break;
            }
        }
    }
    (n > 0.0).then(|| (Point2::from(sum / n), steps / n))
}

/// Finds the `cols × rows` inner corners of a chessboard, ordered row-major in the board frame (see
/// the module notes), refined to sub-pixel accuracy.
pub fn find_corners(img: &Gray, cols: usize, rows: usize) -> Result<Vec<Point2>, NotFound> {
    match search(img, cols, rows) {
        Search::Whole(corners) => Ok(corners),
        Search::Part { cells, .. } => Err(NotFound::Partial { found: cells.len(), expected: cols * rows }),
        Search::Nothing(found) if found < 4 => Err(NotFound::TooFewCorners(found, cols * rows)),
        Search::Nothing(found) => Err(NotFound::Partial { found, expected: cols * rows }),
    }
}

/// Grid cells and their (unrefined) pixels.
pub(crate) type Cells = Vec<((i32, i32), Point2)>;

/// What [`search`] found.
pub(crate) enum Search {
    /// The whole board, in board order, refined.
    Whole(Vec<Point2>),
    /// The largest grid of corners that is not the whole board: cell → unrefined pixel, cells
    /// numbered from where the grid was grown (`crate::partial_board` places them on the board).
    Part {
        /// Grid cell → pixel.
        cells: Cells,
    },
    /// No grid; the most corner-like points seen (at most the board's count).
    Nothing(usize),
}

/// The board's corners, or else the largest grid of corners seen.
pub(crate) fn search(img: &Gray, cols: usize, rows: usize) -> Search {
    let expected = cols * rows;
    let mut best_points = 0;
    let mut best: Option<Cells> = None;
    for sigma in [1.5, 3.0, 5.0] {
        let blurred = img.blur(sigma);
        let radius = (2.0 * sigma).round() as usize;
        let mut cands = saddles(&blurred, radius.max(2));
        cands.sort_by(|a, b| b.1.total_cmp(&a.1));
        cands.truncate(8 * expected + 400);
        let points: Vec<Point2> =
            cands.iter().map(|c| c.0).filter(|p| is_x_junction(&blurred, p, (2.0 * sigma).max(3.0))).collect();
        best_points = best_points.max(points.len().min(expected));
        // A part of the board is looked for among fewer points than the board has.
        for seed in 0..points.len().min(30) {
            let Some(grid) = grow(&points, seed) else { continue };
            if points.len() >= expected
                && let Some(cells) = board_in(&grid, cols, rows)
            {
                let corners: Vec<Point2> = cells.iter().map(|&k| points[k]).collect();
                let oriented = orient(img, corners, cols, rows);
                let step = (oriented[1] - oriented[0]).norm().min((oriented[cols] - oriented[0]).norm());
                return Search::Whole(refine_all(img, &oriented, step));
            }
            if best.as_ref().is_none_or(|b| grid.len() > b.len()) {
                best = Some(grid.iter().map(|(&c, &k)| (c, points[k])).collect());
            }
        }
    }
    match best {
        Some(cells) if cells.len() >= 4 => Search::Part { cells },
        Some(cells) => Search::Nothing(best_points.max(cells.len())),
        None => Search::Nothing(best_points),
    }
}

/// Sub-pixel corners: gradient orthogonality to settle on the junction, then the saddle of the
/// blurred image, which averages the hard edges of a sharp image best. `step` is the board's
/// square in pixels near these corners.
pub(crate) fn refine_all(img: &Gray, corners: &[Point2], step: f64) -> Vec<Point2> {
    let half = ((0.3 * step).round() as usize).clamp(2, 12);
    // σ 2.5 px and a 5 px window: more blur averages the hard edges of a sharp image better but
    // shifts the saddle of a foreshortened junction (measured on the simulated views: mean error
    // 0.14 px at σ 1.5, 0.10 at 2.5, 0.08 at 5, with the focal length drifting up as the blur grows).
    let (sharp, soft) = (img.blur(0.7), img.blur(2.5));
    corners.iter().map(|p| refine_saddle(&soft, refine(&sharp, *p, half), 5)).collect()
}

/// The board's corners in a grown grid: a fully found `cols × rows` (or transposed) rectangle of cells,
/// as candidate indices in row-major order with i along the `cols` side.
fn board_in(grid: &Grid, cols: usize, rows: usize) -> Option<Vec<usize>> {
    let (imin, imax) = (grid.keys().map(|c| c.0).min()?, grid.keys().map(|c| c.0).max()?);
    let (jmin, jmax) = (grid.keys().map(|c| c.1).min()?, grid.keys().map(|c| c.1).max()?);
    for (w, h, transposed) in [(cols as i32, rows as i32, false), (rows as i32, cols as i32, true)] {
        // Every placement of a w × h window that is completely found.
        let mut hits = Vec::new();
        for i0 in imin..=imax - w + 1 {
            for j0 in jmin..=jmax - h + 1 {
                if (0..w).all(|a| (0..h).all(|b| grid.contains_key(&(i0 + a, j0 + b)))) {
                    hits.push((i0, j0));
                }
            }
        }
        // Several placements: the grid caught extra corner-like points beside the board; take the
        // placement of the strongest corners (candidates come sorted by saddle strength).
        if let Some(&(i0, j0)) = hits.iter().min_by_key(|&&(i0, j0)| {
            (0..w).flat_map(|a| (0..h).map(move |b| (a, b))).map(|(a, b)| grid[&(i0 + a, j0 + b)]).sum::<usize>()
        }) {
            let mut out = Vec::with_capacity(cols * rows);
            for r in 0..rows as i32 {
                for c in 0..cols as i32 {
                    let cell = if transposed { (i0 + r, j0 + c) } else { (i0 + c, j0 + r) };
                    out.push(grid[&cell]);
                }
            }
            return Some(out);
        }
    }
    None
}

/// Reorders row-major corners so that, in the image, turning from the +i to the +j direction is
/// clockwise (y down), as the board frame seen from its printed side, and the square diagonally
/// outside corner 0 is dark.
fn orient(img: &Gray, mut c: Vec<Point2>, cols: usize, rows: usize) -> Vec<Point2> {
    let flip_j = |c: &[Point2]| -> Vec<Point2> {
        (0..rows).rev().flat_map(|j| (0..cols).map(move |i| (i, j))).map(|(i, j)| c[j * cols + i]).collect()
    };
    let rotate = |c: &[Point2]| -> Vec<Point2> { c.iter().rev().copied().collect() };
    let (di, dj) = (c[1] - c[0], c[cols] - c[0]);
    if di.x * dj.y - di.y * dj.x < 0.0 {
        c = flip_j(&c);
    }
    let dark_outside = |c: &[Point2]| {
        let (di, dj) = (c[1] - c[0], c[cols] - c[0]);
        let p = c[0] - (di + dj) * 0.5;
        let q = c[0] + (di - dj) * 0.5; // the square beside it, which has the other colour
        img.sample(p.x, p.y) < img.sample(q.x, q.y)
    };
    let here = dark_outside(&c);
    let turned = rotate(&c);
    let there = dark_outside(&turned);
    match (here, there) {
        (true, false) => c,
        (false, true) => turned,
        // Both corners alike (odd × odd squares): the one nearer the image's top-left.
        _ => {
            if (turned[0].x + turned[0].y) < (c[0].x + c[0].y) {
                turned
            } else {
                c
            }
        }
    }
}

/// Sub-pixel corner position as the saddle point of a quadratic fitted to the (blurred) image in a
/// window around the estimate, re-centred until it settles.
pub fn refine_saddle(blurred: &Gray, start: Point2, radius: usize) -> Point2 {
    let mut q = start;
    let r = radius as isize;
    for _ in 0..10 {
        // Least squares for f = a x² + b xy + c y² + d x + e y + g, in offsets from q.
        let mut ata = nalgebra::SMatrix::<f64, 6, 6>::zeros();
        let mut atb = nalgebra::SVector::<f64, 6>::zeros();
        for dy in -r..=r {
            for dx in -r..=r {
                let (x, y) = (dx as f64, dy as f64);
                let row = nalgebra::SVector::<f64, 6>::from_row_slice(&[x * x, x * y, y * y, x, y, 1.0]);
                let f = blurred.sample(q.x + x, q.y + y) as f64;
                ata += row * row.transpose();
                atb += row * f;
            }
        }
        let Some(c) = ata.cholesky().map(|ch| ch.solve(&atb)) else { return q };
        let (a, b, cc, d, e) = (c[0], c[1], c[2], c[3], c[4]);
        let det = 4.0 * a * cc - b * b;
        if det >= 0.0 {
            return q; // not a saddle
        }
        let ox = (-2.0 * cc * d + b * e) / det;
        let oy = (-2.0 * a * e + b * d) / det;
        if ox.abs() > radius as f64 || oy.abs() > radius as f64 {
            return q;
        }
        q = Point2::new(q.x + ox, q.y + oy);
        if ox.abs() < 1e-3 && oy.abs() < 1e-3 {
            break;
        }
    }
    q
}

/// Sub-pixel corner position: the point `q` where every image gradient in a window is orthogonal to
/// the vector from `q` to its pixel (OpenCV's `cornerSubPix` condition), Gaussian-weighted, iterated.
pub fn refine(img: &Gray, start: Point2, half: usize) -> Point2 {
    let mut q = start;
    let h = half as isize;
    let sigma2 = (half as f64 / 2.0).powi(2).max(1.0);
    for _ in 0..20 {
        let (cx, cy) = (q.x.round() as isize, q.y.round() as isize);
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for dy in -h..=h {
            for dx in -h..=h {
                let (x, y) = (cx + dx, cy + dy);
                let gx = ((img.at(x + 1, y) - img.at(x - 1, y)) / 2.0) as f64;
                let gy = ((img.at(x, y + 1) - img.at(x, y - 1)) / 2.0) as f64;
                let wgt = (-((dx * dx + dy * dy) as f64) / (2.0 * sigma2)).exp();
                let (gxx, gxy, gyy) = (gx * gx * wgt, gx * gy * wgt, gy * gy * wgt);
                a11 += gxx;
                a12 += gxy;
                a22 += gyy;
                b1 += gxx * x as f64 + gxy * y as f64;
                b2 += gxy * x as f64 + gyy * y as f64;
            }
        }
        let det = a11 * a22 - a12 * a12;
        if det.abs() < 1e-12 {
            return q;
        }
        let next = Point2::new((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        if (next - start).norm() > half as f64 {
            return q; // wandered off: keep what we had
        }
        let moved = (next - q).norm();
        q = next;
        if moved < 1e-3 {
            break;
        }
    }
    q
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A `cols × rows` (inner corners) board of `square` px squares, rotated by `angle`, with corner 0
    /// at `origin`, rendered 4 × 4 supersampled into a `w × h` grey image; returns the image and the
    /// true corners in board order.
    pub(crate) fn render(
        w: usize,
        h: usize,
        cols: usize,
        rows: usize,
        square: f64,
        angle: f64,
        origin: (f64, f64),
    ) -> (Gray, Vec<Point2>) {
        let (c, s) = (angle.cos(), angle.sin());
        let to_img =
            |i: f64, j: f64| Point2::new(origin.0 + square * (c * i - s * j), origin.1 + square * (s * i + c * j));
        let mut data = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut acc = 0.0;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let (px, py) = (
                            x as f64 - 0.375 + 0.25 * sx as f64 - origin.0,
                            y as f64 - 0.375 + 0.25 * sy as f64 - origin.1,
                        );
                        let (i, j) = ((c * px + s * py) / square, (-s * px + c * py) / square);
                        let inside = i >= -1.0 && j >= -1.0 && i < cols as f64 && j < rows as f64;
                        let dark = inside && ((i + 1.0).floor() as i64 + (j + 1.0).floor() as i64) % 2 == 0;
                        let on_board = i >= -2.0 && j >= -2.0 && i < cols as f64 + 1.0 && j < rows as f64 + 1.0;
                        acc += if dark {
                            0.05
                        } else if on_board {
                            0.85
                        } else {
                            0.1
                        };
                    }
                }
                data[y * w + x] = acc / 16.0;
            }
        }
        let truth =
            (0..rows).flat_map(|j| (0..cols).map(move |i| (i, j))).map(|(i, j)| to_img(i as f64, j as f64)).collect();
        (Gray { width: w, height: h, data }, truth)
    }

    #[test]
    fn a_rotated_board_is_found_in_board_order_to_a_tenth_of_a_pixel() {
        let (img, truth) = render(420, 340, 7, 5, 34.0, 0.3, (120.0, 70.0));
        let found = find_corners(&img, 7, 5).unwrap();
        let worst = found.iter().zip(&truth).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        assert!(worst < 0.1, "worst corner {worst} px off");
        // The transposed request finds nothing: the board has 7 × 5 corners, not 5 × 7 of another.
        assert!(find_corners(&img, 8, 5).is_err());
    }

    #[test]
    fn a_board_cut_by_the_frame_is_reported_partial() {
        let (img, _) = render(300, 240, 7, 5, 34.0, 0.0, (120.0, 60.0));
        match find_corners(&img, 7, 5) {
            Err(NotFound::Partial { found, expected: 35 }) => assert!(found >= 20, "{found}"),
            other => panic!("{other:?}"),
        }
    }
}
