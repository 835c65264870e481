//! Three-dimensional real FFT of an N³ grid (x fastest): real-to-complex along x, which halves the
//! spectrum to (N/2 + 1)·N·N, then complex transforms along y and z; rayon over lines.
//!
//! Each z-plane is transformed along x and y in one go, in parallel over planes: its rows along x,
//! 8 at a time (a cache line of complex f32), their spectra written column by column so that the
//! plane is then y-fastest and its lines along y are contiguous. The lines along z are then gathered
//! across the planes, a few at a time, and transformed where they land: the spectrum is z-fastest,
//! entry (kx, ky, kz) at `kz + N·(ky + N·kx)`, and the inverse transposes it back. Gathering
//! each line across the planes and scattering it back, the layout x-fastest throughout, had taken a
//! third of a leaf's solve in AdFFT. Whoever multiplies the spectrum reads it in this layout
//! ([`RealFft3::spectrum_index`]).

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
    /// Fewest lines one rayon job takes: 1 spreads a transform over the threads; `usize::MAX` keeps
    /// it on the calling thread, for solves that are themselves run side by side (AdFFT's leaves).
    min_len: usize,
}

/// Rows or columns moved together by the planes' transforms and the transposes: 8 complex f32 are
/// one 64-byte cache line, so each line read is used whole.
const BLOCK: usize = 8;

