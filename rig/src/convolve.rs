//! Separable convolution of a float image with its edges clamped: the Gaussian blurs of the
//! simulator's lens and of calibration's corner detection share it (each builds its own kernel).

use rayon::prelude::*;

/// `data` (`w` × `h`, row-major) convolved with `kernel` along rows, then along columns; a tap that
/// falls outside the image reads the nearest edge pixel. `kernel` has odd length, its centre in the
/// middle. Every output pixel is `Σ k_j · src[clamp(x + j − r)]` summed from zero in the kernel's
/// order, as a loop over pixels and taps would sum it, so the bits are those of that definition; the
/// taps are added to a whole row at a time (a tap reads one contiguous run of the row, or one whole
/// row, once the clamped ends are set aside) and rows go to every core. Reading each tap through a
/// clamping accessor had been half of a 100-frame calibration and a tenth of a realistic laser sim.
/// An image whose data does not match its size gives zeros.
// Inlined into its callers, the simulator and calibration, so that it is compiled at their
// opt-level 3 and not rig's 1: rig at 3 throughout cut the calib tests by a fifth but cost CI's
// build more than the tests saved (1,366 s against 1,297).
#[inline]
pub fn convolve_clamped(data: &[f32], w: usize, h: usize, kernel: &[f32]) -> Vec<f32> {
    if w == 0 || h == 0 || data.len() != w * h || kernel.is_empty() {
        return vec![0.0; data.len()];
    }
    let r = (kernel.len() / 2) as isize;
    let mut tmp = vec![0.0f32; w * h];
    // Along rows: tap offset d reads src[clamp(x + d)]: the row's first value left of `lo`, its
    // last from `hi` on, and the row shifted by d between.
    tmp.par_chunks_mut(w).zip(data.par_chunks(w)).for_each(|(out, src)| {
        let (first, last) = (src[0], src[w - 1]);
        for (j, &k) in kernel.iter().enumerate() {
            let d = j as isize - r;
            let lo = (-d).clamp(0, w as isize) as usize;
            let hi = (w as isize - d).clamp(lo as isize, w as isize) as usize;
            out[..lo].iter_mut().for_each(|o| *o += k * first);
            if lo < hi {
                let shifted = &src[(lo as isize + d) as usize..(hi as isize + d) as usize];
                out[lo..hi].iter_mut().zip(shifted).for_each(|(o, &s)| *o += k * s);
            }
            out[hi..].iter_mut().for_each(|o| *o += k * last);
        }
    });
    // Along columns: tap offset d reads row clamp(y + d) whole.
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        for (j, &k) in kernel.iter().enumerate() {
            let yy = (y as isize + j as isize - r).clamp(0, h as isize - 1) as usize;
            out.iter_mut().zip(&tmp[yy * w..yy * w + w]).for_each(|(o, &s)| *o += k * s);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition: each pixel's taps in the kernel's order, each read through the clamp.
    fn by_definition(data: &[f32], w: usize, h: usize, kernel: &[f32]) -> Vec<f32> {
        let r = (kernel.len() / 2) as isize;
        let pass = |src: &[f32], along_rows: bool| -> Vec<f32> {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as isize, (i / w) as isize);
                    let mut acc = 0.0;
                    for (j, k) in kernel.iter().enumerate() {
                        let d = j as isize - r;
                        let (xx, yy) = if along_rows {
                            ((x + d).clamp(0, w as isize - 1), y)
                        } else {
                            (x, (y + d).clamp(0, h as isize - 1))
                        };
                        acc += k * src[yy as usize * w + xx as usize];
                    }
                    acc
                })
                .collect()
        };
        pass(&pass(data, true), false)
    }

    #[test]
    fn row_at_a_time_gives_the_definitions_bits_and_a_wrong_size_gives_zeros() {
        let mut draws = crate::split_mix::SplitMix(99);
        let mut next = || draws.below(1 << 24) as f32 / (1u64 << 24) as f32;
        // Images narrower and shorter than the kernel included: every tap then reads a clamped end.
        for (w, h, taps) in [(37, 23, 5), (64, 48, 15), (1, 5, 7), (5, 1, 7), (2, 3, 19), (3, 2, 3)] {
            let data: Vec<f32> = (0..w * h).map(|_| next()).collect();
            let kernel: Vec<f32> = (0..taps).map(|_| next()).collect();
            let (fast, slow) = (convolve_clamped(&data, w, h, &kernel), by_definition(&data, w, h, &kernel));
            assert!(fast.iter().zip(&slow).all(|(a, b)| a.to_bits() == b.to_bits()), "{w} x {h}, {taps} taps");
        }
        assert_eq!(convolve_clamped(&[1.0, 2.0, 3.0], 2, 2, &[1.0]), vec![0.0; 3]);
        assert!(convolve_clamped(&[], 0, 4, &[1.0]).is_empty());
    }
}
