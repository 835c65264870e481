//! The weights of eq. 4.4 (eq. 4.6's with the frame factor Ψ) for one row of centres and one grid
//! offset, accumulated into the sums of eq. 4.3: Σ w·h and Σ w per centre.
//!
//! The loops run over plain slices of one row so the compiler vectorises them; the exponential is
//! [`exp_neg`], a branch-free one that vectorises too.

/// Scalars of one (frame, offset) job.
#[derive(Clone, Copy)]
pub(super) struct Bandwidths {
    /// 1 / d² (eq. 4.4's Φ_d).
    pub inv_d2: f32,
    /// 1 / s² (eq. 4.4's Φ_s).
    pub inv_s2: f32,
    /// The frame weight Ψ_dk·Ψ_sk (eq. 4.6; 1 for a single frame).
    pub psi: f32,
    /// The offset's Chebyshev length: a centre uses it only if its neighbourhood reaches that far.
    pub reach: f32,
}

/// One side of a pair in a row: the centre's direction and reach, and its accumulators.
pub(super) struct Centre<'a> {
    pub dx: &'a [f32],
    pub dy: &'a [f32],
    pub dz: &'a [f32],
    pub reach: &'a [f32],
    pub num: &'a mut [f32],
    pub den: &'a mut [f32],
}

/// Positions of a row's cells (relative to the shared origin) and validity.
#[derive(Clone)]
pub(super) struct Cells<'a> {
    pub x: &'a [f32],
    pub y: &'a [f32],
    pub z: &'a [f32],
    pub m: &'a [f32],
}

/// `exp(x)` for `x ≤ 0` (relative error below 5e-6: a weight's error moves a point by that fraction of
/// its displacement), without branches: 2^n from the exponent bits times a degree-5 polynomial on
/// [−ln 2 / 2, ln 2 / 2].
#[inline(always)]
pub(super) fn exp_neg(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    // Adding and subtracting 1.5·2²³ rounds to the nearest integer without a rounding instruction.
    const ROUND: f32 = 12_582_912.0;
    let x = x.max(-87.0);
    let n = (x * LOG2E + ROUND) - ROUND;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = 1.0 + r * (1.0 + r * (0.5 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0)))));
    p * f32::from_bits(((n as i32 + 127) as u32) << 23)
}

/// The similarity term from a patch sum (eq. 4.5): the mean squared height difference along `d`.
///
/// Eq. 4.4 writes Φ_s = exp(−Sim²/s²) with eq. 4.5's Sim already a mean of squared heights; as in
/// NL-means (eq. 4.2) that is read as exp(−Sim/s²), the squared patch distance over s² (squaring it
/// again would make the weight's units mm⁴/mm²).
/// `b` holds the six sums of `a·aᵀ` and the reciprocal of the number of pairs.
#[inline(always)]
fn patch_similarity(b: [f32; 7], dx: f32, dy: f32, dz: f32) -> f32 {
    let q = dx * dx * b[0] + dy * dy * b[3] + dz * dz * b[5] + 2.0 * (dx * dy * b[1] + dx * dz * b[2] + dy * dz * b[4]);
    // b[6] is 1 / count (see `PatchSums::for_each_row`).
    q.max(0.0) * b[6]
}

/// Adds one row's pairs (centre i in `c`, neighbour j in `nb`, both `n` long) to the centres' sums.
/// `patch` holds the rows of the seven patch-sum channels for these centres (non-local similarity),
/// or is `None` for the bilateral filter. With `back`, the same pairs are also added the other way
/// round (j as the centre, i as the neighbour, whose patch sums are the same: the pair tensor is
/// symmetric in the two points), which halves the work on a single frame.
pub(super) fn accumulate_row(
    c: Centre<'_>,
    ci: Cells<'_>,
    nb: Cells<'_>,
    patch: Option<[&[f32]; 7]>,
    back: Option<Centre<'_>>,
    bw: Bandwidths,
) {
    // A row vectorises best with AVX2 and FMA where the processor has them: pulp checks once and
    // compiles this closure, with all it inlines, for each instruction set.
    pulp::Arch::new().dispatch(
        #[inline(always)]
        || match (patch, back) {
            (Some(b), None) => non_local(c, ci, nb, b, bw),
            (Some(b), Some(o)) => non_local_both_ways(c, ci, nb, b, o, bw),
            (None, back) => {
                if let Some(o) = back {
                    // The same pairs with the neighbour as the centre.
                    bilateral(o, nb.clone(), ci.clone(), bw);
                }
                bilateral(c, ci, nb, bw);
            }
        },
    );
}

