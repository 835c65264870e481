//! N-step phase shift: the wrapped phase of a sinusoid shifted by 2π/N between frames, and its
//! unwrapping by the Gray-code index.
//!
//! Frame k shows `0.5 + 0.5·cos(2π·x/p − 2π·k/N)` (see `rig::patterns`), so a pixel records
//! `I_k = A + B·cos(θ − 2πk/N)` with θ = 2π·x/p. Then `Σ I_k·sin(2πk/N) = (N/2)·B·sin θ` and
//! `Σ I_k·cos(2πk/N) = (N/2)·B·cos θ`: θ is the angle of the two sums and B their norm over N/2.
//! Harmonics of the pattern up to order N − 2 cancel, which is why the projector's gamma must be
//! compensated for N = 4.

use std::f64::consts::TAU;

/// The sines and cosines of the N step angles, computed once per decode.
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseSteps {
    sin: Vec<f64>,
    cos: Vec<f64>,
    /// The period in projector pixels.
    pub period_px: f64,
}

impl PhaseSteps {
    /// N steps with period `period_px`.
    pub fn new(steps: usize, period_px: f64) -> Self {
        let (sin, cos) = (0..steps).map(|k| (TAU * k as f64 / steps as f64).sin_cos()).unzip();
        PhaseSteps { sin, cos, period_px }
    }

    /// The (sin, cos) weights of step `k`.
    pub fn weights(&self, k: usize) -> (f32, f32) {
        (self.sin[k] as f32, self.cos[k] as f32)
    }

    /// Position within the period and modulation from the sums `Σ I_k·sin(2πk/N)` and `Σ I_k·cos(2πk/N)`.
    /// Single precision: its 1e-7 rad is far below what 8-bit frames resolve, at half the cost.
    pub fn finish(&self, s: f64, c: f64) -> (f64, f64) {
        let (s, c) = (s as f32, c as f32);
        let theta = s.atan2(c).rem_euclid(std::f32::consts::TAU) as f64;
        (theta / TAU * self.period_px, 2.0 * (s * s + c * c).sqrt() as f64 / self.sin.len() as f64)
    }

    /// One pixel's position within the period (projector pixels, in [0, p)) and modulation B (grey
    /// levels), from its N grey levels in step order.
    pub fn decode_pixel(&self, values: impl Iterator<Item = u8>) -> (f64, f64) {
        let (mut s, mut c) = (0.0, 0.0);
        for (k, v) in values.enumerate() {
            s += v as f64 * self.sin[k];
            c += v as f64 * self.cos[k];
        }
        self.finish(s, c)
    }
}

/// Unwraps a position within the period using the Gray-code index of the same pixel: the period count
/// is the one that puts the result nearest the index. `None` when the two disagree by more than
/// `tolerance_px` (a decoding error on one side, typically at a depth edge or in a mixed pixel).
pub fn unwrap(wrapped: f64, gray_index: u32, period_px: f64, tolerance_px: f64) -> Option<f64> {
    let c = gray_index as f64;
    let k = ((c - wrapped) / period_px).round();
    let x = wrapped + k * period_px;
    ((x - c).abs() <= tolerance_px).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_the_phase_of_a_synthetic_sinusoid() {
        let steps = PhaseSteps::new(4, 16.0);
        for &x in &[0.0, 3.3, 7.9, 15.99] {
            let values = (0..4).map(|k| (120.0 + 80.0 * (TAU * x / 16.0 - TAU * k as f64 / 4.0).cos()).round() as u8);
            let (w, b) = steps.decode_pixel(values);
            let err = (w - x).abs().min(16.0 - (w - x).abs());
            assert!(err < 0.05, "x {x}: {w}");
            assert!((b - 80.0).abs() < 1.0);
        }
    }

    #[test]
    fn unwrapping_picks_the_period_nearest_the_gray_index() {
        assert_eq!(unwrap(15.8, 48, 16.0, 1.5), Some(47.8));
        assert_eq!(unwrap(0.2, 48, 16.0, 1.5), Some(48.2));
        assert_eq!(unwrap(8.0, 48, 16.0, 1.5), None);
    }
}
