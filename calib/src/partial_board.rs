//! Boards partly seen: cut by the image frame, covered by a hand or a clamp, or too oblique at one
//! end — the commonest reason a real capture yields no board. The largest grid of corners
//! [`crate::chessboard`] grows is kept when it is not the whole board, and its corners are given
//! their numbers on the board where the image says which they are:
//!
//! - the grid is first re-based along the squares' sides: on an oblique board a corner's nearest
//!   neighbours can lie along a diagonal, and the grid grown from them is a lattice whose cells are
//!   not squares (the basis whose cells split cleanest into dark and light is kept);
//! - a corner whose four squares do not all show the checker's colours (a cover's edge, a shadow
//!   beside it) is dropped: its refinement would be pulled off the junction;
//! - the squares' colours fix the numbering's parity (the square diagonally outside corner 0 is
//!   dark, as for a whole board), and the grid's turn in the image fixes its handedness;
//! - each side of the grid is looked past: one square beyond its last corners the board either goes
//!   on (the next squares alternate dark and light, as the checker predicts) or ends (its light
//!   margin — as light as its light squares — where the checker would have put a dark square), or
//!   cannot be told (outside the image, covered; a cover of white paper would pass for the margin,
//!   which is why a placement must agree with every side);
//! - every placement of the grid on the board (four quarter turns, every shift that keeps it on the
//!   board) that agrees with all of that is kept. One left: the corners are **identified**. Several
//!   (no margin in view): the corners keep the first placement's numbers and are **unplaced** — right
//!   up to a shift and a quarter turn on the board, which a step solving one pose per view (the lens,
//!   the projector, a laser plane) does not see, and which the turntable's steps, relating views to
//!   one another, must not use. A board of an even count of squares both ways looks the same
//!   turned half round: two placements a half turn apart count as one, numbered as a whole board
//!   of that kind is (corner 0 the nearer the image's top-left).

use crate::NotFound;
use crate::chessboard::{Search, refine_all, search};
use crate::gray::Gray;
use rig::math::{Point2, Vector2};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Where the found corners sit on the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// Every inner corner was found.
    #[default]
    Whole,
    /// Part of the board, placed on it by its margin: each corner's number is its own.
    Identified,
    /// Part of the board with no margin in view: numbered as one placement of several that fit,
    /// right up to a shift and a quarter turn on the board.
    Unplaced,
}

/// A board's corners as found in one image: whole or in part.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardCorners {
    /// Each found corner's number on the board (row-major, `i + cols · j`, as [`crate::find_corners`]
    /// orders a whole board), ascending.
    pub ids: Vec<usize>,
    /// Their pixels, refined to sub-pixel accuracy.
    pub pixels: Vec<Point2>,
    /// How far the numbers can be trusted.
    pub placement: Placement,
}

/// The fewest corners a part of a board is used with: a quarter of the board, and never fewer than
/// 3 × 3 (a homography from fewer is carried by noise).
pub fn min_corners(cols: usize, rows: usize) -> usize {
    (cols * rows).div_ceil(4).max(9)
}

