//! Patch similarity (eq. 4.5) at a cost independent of the patch height, by streaming box sums.
//!
//! For a fixed grid offset δ between the two patch centres, `Σ_o ((p_{i+o} − p_{i+δ+o})·d_i)²` equals
//! `d_iᵀ·(Σ_o a_{i+o}·a_{i+o}ᵀ)·d_i` with `a_x = p_x − p_{x+δ}`: a box sum over the patch of the six
//! components of `a·aᵀ` (plus the count of valid pairs), with `d_i` exactly the centre's direction as
//! eq. 4.5 has it. [`PatchSums`] walks the rows once per offset: each row's channels enter a running
//! vertical sum and leave it 2·half + 1 rows later (so the cost does not grow with the patch height),
//! and the vertical sums are added across the patch's columns. Those column sums are direct adds that
//! vectorise for the usual patch widths (≤ 9) and a running sum beyond, so no patch size costs more
//! than a fixed amount per cell.
//!
//! Sums are single precision. The running vertical sums are recomputed exactly from the stored rows
//! every [`REFRESH`] rows, which bounds their drift; prefix sums over a whole image (a summed-area
//! table) would not survive single precision, as the small patch sums would be differences of large
//! totals.

use super::planes::Planes;
use std::ops::Range;

/// Channels of the pair tensor: xx, xy, xz, yy, yz, zz of `a·aᵀ`, then the count of valid pairs.
pub(super) const CHANNELS: usize = 7;

/// Rows between exact recomputations of the running vertical sums.
const REFRESH: usize = 32;

/// Patch widths up to this are summed across columns by direct (vectorised) adds.
const DIRECT_MAX_HALF: usize = 4;

/// Streaming box sums of the pair tensor over `(2·half + 1)²` patches, for one offset at a time.
pub(super) struct PatchSums {
    w: usize,
    h: usize,
    half: usize,
    /// The last 2·half + 2 channel rows, `CHANNELS × w` each.
    ring: Vec<f32>,
    /// Running sums of the channel rows in the current window, `CHANNELS × w`.
    vert: Vec<f32>,
    /// The patch sums of the current centre row, `CHANNELS × w`.
    boxed: Vec<f32>,
}

impl PatchSums {
    /// Buffers for `w × h` grids and patches of half-size `half`.
    pub fn new(w: usize, h: usize, half: usize) -> Self {
        PatchSums {
            w,
            h,
            half,
            ring: vec![0.0; (2 * half + 2) * CHANNELS * w],
            vert: vec![0.0; CHANNELS * w],
            boxed: vec![0.0; CHANNELS * w],
        }
    }

    /// Walks the centre rows `rows` of the pairs (x in `cur`, x + (dc, dr) in `other`) in order,
    /// calling `f(row, sums)` with the row's patch sums: `sums[k·w + c]` is channel k of the patch
    /// around column c, clipped to the grid, except that channel 6 holds 1 / count (1 where none).
    pub fn for_each_row(
        &mut self,
        cur: &Planes,
        other: &Planes,
        (dc, dr): (isize, isize),
        rows: Range<usize>,
        mut f: impl FnMut(usize, &[f32]),
    ) {
        let half = self.half;
        for rho in rows.start.saturating_sub(half)..rows.end + half {
            // Vectorised with AVX2 where the processor has it (see `weights::accumulate_row`).
            let op = Advance { sums: self, cur, other, dc, dr, rho, first: rows.start };
            if let Some(r) = pulp::Arch::new().dispatch(op) {
                f(r, &self.boxed);
            }
        }
    }