/// Eq. 4.4 with eq. 4.5's similarity, centre to neighbour.
#[inline(always)]
fn non_local(c: Centre<'_>, ci: Cells<'_>, nb: Cells<'_>, b: [&[f32]; 7], bw: Bandwidths) {
    let n = c.num.len();
    let Bandwidths { inv_d2, inv_s2, psi, reach } = bw;
    let (dx, dy, dz, rc, den) = (&c.dx[..n], &c.dy[..n], &c.dz[..n], &c.reach[..n], &mut c.den[..n]);
    let (xi, yi, zi) = (&ci.x[..n], &ci.y[..n], &ci.z[..n]);
    let (xj, yj, zj, mj) = (&nb.x[..n], &nb.y[..n], &nb.z[..n], &nb.m[..n]);
    let [b0, b1, b2, b3, b4, b5, b6] = b.map(|s| &s[..n]);
    let num = c.num;
    for k in 0..n {
        let (ax, ay, az) = (xi[k] - xj[k], yi[k] - yj[k], zi[k] - zj[k]);
        let m = [b0[k], b1[k], b2[k], b3[k], b4[k], b5[k], b6[k]];
        let height = ax * dx[k] + ay * dy[k] + az * dz[k];
        let arg = (ax * ax + ay * ay + az * az) * inv_d2 + patch_similarity(m, dx[k], dy[k], dz[k]) * inv_s2;
        let wgt = if (rc[k] >= reach) & (mj[k] > 0.0) { psi * exp_neg(-arg) } else { 0.0 };
        num[k] += wgt * height;
        den[k] += wgt;
    }
}

/// [`non_local`] for the pairs both ways round: the patch sums serve both centres. Two loops over the
/// row rather than one, so each keeps its values in registers.
#[inline(always)]
fn non_local_both_ways(c: Centre<'_>, ci: Cells<'_>, nb: Cells<'_>, b: [&[f32]; 7], o: Centre<'_>, bw: Bandwidths) {
    let n = c.num.len();
    let (ci2, nb2) = (ci.clone(), nb.clone());
    non_local(c, ci, nb, b, bw);
    // The same pairs with the neighbour as the centre: (j, i) instead of (i, j).
    non_local(o, nb2, ci2, b.map(|s| &s[..n]), bw);
}

/// The bilateral filter: the similarity of the two points alone, their height difference squared.
#[inline(always)]
fn bilateral(c: Centre<'_>, ci: Cells<'_>, nb: Cells<'_>, bw: Bandwidths) {
    let n = c.num.len();
    let Bandwidths { inv_d2, inv_s2, psi, reach } = bw;
    let (dx, dy, dz, rc, den) = (&c.dx[..n], &c.dy[..n], &c.dz[..n], &c.reach[..n], &mut c.den[..n]);
    let (xi, yi, zi) = (&ci.x[..n], &ci.y[..n], &ci.z[..n]);
    let (xj, yj, zj, mj) = (&nb.x[..n], &nb.y[..n], &nb.z[..n], &nb.m[..n]);
    let num = c.num;
    for k in 0..n {
        let (ax, ay, az) = (xi[k] - xj[k], yi[k] - yj[k], zi[k] - zj[k]);
        let height = ax * dx[k] + ay * dy[k] + az * dz[k];
        let arg = (ax * ax + ay * ay + az * az) * inv_d2 + height * height * inv_s2;
        let wgt = if (rc[k] >= reach) & (mj[k] > 0.0) { psi * exp_neg(-arg) } else { 0.0 };
        num[k] += wgt * height;
        den[k] += wgt;
    }
}

#[cfg(test)]
mod tests {
    use super::exp_neg;

    #[test]
    fn the_fast_exponential_is_accurate_over_its_range() {
        let mut worst: f64 = 0.0;
        for k in 0..=200_000 {
            let x = (-87.0 * k as f64 / 200_000.0) as f32;
            let exact = f64::from(x).exp();
            worst = worst.max(((f64::from(exp_neg(x)) - exact) / exact).abs());
        }
        assert!(worst < 5e-6, "worst relative error {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(-1e30) >= 0.0 && exp_neg(-1e30) < 1e-37);
    }
}