/// Lines along z gathered and transformed together by [`RealFft3::forward_z`]: 32 at 128³ are 32 KB.
const Z_LINES: usize = 32;

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
            min_len: 1,
        }
    }

    /// Whether the transforms spread over rayon's threads (the default) or stay on the caller's.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.min_len = if parallel { 1 } else { usize::MAX };
    }

    /// What [`RealFft3::set_parallel`] set, as the fewest items of a rayon job (for the caller's own
    /// loops over the same grid).
    pub fn min_len(&self) -> usize {
        self.min_len
    }

    /// Grid points per axis.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Spectrum entries along x: N/2 + 1.
    pub fn half(&self) -> usize {
        self.n / 2 + 1
    }

    /// The spectrum's length, (N/2 + 1)·N·N.
    pub fn spectrum_len(&self) -> usize {
        self.half() * self.n * self.n
    }

    /// Where entry (kx, ky, kz) of the spectrum is.
    pub fn spectrum_index(&self, kx: usize, ky: usize, kz: usize) -> usize {
        kz + self.n * (ky + self.n * kx)
    }

    /// The grid of N³ real values (x fastest) held at the start of a spectrum-sized buffer: the
    /// forward transform reads its input there and the inverse leaves its output there.
    pub fn real_part<'b>(&self, buffer: &'b mut [Complex32]) -> &'b mut [f32] {
        let n3 = self.n * self.n * self.n;
        &mut bytemuck::cast_slice_mut::<Complex32, f32>(buffer)[..n3]
    }

    /// [`RealFft3::real_part`], to read.
    pub fn real_view<'b>(&self, buffer: &'b [Complex32]) -> &'b [f32] {
        let n3 = self.n * self.n * self.n;
        &bytemuck::cast_slice::<Complex32, f32>(buffer)[..n3]
    }

    /// Forward transform of the real grid in `buffer` ([`RealFft3::real_part`]) into its spectrum, in
    /// `buffer` too; `scratch` (spectrum-sized) is left garbage.
    pub fn forward(&self, buffer: &mut [Complex32], scratch: &mut [Complex32]) {
        self.forward_planes(buffer, scratch, &|out, plane| out.copy_from_slice(plane));
        self.forward_z(scratch, buffer);
    }

    /// The forward transform's first half: each z-plane of the real grid in `buffer`
    /// ([`RealFft3::real_part`]; left garbage) transformed along x and y, handed to `emit` with its
    /// plane of `planes` to write, both with entry (kx, ky) at `ky + N·kx` (plane z of `planes` is
    /// its z-th (N/2 + 1)·N entries). A caller summing transforms that differ only in how their planes
    /// are weighed adds them here and takes [`RealFft3::forward_z`] once for the sum. (`emit` is a
    /// trait object, called once a plane: the parallel loop is compiled once, not per closure.)
    ///
    /// Rows that are all zero are not transformed (their spectrum is zero), nor planes that are: a
    /// local solve's samples lie on a surface, which about half the rows along x miss (0.12–0.83 of a
    /// 128³ leaf's rows are hit, 0.48 on average, over 40 leaves of the bunny at 512³).
    pub fn forward_planes(
        &self,
        buffer: &mut [Complex32],
        planes: &mut [Complex32],
        emit: &(dyn Fn(&mut [Complex32], &[Complex32]) + Sync),
    ) {
        let (n, h) = (self.n, self.half());
        assert_eq!((buffer.len(), planes.len()), (self.spectrum_len(), self.spectrum_len()));
        let real = self.real_part(buffer);
        real.par_chunks_mut(n * n).zip(planes.par_chunks_mut(h * n)).with_min_len(self.min_len).for_each_init(
            || {
                let zero = Complex32::default();
                (self.r2c.make_scratch_vec(), vec![zero; BLOCK * h], self.y_scratch(&self.forward), vec![zero; h * n])
            },
            |(work, rows, y_work, spectrum), (plane, out)| {
                let mut any = false;
                for y0 in (0..n).step_by(BLOCK) {
                    let count = BLOCK.min(n - y0);
                    for (j, row) in rows.chunks_mut(h).take(count).enumerate() {
                        let line = &mut plane[(y0 + j) * n..][..n];
                        if line.iter().all(|&v| v == 0.0) {
                            row.fill(Complex32::default());
                        } else {
                            any = true;
                            self.r2c.process_with_scratch(line, row, work).expect("lengths match");
                        }
                    }
                    for kx in 0..h {
                        for (j, v) in spectrum[kx * n + y0..][..count].iter_mut().enumerate() {
                            *v = rows[j * h + kx];
                        }
                    }
                }
                if any {
                    self.forward.process_with_scratch(spectrum, y_work);
                }
                emit(out, spectrum);
            },
        );
    }

    /// The forward transform's second half: `planes` as [`RealFft3::forward_planes`] left them
    /// transformed along z into `spectrum` ([`RealFft3::spectrum_index`]).
    ///
    /// 32 lines at a time (`Z_LINES`) are gathered across the planes and transformed while they are in
    /// cache: one pass over the spectrum where a transpose and then the transforms took two.
    pub fn forward_z(&self, planes: &[Complex32], spectrum: &mut [Complex32]) {
        let (n, row) = (self.n, self.half() * self.n);
        assert_eq!((planes.len(), spectrum.len()), (self.spectrum_len(), self.spectrum_len()));
        spectrum.par_chunks_mut(Z_LINES * n).enumerate().with_min_len(self.min_len).for_each_init(
            || vec![Complex32::default(); self.forward.get_inplace_scratch_len()],
            |scratch, (b, lines)| {
                let (c0, width) = (b * Z_LINES, lines.len() / n);
                for z in 0..n {
                    for (j, v) in planes[z * row + c0..][..width].iter().enumerate() {
                        lines[j * n + z] = *v;
                    }
                }
                self.forward.process_with_scratch(lines, scratch);
            },
        );
    }

    /// Inverse transform (unnormalised: a forward–inverse round trip scales by N³) of the spectrum in
    /// `buffer`, leaving the real grid in [`RealFft3::real_part`] of it; `scratch` is left garbage.
    pub fn inverse(&self, buffer: &mut [Complex32], scratch: &mut [Complex32]) {
        let (n, h) = (self.n, self.half());
        assert_eq!((buffer.len(), scratch.len()), (self.spectrum_len(), self.spectrum_len()));
        self.along_z(buffer, &self.inverse);
        self.to_x_fastest(buffer, scratch);
        let real = self.real_part(buffer);
        scratch.par_chunks_mut(h * n).zip(real.par_chunks_mut(n * n)).with_min_len(self.min_len).for_each_init(
            || (self.c2r.make_scratch_vec(), vec![Complex32::default(); BLOCK * h], self.y_scratch(&self.inverse)),
            |(work, rows, y_work), (plane, out)| {
                self.inverse.process_with_scratch(plane, y_work);
                for y0 in (0..n).step_by(BLOCK) {
                    let count = BLOCK.min(n - y0);
                    for kx in 0..h {
                        for (j, v) in plane[kx * n + y0..][..count].iter().enumerate() {
                            rows[j * h + kx] = *v;
                        }
                    }
                    for (j, row) in rows.chunks_mut(h).take(count).enumerate() {
                        // A real signal's spectrum has real DC and Nyquist terms; rounding leaves
                        // tiny imaginary parts there, which the transform would refuse.
                        row[0].im = 0.0;
                        row[h - 1].im = 0.0;
                        let line = &mut out[(y0 + j) * n..][..n];
                        self.c2r.process_with_scratch(row, line, work).expect("lengths match");
                    }
                }
            },
        );
    }

    /// Scratch for a plane's lines along y, transformed in one call.
    fn y_scratch(&self, fft: &Arc<dyn Fft<f32>>) -> Vec<Complex32> {
        vec![Complex32::default(); fft.get_inplace_scratch_len()]
    }

    /// Transforms along z of the spectrum z-fastest: contiguous lines, in parallel.
    fn along_z(&self, spectrum: &mut [Complex32], fft: &Arc<dyn Fft<f32>>) {
        let n = self.n;
        spectrum.par_chunks_mut(BLOCK * n).with_min_len(self.min_len).for_each_init(
            || vec![Complex32::default(); fft.get_inplace_scratch_len()],
            |scratch, lines| fft.process_with_scratch(lines, scratch),
        );
    }

    /// The inverse of [`RealFft3::forward_z`]'s gather, `to[z·(half·N) + c] = from[c·N + z]`: blocks of
    /// [`BLOCK`] z-planes in parallel.
    fn to_x_fastest(&self, from: &[Complex32], to: &mut [Complex32]) {
        let (n, row) = (self.n, self.half() * self.n);
        to.par_chunks_mut(BLOCK * row).enumerate().with_min_len(self.min_len).for_each(|(b, planes)| {
            let z0 = b * BLOCK;
            let depth = planes.len() / row;
            for c in 0..row {
                for (dz, v) in from[c * n + z0..][..depth].iter().enumerate() {
                    planes[dz * row + c] = *v;
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_round_trip_restores_the_grid_and_a_plane_wave_lands_on_its_frequency() {
        // 12 is not a multiple of the transposes' blocks: their ragged ends are covered too.
        for (n, parallel) in [(12, true), (16, true), (16, false)] {
            let mut fft = RealFft3::new(n);
            fft.set_parallel(parallel);
            let wave = |x: usize, y: usize, z: usize| {
                let t = std::f32::consts::TAU * (2.0 * x as f32 + 3.0 * y as f32 + 5.0 * z as f32) / n as f32;
                t.cos()
            };
            let grid: Vec<f32> = (0..n * n * n).map(|i| wave(i % n, (i / n) % n, i / (n * n)) + 0.25).collect();
            let mut buffer = vec![Complex32::default(); fft.spectrum_len()];
            let mut scratch = buffer.clone();
            fft.real_part(&mut buffer).copy_from_slice(&grid);
            fft.forward(&mut buffer, &mut scratch);
            let total = (n * n * n) as f32;
            let at = |kx: usize, ky: usize, kz: usize| buffer[fft.spectrum_index(kx, ky, kz)];
            // cos(ω·x) puts N³/2 at +ω (the conjugate at −ω is not stored in the half spectrum).
            assert!((at(2, 3, 5).re - total / 2.0).abs() < 1e-2 * total, "{:?}", at(2, 3, 5));
            assert!((at(0, 0, 0).re - 0.25 * total).abs() < 1e-3 * total);
            let others: f32 = buffer.iter().map(|c| c.norm()).sum::<f32>() - at(2, 3, 5).norm() - at(0, 0, 0).norm();
            assert!(others < 1e-2 * total, "leakage {others}");
            fft.inverse(&mut buffer, &mut scratch);
            let real = fft.real_part(&mut buffer);
            let worst = real.iter().zip(&grid).map(|(r, g)| (r / total - g).abs()).fold(0.0, f32::max);
            assert!(worst < 1e-4, "round trip off by {worst}");
        }
    }

    /// Rows and planes that are all zero are skipped, not dropped: a few points in an otherwise empty
    /// grid (most rows and planes zero, as a local solve's samples leave them) come out with each
    /// entry of the spectrum their analytic sum, Σ a·exp(−2πi·k·x/N).
    #[test]
    fn a_grid_of_a_few_points_has_their_analytic_spectrum() {
        let n = 16;
        let points = [((3, 5, 7), 1.0f32), ((3, 6, 7), -0.5), ((12, 0, 9), 2.0)];
        let fft = RealFft3::new(n);
        let mut buffer = vec![Complex32::default(); fft.spectrum_len()];
        let mut scratch = buffer.clone();
        for &((x, y, z), a) in &points {
            fft.real_part(&mut buffer)[x + n * (y + n * z)] = a;
        }
        fft.forward(&mut buffer, &mut scratch);
        let mut worst = 0f32;
        for kx in 0..fft.half() {
            for ky in 0..n {
                for kz in 0..n {
                    let expected: Complex32 = points
                        .iter()
                        .map(|&((x, y, z), a)| {
                            let phase = -std::f32::consts::TAU * ((kx * x + ky * y + kz * z) % n) as f32 / n as f32;
                            Complex32::from_polar(a, phase)
                        })
                        .sum();
                    worst = worst.max((buffer[fft.spectrum_index(kx, ky, kz)] - expected).norm());
                }
            }
        }
        assert!(worst < 1e-4, "spectrum off by {worst}");
    }
}