    /// Takes in channel row `rho` (if inside the grid); once `rho − half` is a centre row (from
    /// `first` on), brings the vertical sums to its window and its patch sums into `boxed`, and
    /// returns it.
    #[inline(always)]
    fn advance(
        &mut self,
        cur: &Planes,
        other: &Planes,
        dc: isize,
        dr: isize,
        rho: usize,
        first: usize,
    ) -> Option<usize> {
        let (w, h, half) = (self.w, self.h, self.half);
        let slots = 2 * half + 2;
        let row_len = CHANNELS * w;
        if rho < h {
            let slot = &mut self.ring[(rho % slots) * row_len..][..row_len];
            channel_row(cur, other, dc, dr, rho, slot);
        }
        let r = rho.checked_sub(half).filter(|&r| r >= first && r < h)?;
        if (r - first).is_multiple_of(REFRESH) {
            // Exact sum of the window's rows: starts the walk and resets any drift of running sums.
            self.vert.fill(0.0);
            for row in r.saturating_sub(half)..(r + half + 1).min(h) {
                let slot = &self.ring[(row % slots) * row_len..][..row_len];
                self.vert.iter_mut().zip(slot).for_each(|(v, a)| *v += a);
            }
        } else {
            let new = (rho < h).then(|| (rho % slots) * row_len);
            let old = rho.checked_sub(2 * half + 1).map(|r| (r % slots) * row_len);
            match (new, old) {
                (Some(a), Some(b)) => {
                    let (ra, rb) = (&self.ring[a..a + row_len], &self.ring[b..b + row_len]);
                    self.vert.iter_mut().zip(ra).zip(rb).for_each(|((v, x), y)| *v += x - y);
                }
                (Some(a), None) => self.vert.iter_mut().zip(&self.ring[a..a + row_len]).for_each(|(v, x)| *v += x),
                (None, Some(b)) => self.vert.iter_mut().zip(&self.ring[b..b + row_len]).for_each(|(v, x)| *v -= x),
                (None, None) => {}
            }
        }
        for k in 0..CHANNELS {
            across_columns(&self.vert[k * w..][..w], &mut self.boxed[k * w..][..w], half);
        }
        // The count channel becomes its reciprocal, which both centres of a pair use (see
        // `weights::patch_similarity`). A valid pair lies in its own patch, so wherever the sums are
        // used the count is at least 1.
        for count in &mut self.boxed[6 * w..7 * w] {
            *count = 1.0 / count.max(1.0);
        }
        Some(r)
    }
}

/// [`PatchSums::advance`] as a pulp operation, compiled for each instruction set.
struct Advance<'a> {
    sums: &'a mut PatchSums,
    cur: &'a Planes,
    other: &'a Planes,
    dc: isize,
    dr: isize,
    rho: usize,
    first: usize,
}

impl pulp::WithSimd for Advance<'_> {
    type Output = Option<usize>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Option<usize> {
        self.sums.advance(self.cur, self.other, self.dc, self.dr, self.rho, self.first)
    }
}

/// Channel row `rho`: the pair tensor of (x in `cur`, x + (dc, dr) in `other`), zero where either
/// cell is invalid or outside the grid.
#[inline(always)]
fn channel_row(cur: &Planes, other: &Planes, dc: isize, dr: isize, rho: usize, out: &mut [f32]) {
    let (w, h) = (cur.w, cur.h);
    let jr = rho as isize + dr;
    let (c0, c1) = ((-dc).max(0) as usize, (w as isize - dc).min(w as isize).max(0) as usize);
    if !(0..h as isize).contains(&jr) || c0 >= c1 {
        out.fill(0.0);
        return;
    }
    for row in out.chunks_exact_mut(w) {
        row[..c0].fill(0.0);
        row[c1..].fill(0.0);
    }
    let [xa, ya, za, ma] = cur.row(rho, c0, c1);
    let [xb, yb, zb, mb] = other.row(jr as usize, (c0 as isize + dc) as usize, (c1 as isize + dc) as usize);
    let mut rows = out.chunks_exact_mut(w);
    let mut next = || &mut rows.next().expect("seven channel rows")[c0..c1];
    let (o0, o1, o2, o3, o4, o5, o6) = (next(), next(), next(), next(), next(), next(), next());
    let n = c1 - c0;
    let (xb, yb, zb, mb, ya, za, ma) = (&xb[..n], &yb[..n], &zb[..n], &mb[..n], &ya[..n], &za[..n], &ma[..n]);
    for c in 0..n {
        let m = ma[c] * mb[c];
        let (ax, ay, az) = (xa[c] - xb[c], ya[c] - yb[c], za[c] - zb[c]);
        let (mx, my) = (m * ax, m * ay);
        o0[c] = mx * ax;
        o1[c] = mx * ay;
        o2[c] = mx * az;
        o3[c] = my * ay;
        o4[c] = my * az;
        o5[c] = m * az * az;
        o6[c] = m;
    }
}