/// The `cols × rows` board's inner corners in `img`: the whole board where it is all in view, or
/// else the largest part of it (at least [`min_corners`], three rows and three columns), placed on
/// the board as far as the image tells (see the module notes).
pub fn find_board(img: &Gray, cols: usize, rows: usize) -> Result<BoardCorners, NotFound> {
    let expected = cols * rows;
    let cells = match search(img, cols, rows) {
        Search::Whole(pixels) => {
            return Ok(BoardCorners { ids: (0..expected).collect(), pixels, placement: Placement::Whole });
        }
        Search::Part { cells } => cells,
        Search::Nothing(found) if found < 4 => return Err(NotFound::TooFewCorners(found, expected)),
        Search::Nothing(found) => return Err(NotFound::Partial { found, expected }),
    };
    let too_few = NotFound::Partial { found: cells.len(), expected };
    let span = |f: fn(&(i32, i32)) -> i32| {
        let v: Vec<i32> = cells.iter().map(|(c, _)| f(c)).collect();
        v.iter().max().unwrap_or(&0) - v.iter().min().unwrap_or(&0) + 1
    };
    if cells.len() < min_corners(cols, rows) || span(|c| c.0) < 3 || span(|c| c.1) < 3 {
        return Err(too_few);
    }
    let grid = Part::new(img, cells);
    let Some((placement, numbers)) = grid.place(cols, rows) else { return Err(too_few) };
    // A corner beside a cover or a shadow is pulled off the junction by it: only corners whose
    // four squares all show the checker's colours are kept.
    let mut found: Vec<(usize, Point2)> =
        grid.cells.iter().filter(|(c, _)| grid.clean(*c)).map(|(c, p)| (numbers(*c), *p)).collect();
    if found.len() < min_corners(cols, rows) {
        return Err(too_few);
    }
    found.sort_by_key(|f| f.0);
    let pixels: Vec<Point2> = found.iter().map(|f| f.1).collect();
    let pixels = refine_all(img, &pixels, grid.step);
    // Every corner, each placed: the whole board after all (seen too obliquely for the grid
    // `find_corners` grows along its sides).
    let placement =
        if found.len() == expected && placement == Placement::Identified { Placement::Whole } else { placement };
    Ok(BoardCorners { ids: found.iter().map(|f| f.0).collect(), pixels, placement })
}

/// What lies one square past a side of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Beyond {
    /// More squares: the board goes on.
    Board,
    /// The board's light margin: the board ends here.
    Margin,
    /// Out of the image, covered, or unclear.
    Unknown,
}

/// A grid of found corners, cells made right-handed in the image and numbered from (0, 0).
struct Part<'a> {
    img: &'a Gray,
    cells: Vec<((i32, i32), Point2)>,
    at: HashMap<(i32, i32), Point2>,
    /// The square in pixels (median of neighbouring corners' distances).
    step: f64,
    /// Which squares are dark: those whose first corner's (i + j) has this parity.
    dark_parity: i32,
    /// Between the dark and the light squares' brightness.
    threshold: f32,
    /// The light squares' mean brightness: the board's paper, which its margin is too.
    light: f32,
}

/// The cells between four found corners, each with the image's brightness at its centre.
fn squares(img: &Gray, cells: &[((i32, i32), Point2)]) -> Vec<((i32, i32), f32)> {
    let at: HashMap<(i32, i32), Point2> = cells.iter().copied().collect();
    cells
        .iter()
        .filter_map(|&((i, j), p)| {
            let (a, b, c) = (at.get(&(i + 1, j))?, at.get(&(i, j + 1))?, at.get(&(i + 1, j + 1))?);
            let m = Point2::from((p.coords + a.coords + b.coords + c.coords) / 4.0);
            Some(((i, j), img.sample(m.x, m.y)))
        })
        .collect()
}

/// How cleanly the cells split into a checker: the share of squares whose brightness is on the side
/// of the middle grey their parity says, ties on the fewest squares broken by count.
fn checker_score(img: &Gray, cells: &[((i32, i32), Point2)]) -> f64 {
    let sq = squares(img, cells);
    if sq.len() < 4 {
        return 0.0;
    }
    let (lo, hi) = sq.iter().fold((f32::MAX, f32::MIN), |m, s| (m.0.min(s.1), m.1.max(s.1)));
    let mid = (lo + hi) / 2.0;
    let even_dark = sq.iter().filter(|(c, v)| ((c.0 + c.1).rem_euclid(2) == 0) == (*v < mid)).count();
    let agree = even_dark.max(sq.len() - even_dark) as f64 / sq.len() as f64;
    agree + 1e-6 * sq.len() as f64
}

