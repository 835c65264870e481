//! Three-dimensional real FFT of an N³ grid (x fastest): real-to-complex along x, which halves the
//! spectrum to (N/2 + 1)·N·N, then complex transforms along y and z; rayon over lines.

use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Plans for one grid size.
pub struct RealFft3 {
    n: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    forward: Arc<dyn Fft<f32>>,
    inverse: Arc<dyn Fft<f32>>,
}

/// z-lines gathered per batch: enough to keep both cores busy, little memory beside the grid.
const Z_BATCH_ROWS: usize = 8;

impl RealFft3 {
    /// Plans transforms of an `n`³ grid; `n` even.
    pub fn new(n: usize) -> Self {
        assert!(n >= 2 && n.is_multiple_of(2), "grid size must be even, got {n}");
        let mut real = RealFftPlanner::<f32>::new();
        let mut complex = FftPlanner::<f32>::new();
        RealFft3 {
            n,
            r2c: real.plan_fft_forward(n),
            c2r: real.plan_fft_inverse(n),
            forward: complex.plan_fft_forward(n),
            inverse: complex.plan_fft_inverse(n),
        }
    }

    /// Grid points per axis.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Spectrum entries along x: N/2 + 1.
    pub fn half(&self) -> usize {
        self.n / 2 + 1
    }

    /// The spectrum's length, (N/2 + 1)·N·N; entry (kx, ky, kz) at `kx + half·(ky + N·kz)`.
    pub fn spectrum_len(&self) -> usize {
        self.half() * self.n * self.n
    }

    /// Forward transform. `real` (N³) is used as scratch and left garbage.
    pub fn forward(&self, real: &mut [f32], spectrum: &mut [Complex32]) {
        let (n, h) = (self.n, self.half());
        assert_eq!((real.len(), spectrum.len()), (n * n * n, self.spectrum_len()));
        real.par_chunks_mut(n).zip(spectrum.par_chunks_mut(h)).for_each_init(
            || self.r2c.make_scratch_vec(),
            |scratch, (line, out)| self.r2c.process_with_scratch(line, out, scratch).expect("lengths match"),
        );
        self.along_y(spectrum, &self.forward);
        self.along_z(spectrum, &self.forward);
    }

    /// Inverse transform (unnormalised: a forward–inverse round trip scales by N³). `spectrum` is
    /// left garbage.
    pub fn inverse(&self, spectrum: &mut [Complex32], real: &mut [f32]) {
        let (n, h) = (self.n, self.half());
        assert_eq!((real.len(), spectrum.len()), (n * n * n, self.spectrum_len()));
        self.along_z(spectrum, &self.inverse);
        self.along_y(spectrum, &self.inverse);
        spectrum.par_chunks_mut(h).zip(real.par_chunks_mut(n)).for_each_init(
            || self.c2r.make_scratch_vec(),
            |scratch, (line, out)| {
                // A real signal's spectrum has real DC and Nyquist terms; rounding leaves tiny
                // imaginary parts there, which the transform would refuse.
                line[0].im = 0.0;
                line[h - 1].im = 0.0;
                self.c2r.process_with_scratch(line, out, scratch).expect("lengths match");
            },
        );
    }

    /// Transforms along y: each z-slab is contiguous, so slabs go in parallel.
    fn along_y(&self, spectrum: &mut [Complex32], fft: &Arc<dyn Fft<f32>>) {
        let (n, h) = (self.n, self.half());
        spectrum.par_chunks_mut(h * n).for_each_init(
            || (vec![Complex32::default(); n], vec![Complex32::default(); fft.get_inplace_scratch_len()]),
            |(line, scratch), slab| {
                for kx in 0..h {
                    for y in 0..n {
                        line[y] = slab[kx + h * y];
                    }
                    fft.process_with_scratch(line, scratch);
                    for y in 0..n {
                        slab[kx + h * y] = line[y];
                    }
                }
            },
        );
    }

    /// Transforms along z: lines cross every slab, so batches of y-rows are gathered, transformed in
    /// parallel and scattered back.
    fn along_z(&self, spectrum: &mut [Complex32], fft: &Arc<dyn Fft<f32>>) {
        let (n, h) = (self.n, self.half());
        for rows in (0..n).collect::<Vec<_>>().chunks(Z_BATCH_ROWS) {
            let done: Vec<Vec<Complex32>> = rows
                .par_iter()
                .map_init(
                    || vec![Complex32::default(); fft.get_inplace_scratch_len()],
                    |scratch, &y| {
                        // The row's h lines of length n, line by line.
                        let mut block = vec![Complex32::default(); h * n];
                        for kx in 0..h {
                            let line = &mut block[kx * n..(kx + 1) * n];
                            for (z, v) in line.iter_mut().enumerate() {
                                *v = spectrum[kx + h * (y + n * z)];
                            }
                            fft.process_with_scratch(line, scratch);
                        }
                        block
                    },
                )
                .collect();
            for (&y, block) in rows.iter().zip(done) {
                for kx in 0..h {
                    for z in 0..n {
                        spectrum[kx + h * (y + n * z)] = block[kx * n + z];
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_round_trip_restores_the_grid_and_a_plane_wave_lands_on_its_frequency() {
        let n = 12;
        let fft = RealFft3::new(n);
        let wave = |x: usize, y: usize, z: usize| {
            let t = std::f32::consts::TAU * (2.0 * x as f32 + 3.0 * y as f32 + 5.0 * z as f32) / n as f32;
            t.cos()
        };
        let grid: Vec<f32> = (0..n * n * n).map(|i| wave(i % n, (i / n) % n, i / (n * n)) + 0.25).collect();
        let mut real = grid.clone();
        let mut spectrum = vec![Complex32::default(); fft.spectrum_len()];
        fft.forward(&mut real, &mut spectrum);
        let total = (n * n * n) as f32;
        let at = |kx: usize, ky: usize, kz: usize| spectrum[kx + fft.half() * (ky + n * kz)];
        // cos(ω·x) puts N³/2 at +ω (the conjugate at −ω is not stored in the half spectrum).
        assert!((at(2, 3, 5).re - total / 2.0).abs() < 1e-2 * total, "{:?}", at(2, 3, 5));
        assert!((at(0, 0, 0).re - 0.25 * total).abs() < 1e-3 * total);
        let others: f32 = spectrum.iter().map(|c| c.norm()).sum::<f32>() - at(2, 3, 5).norm() - at(0, 0, 0).norm();
        assert!(others < 1e-2 * total, "leakage {others}");
        fft.inverse(&mut spectrum, &mut real);
        let worst = real.iter().zip(&grid).map(|(r, g)| (r / total - g).abs()).fold(0.0, f32::max);
        assert!(worst < 1e-4, "round trip off by {worst}");
    }
}