/// `out[c] = Σ_{|c' − c| ≤ half} v[c']`, clipped to the row.
#[inline(always)]
fn across_columns(v: &[f32], out: &mut [f32], half: usize) {
    let w = v.len();
    if half <= DIRECT_MAX_HALF && w > 2 * half {
        match half {
            0 => out.copy_from_slice(v),
            1 => interior::<3>(v, &mut out[1..w - 1]),
            2 => interior::<5>(v, &mut out[2..w - 2]),
            3 => interior::<7>(v, &mut out[3..w - 3]),
            _ => interior::<9>(v, &mut out[4..w - 4]),
        }
        // Clipped columns near both ends.
        for c in (0..half).chain(w - half..w) {
            out[c] = v[c.saturating_sub(half)..(c + half + 1).min(w)].iter().sum();
        }
    } else {
        let mut s: f32 = v[..half.min(w)].iter().sum();
        for c in 0..w {
            if c + half < w {
                s += v[c + half];
            }
            out[c] = s;
            if c >= half {
                s -= v[c - half];
            }
        }
    }
}

/// `out[k] = Σ_{t < SPAN} v[k + t]`: a fixed number of adds per column, which vectorises across columns.
#[inline(always)]
fn interior<const SPAN: usize>(v: &[f32], out: &mut [f32]) {
    let n = out.len();
    let v = &v[..n + SPAN - 1];
    for (k, o) in out.iter_mut().enumerate() {
        let mut s = v[k];
        for t in 1..SPAN {
            s += v[k + t];
        }
        *o = s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::{Point3, Vector3};
    use rig::{RangeGrid, Sensor};

    fn wavy(w: usize, h: usize) -> RangeGrid {
        let mut g = RangeGrid::empty(w, h, Sensor::Center(Point3::origin()));
        for i in 0..w * h {
            let (c, r) = ((i % w) as f64, (i / w) as f64);
            g.points[i] = Point3::new(c, r, 100.0 + (c * 0.7).sin() + (r * 1.3).cos());
            g.valid[i] = i % 11 != 3;
        }
        g
    }

    /// Every patch sum, for several offsets and patch sizes (direct and running column sums), against
    /// eq. 4.5 summed directly.
    #[test]
    fn streamed_patch_sums_equal_direct_sums() {
        let (w, h) = (23usize, 71usize);
        let g = wavy(w, h);
        let planes = Planes::new(&g, &Point3::new(10.0, 30.0, 100.0));
        let d = Vector3::new(0.1, -0.2, 1.0).normalize();
        for (dc, dr, half) in [(2isize, -1isize, 2usize), (-3, 3, 1), (1, 0, 5), (0, 2, 0)] {
            let mut sums = PatchSums::new(w, h, half);
            let (mut rows, mut next) = (0, 0);
            // The whole grid in uneven bands, as the filter walks it.
            for band in [0..5, 5..40, 40..41, 41..h] {
                let band_len = band.len();
                sums.for_each_row(&planes, &planes, (dc, dr), band, |r, b| {
                    assert_eq!(r, next);
                    next += 1;
                    rows += 1;
                    for c in 0..w {
                        let (mut s, mut n) = (0.0, 0.0);
                        for rr in r.saturating_sub(half)..=(r + half).min(h - 1) {
                            for cc in c.saturating_sub(half)..=(c + half).min(w - 1) {
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
                        let m: [f64; CHANNELS] = std::array::from_fn(|k| f64::from(b[k * w + c]));
                        assert_eq!(
                            m[6],
                            f64::from(1.0 / (n as f32).max(1.0)),
                            "1 / count at ({c}, {r}), offset ({dc}, {dr}), half {half}"
                        );
                        let q = d.x * d.x * m[0]
                            + d.y * d.y * m[3]
                            + d.z * d.z * m[5]
                            + 2.0 * (d.x * d.y * m[1] + d.x * d.z * m[2] + d.y * d.z * m[4]);
                        assert!(
                            (q - s).abs() < 1e-4 * (1.0 + s),
                            "({c}, {r}) offset ({dc}, {dr}) half {half}: {q} vs {s}"
                        );
                    }
                });
                assert!(band_len > 0);
            }
            assert_eq!(rows, h);
        }
    }
}