impl<'a> Part<'a> {
    fn new(img: &'a Gray, cells: Vec<((i32, i32), Point2)>) -> Self {
        // On an oblique board the grid may have been grown along a diagonal (a corner's nearest
        // neighbours are not always along the squares' sides): a lattice still, but its cells are
        // not squares. The basis whose cells split cleanest into dark and light is the board's.
        let mut cells = [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]
            .into_iter()
            .map(|(si, sj)| cells.iter().map(|&((i, j), p)| ((i + si * j, j + sj * i), p)).collect::<Vec<_>>())
            .map(|c| (checker_score(img, &c), c))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map_or(cells, |best| best.1);
        // Right-handed as the printed board is seen: turning from +i to +j is clockwise (y down).
        let at: HashMap<(i32, i32), Point2> = cells.iter().copied().collect();
        let (mut di, mut dj) = (Vector2::zeros(), Vector2::zeros());
        for (&(i, j), p) in &at {
            if let Some(q) = at.get(&(i + 1, j)) {
                di += q - p;
            }
            if let Some(q) = at.get(&(i, j + 1)) {
                dj += q - p;
            }
        }
        if di.x * dj.y - di.y * dj.x < 0.0 {
            cells.iter_mut().for_each(|(c, _)| c.1 = -c.1);
        }
        let (i0, j0) = (cells.iter().map(|c| c.0.0).min().unwrap_or(0), cells.iter().map(|c| c.0.1).min().unwrap_or(0));
        cells.iter_mut().for_each(|(c, _)| *c = (c.0 - i0, c.1 - j0));
        cells.sort_by_key(|c| (c.0.1, c.0.0));
        let at: HashMap<(i32, i32), Point2> = cells.iter().copied().collect();
        let mut steps: Vec<f64> = cells
            .iter()
            .filter_map(|&((i, j), p)| at.get(&(i + 1, j)).or_else(|| at.get(&(i, j + 1))).map(|q| (q - p).norm()))
            .collect();
        steps.sort_by(f64::total_cmp);
        let step = steps.get(steps.len() / 2).copied().unwrap_or(1.0);
        // The squares between four found corners: dark or light, by their centres' brightness.
        let squares = squares(img, &cells);
        let mut values: Vec<f32> = squares.iter().map(|s| s.1).collect();
        values.sort_by(f32::total_cmp);
        let threshold = if values.is_empty() { 0.5 } else { (values[0] + values[values.len() - 1]) / 2.0 };
        // Parity by vote: squares of one parity dark, the other light.
        let even_dark = squares.iter().filter(|(c, v)| ((c.0 + c.1).rem_euclid(2) == 0) == (*v < threshold)).count();
        let dark_parity = if 2 * even_dark >= squares.len() { 0 } else { 1 };
        let lights: Vec<f32> = squares.iter().map(|s| s.1).filter(|&v| v >= threshold).collect();
        let light = lights.iter().sum::<f32>() / lights.len().max(1) as f32;
        Part { img, cells, at, step, dark_parity, threshold, light }
    }

    /// Whether the square whose first corner is (i, j) is dark, as the checker goes on.
    fn dark(&self, (i, j): (i32, i32)) -> bool {
        (i + j).rem_euclid(2) == self.dark_parity
    }

    /// Brightness at a point given in grid coordinates, extrapolated from the nearest found corner
    /// and its neighbours; `None` outside the image.
    fn sample(&self, x: f64, y: f64, from: (i32, i32)) -> Option<f32> {
        let p = *self.at.get(&from)?;
        // The local grid vectors: to the neighbour inward (negated) along each axis.
        let axis = |d: (i32, i32)| -> Option<Vector2> {
            match (self.at.get(&(from.0 + d.0, from.1 + d.1)), self.at.get(&(from.0 - d.0, from.1 - d.1))) {
                (_, Some(q)) => Some(p - q),
                (Some(q), None) => Some(q - p),
                _ => None,
            }
        };
        let (u, v) = (axis((1, 0))?, axis((0, 1))?);
        let q = p + u * (x - from.0 as f64) + v * (y - from.1 as f64);
        let margin = 2.0;
        let inside = q.x >= margin
            && q.y >= margin
            && q.x < self.img.width as f64 - 1.0 - margin
            && q.y < self.img.height as f64 - 1.0 - margin;
        inside.then(|| self.img.sample(q.x, q.y))
    }

