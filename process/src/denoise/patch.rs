//! Patch similarity by summed-area tables (eq. 4.5 at a cost independent of the patch size).
//!
//! For a fixed grid offset δ between the two patch centres, `Σ_o ((p_{i+o} − p_{i+δ+o})·d_i)²` equals
//! `d_iᵀ·(Σ_o a_{i+o}·a_{i+o}ᵀ)·d_i` with `a_x = p_x − p_{x+δ}`: a box sum over the patch of the six
//! components of `a·aᵀ`, which one summed-area table per offset answers in four look-ups — whatever the
//! patch size, and with `d_i` exactly the centre's direction, as eq. 4.5 has it.

use rig::RangeGrid;
use rig::math::{Real, Vector3};

/// Channels: xx, xy, xz, yy, yz, zz of `a·aᵀ`, then the count of valid pairs.
type Cell = [Real; 7];

/// The summed-area table of one offset δ = (dc, dr) between `current` and `other`.
#[derive(Default)]
pub struct PairTable {
    w: usize,
    h: usize,
    sums: Vec<Cell>,
}

impl PairTable {
    /// Builds the table for the pairs (x in `current`, x + δ in `other`), both valid.
    pub fn build(current: &RangeGrid, other: &RangeGrid, dc: isize, dr: isize) -> Self {
        let mut t = PairTable::default();
        t.fill(current, other, dc, dr);
        t
    }

    /// Refills the table for another offset, reusing its memory.
    pub fn fill(&mut self, current: &RangeGrid, other: &RangeGrid, dc: isize, dr: isize) {
        let (w, h) = (current.width, current.height);
        let stride = w + 1;
        self.w = w;
        self.h = h;
        self.sums.clear();
        self.sums.resize(stride * (h + 1), [0.0; 7]);
        let sums = &mut self.sums;
        for r in 0..h {
            let mut row = [0.0; 7];
            let (rr, inside_r) = (r as isize + dr, (0..h as isize).contains(&(r as isize + dr)));
            for c in 0..w {
                let i = r * w + c;
                let cc = c as isize + dc;
                if inside_r && (0..w as isize).contains(&cc) && current.valid[i] {
                    let j = rr as usize * w + cc as usize;
                    if other.valid[j] {
                        let a = current.points[i] - other.points[j];
                        let v = [a.x * a.x, a.x * a.y, a.x * a.z, a.y * a.y, a.y * a.z, a.z * a.z, 1.0];
                        for k in 0..7 {
                            row[k] += v[k];
                        }
                    }
                }
                let above = sums[r * stride + c + 1];
                let cell = &mut sums[(r + 1) * stride + c + 1];
                for k in 0..7 {
                    cell[k] = above[k] + row[k];
                }
            }
        }
    }

    /// The box sum over the `(2·half + 1)²` patch centred on (c, r), clipped to the grid.
    pub fn patch(&self, c: usize, r: usize, half: usize) -> Cell {
        let stride = self.w + 1;
        let (c0, r0) = (c.saturating_sub(half), r.saturating_sub(half));
        let (c1, r1) = ((c + half + 1).min(self.w), (r + half + 1).min(self.h));
        let (a, b, cc, d) = (
            self.sums[r0 * stride + c0],
            self.sums[r0 * stride + c1],
            self.sums[r1 * stride + c0],
            self.sums[r1 * stride + c1],
        );
        std::array::from_fn(|k| d[k] - b[k] - cc[k] + a[k])
    }
}

/// Eq. 4.5 from a patch sum: the mean squared height difference along `d`; `None` without valid pairs.
pub fn similarity(m: &Cell, d: &Vector3) -> Option<Real> {
    if m[6] < 0.5 {
        return None;
    }
    let q = d.x * d.x * m[0]
        + d.y * d.y * m[3]
        + d.z * d.z * m[5]
        + 2.0 * (d.x * d.y * m[1] + d.x * d.z * m[2] + d.y * d.z * m[4]);
    Some(q.max(0.0) / m[6])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::Sensor;
    use rig::math::Point3;

    #[test]
    fn table_patches_equal_direct_sums() {
        let (w, h) = (9usize, 7usize);
        let mut g = RangeGrid::empty(w, h, Sensor::Center(Point3::origin()));
        for i in 0..w * h {
            let (c, r) = ((i % w) as f64, (i / w) as f64);
            g.points[i] = Point3::new(c, r, 100.0 + (c * 0.7).sin() + (r * 1.3).cos());
            g.valid[i] = i % 11 != 3;
        }
        let d = Vector3::new(0.1, -0.2, 1.0).normalize();
        let (dc, dr) = (2isize, -1isize);
        let t = PairTable::build(&g, &g, dc, dr);
        for (c, r) in [(0usize, 0usize), (4, 3), (8, 6), (1, 5)] {
            let (mut s, mut n) = (0.0, 0.0);
            for rr in r.saturating_sub(2)..=(r + 2).min(h - 1) {
                for cc in c.saturating_sub(2)..=(c + 2).min(w - 1) {
                    let (jc, jr) = (cc as isize + dc, rr as isize + dr);
                    if (0..w as isize).contains(&jc) && (0..h as isize).contains(&jr) {
                        let (i, j) = (rr * w + cc, jr as usize * w + jc as usize);
                        if g.valid[i] && g.valid[j] {
                            s += ((g.points[i] - g.points[j]).dot(&d)).powi(2);
                            n += 1.0;
                        }
                    }
                }
            }
            let sim = similarity(&t.patch(c, r, 2), &d).unwrap();
            assert!((sim - s / n).abs() < 1e-9, "({c}, {r}): {sim} vs {}", s / n);
        }
    }
}