    /// Whether the four squares around corner `c` show the checker's colours; a square outside the image counts if the corner's refinement window is inside.
    fn clean(&self, c: (i32, i32)) -> bool {
        let Some(p) = self.at.get(&c) else { return false };
        let reach = 0.3 * self.step + 3.0;
        let inside =
            p.x >= reach && p.y >= reach && p.x < self.img.width as f64 - reach && p.y < self.img.height as f64 - reach;
        [(-1, -1), (0, -1), (-1, 0), (0, 0)].iter().all(|&(di, dj)| {
            let (x, y) = (c.0 as f64 + di as f64 + 0.5, c.1 as f64 + dj as f64 + 0.5);
            match self.sample(x, y, c) {
                Some(v) if self.dark((c.0 + di, c.1 + dj)) => v < self.threshold,
                Some(v) => v >= self.threshold,
                None => inside,
            }
        })
    }

    /// What lies past the side of the grid facing `out` (a unit step: (1, 0), (−1, 0), (0, 1), (0, −1)).
    fn beyond(&self, out: (i32, i32)) -> Beyond {
        // The edge: the found corners farthest along `out` in each line across it.
        let along = |c: (i32, i32)| c.0 * out.0 + c.1 * out.1;
        let across = |c: (i32, i32)| c.0 * out.1.abs() + c.1 * out.0.abs();
        let mut edge: HashMap<i32, (i32, i32)> = HashMap::new();
        for &(c, _) in &self.cells {
            let e = edge.entry(across(c)).or_insert(c);
            if along(c) > along(*e) {
                *e = c;
            }
        }
        let extreme = edge.values().map(|&c| along(c)).max().unwrap_or(0);
        let side = |c: (i32, i32)| (out.1.abs() * c.0 + out.0.abs() * c.1, c);
        let mut edge: Vec<(i32, (i32, i32))> = edge.into_values().filter(|&c| along(c) == extreme).map(side).collect();
        edge.sort();
        // Per pair of edge corners, the square just past them (still the board's: its colour must be
        // the checker's, or the edge is covered or unclear) and the one past that, sampled a
        // quarter-square beyond the board's last squares: a narrow margin is still margin there.
        let (mut board, mut margin, mut conflict) = (0, 0, 0);
        for w in edge.windows(2) {
            let (a, b) = (w[0].1, w[1].1);
            if (w[1].0 - w[0].0) != 1 {
                continue;
            }
            let mid = ((a.0 + b.0) as f64 / 2.0, (a.1 + b.1) as f64 / 2.0);
            let (ox, oy) = (out.0 as f64, out.1 as f64);
            let (Some(near), Some(far)) = (
                self.sample(mid.0 + 0.5 * ox, mid.1 + 0.5 * oy, a),
                self.sample(mid.0 + 1.25 * ox, mid.1 + 1.25 * oy, a),
            ) else {
                continue;
            };
            // A square's first corner (its smallest i and j), from its centre.
            let first = |k: f64| {
                let (x, y) = (mid.0 + k * ox, mid.1 + k * oy);
                ((x - 0.5).round() as i32, (y - 0.5).round() as i32)
            };
            if (near < self.threshold) != self.dark(first(0.5)) {
                continue;
            }
            // The margin is the board's paper: as light as its light squares (a card or a hand
            // over the board is not, unless it is white paper too).
            let paper = (far - self.light).abs() < 0.5 * (self.light - self.threshold);
            match (self.dark(first(1.5)), far < self.threshold) {
                (true, true) => board += 1,
                (true, false) if paper => margin += 1,
                (true, false) => conflict += 1,
                (false, false) => {}
                (false, true) => conflict += 1,
            }
        }
        if margin >= 1 && board == 0 {
            Beyond::Margin
        } else if board >= 1 && margin == 0 && conflict == 0 {
            Beyond::Board
        } else {
            Beyond::Unknown
        }
    }

    /// The placements on a `cols × rows` board that agree with the squares and the sides: the first
    /// one's numbering, and whether it was the only one.
    #[allow(clippy::type_complexity)]
    fn place(&self, cols: usize, rows: usize) -> Option<(Placement, Box<dyn Fn((i32, i32)) -> usize>)> {
        let (w, h) = (
            self.cells.iter().map(|c| c.0.0).max().unwrap_or(0) + 1,
            self.cells.iter().map(|c| c.0.1).max().unwrap_or(0) + 1,
        );
        let sides = [(1, 0), (-1, 0), (0, 1), (0, -1)].map(|o| (o, self.beyond(o)));
        let (cols, rows) = (cols as i32, rows as i32);
        // A quarter turn q maps grid cell (i, j) of the w × h grid into a box at the origin.
        let turn = move |q: i32, (i, j): (i32, i32)| match q {
            0 => (i, j),
            1 => (h - 1 - j, i),
            2 => (w - 1 - i, h - 1 - j),
            _ => (j, w - 1 - i),
        };
        let turn_dir = |q: i32, (x, y): (i32, i32)| match q {
            0 => (x, y),
            1 => (-y, x),
            2 => (-x, -y),
            _ => (y, -x),
        };
        let mut fits = Vec::new();
        for q in 0..4 {
            let (bw, bh) = if q % 2 == 0 { (w, h) } else { (h, w) };
            for a0 in 0..=(cols - bw) {
                for b0 in 0..=(rows - bh) {
                    let map = |c: (i32, i32)| {
                        let t = turn(q, c);
                        (t.0 + a0, t.1 + b0)
                    };
                    // Parity: grid square (0, 0)'s colour against the board square it lands on,
                    // whose first corner is the smallest of its four corners' numbers.
                    let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(map);
                    let first = corners.iter().fold((i32::MAX, i32::MAX), |m, c| (m.0.min(c.0), m.1.min(c.1)));
                    // A board square is dark when its first corner's (i + j) is even: the square
                    // outside corner 0 (first corner (−1, −1)) is dark.
                    if ((first.0 + first.1).rem_euclid(2) == 0) != self.dark((0, 0)) {
                        continue;
                    }
                    let agrees = sides.iter().all(|&(out, beyond)| {
                        // The board side this grid side faces, and whether the grid reaches it.
                        let (dx, dy) = turn_dir(q, out);
                        let reach = match (dx, dy) {
                            (1, _) => a0 + bw - 1 == cols - 1,
                            (-1, _) => a0 == 0,
                            (_, 1) => b0 + bh - 1 == rows - 1,
                            _ => b0 == 0,
                        };
                        match beyond {
                            Beyond::Margin => reach,
                            Beyond::Board => !reach,
                            Beyond::Unknown => true,
                        }
                    });
                    if agrees {
                        fits.push((q, a0, b0));
                    }
                }
            }
        }
        let number = move |(q, a0, b0): (i32, i32, i32), c: (i32, i32)| {
            let t = turn(q, c);
            ((t.1 + b0) * cols + t.0 + a0) as usize
        };
        let ids = |f: (i32, i32, i32)| -> Vec<usize> { self.cells.iter().map(|&(c, _)| number(f, c)).collect() };
        let first = *fits.first()?;
        // A board of an even count of squares both ways (cols + rows even) looks the same turned
        // half round: two placements a half turn apart are one, as for a whole board, and the
        // numbering is the whole board's convention — corner 0 the nearer the image's top-left.
        let half_turn = |id: usize| {
            let (i, j) = (id as i32 % cols, id as i32 / cols);
            ((rows - 1 - j) * cols + cols - 1 - i) as usize
        };
        let symmetric = (cols + rows) % 2 == 0;
        let same = |f: (i32, i32, i32)| {
            let (a, b) = (ids(first), ids(f));
            a == b || (symmetric && a.iter().map(|&i| half_turn(i)).eq(b.iter().copied()))
        };
        let chosen = if fits.iter().all(|&f| same(f)) {
            // Of the (at most two) placements, the one whose lowest-numbered corner is nearer the
            // image's top-left.
            let lowest = |f: (i32, i32, i32)| {
                let k = (0..self.cells.len()).min_by_key(|&k| number(f, self.cells[k].0)).unwrap_or(0);
                let p = self.cells[k].1;
                p.x + p.y
            };
            let best = fits.iter().copied().min_by(|&a, &b| lowest(a).total_cmp(&lowest(b))).unwrap_or(first);
            (Placement::Identified, best)
        } else {
            (Placement::Unplaced, first)
        };
        let (placement, f) = chosen;
        Some((placement, Box::new(move |c| number(f, c))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chessboard::tests::render;

    /// Every found corner within `tol` px of the true corner of its number.
    fn assert_on_truth(found: &BoardCorners, truth: &[Point2], tol: f64) {
        for (id, p) in found.ids.iter().zip(&found.pixels) {
            let e = (p - truth[*id]).norm();
            assert!(e < tol, "corner {id} at {p:?} is {e:.3} px from its truth {:?}", truth[*id]);
        }
    }

    #[test]
    fn a_board_cut_by_the_frame_is_placed_by_its_margins() {
        // 7 × 5 corners, the right third past the image's edge.
        let (img, truth) = render(300, 240, 7, 5, 34.0, 0.0, (120.0, 60.0));
        let found = find_board(&img, 7, 5).unwrap();
        assert_eq!(found.placement, Placement::Identified);
        // Columns 0–4 of 7 in view, and column 5 at 10 px from the edge where it is found.
        assert!([25, 30].contains(&found.ids.len()), "{:?}", found.ids);
        assert_on_truth(&found, &truth, 0.1);
    }

    #[test]
    fn a_turned_board_cut_at_its_first_corner_is_placed_by_the_far_corner() {
        // The board's first corner off the top-left of the image, turned in its plane.
        let (img, truth) = render(420, 340, 9, 6, 40.0, 0.25, (-20.0, -30.0));
        let found = find_board(&img, 9, 6).unwrap();
        let in_view = truth.iter().filter(|p| p.x > 4.0 && p.y > 4.0 && p.x < 415.0 && p.y < 335.0).count();
        assert_eq!(found.placement, Placement::Identified);
        assert!(found.ids.len() + 8 >= in_view && found.ids.len() < 54, "{} of {in_view}", found.ids.len());
        assert_on_truth(&found, &truth, 0.1);
    }

    #[test]
    fn a_covered_board_is_placed_and_only_its_visible_corners_kept() {
        let (mut img, truth) = render(420, 340, 7, 5, 34.0, 0.2, (110.0, 60.0));
        // A grey card over the board's right part, as a hand or a clamp.
        for y in 40..300 {
            for x in 240..420 {
                img.data[y * 420 + x] = 0.35;
            }
        }
        let found = find_board(&img, 7, 5).unwrap();
        assert_eq!(found.placement, Placement::Identified);
        assert!((15..35).contains(&found.ids.len()), "{}", found.ids.len());
        assert!(found.pixels.iter().all(|p| p.x < 240.0));
        assert_on_truth(&found, &truth, 0.1);
    }

    #[test]
    fn a_board_seen_only_inside_is_unplaced_but_consistent() {
        // No margin in view: the part fits the board at many places.
        let (img, _) = render(300, 240, 15, 12, 30.0, 0.0, (-100.0, -80.0));
        let found = find_board(&img, 15, 12).unwrap();
        assert_eq!(found.placement, Placement::Unplaced);
        assert!(found.ids.len() >= 50, "{}", found.ids.len());
        // Numbers follow the grid: a corner's right or lower neighbour by number is a square away.
        let at: HashMap<usize, Point2> = found.ids.iter().copied().zip(found.pixels.iter().copied()).collect();
        let mut checked = 0;
        for (&id, p) in &at {
            for next in [id + 1, id + 15] {
                if let Some(q) = at.get(&next).filter(|_| next == id + 15 || (id + 1) % 15 != 0) {
                    assert!(((q - p).norm() - 30.0).abs() < 0.5, "{id} → {next}: {:.2} px", (q - p).norm());
                    checked += 1;
                }
            }
        }
        assert!(checked > 60, "{checked}");
    }

    #[test]
    fn too_little_of_a_board_is_refused() {
        let (img, _) = render(120, 100, 9, 6, 34.0, 0.0, (40.0, 30.0));
        assert!(find_board(&img, 9, 6).is_err());
    }
}
