//! Structured-light pattern sequences: Gray code with inverses and N-step phase shift, generated here
//! and decoded by `process`, so the simulator, a real capture session and the decoder agree on what
//! every frame shows.
//!
//! # Conventions
//! Projector pixel column `c` covers `u ∈ [c − 0.5, c + 0.5)`. A Gray-code frame for bit `b` (0 = most
//! significant) lights column `c` where bit `nbits − 1 − b` of `gray(c)` is 1; its inverse lights the
//! others. A phase frame `k` of `N` with period `p` px shows `0.5 + 0.5·cos(2π·c/p − 2π·k/N)` at pixel
//! `c`, so the phase recovered at a point is `2π·u/p` (mod 2π).

use serde::{Deserialize, Serialize};

/// Which projector coordinate a pattern codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Projector columns (u).
    Columns,
    /// Projector rows (v).
    Rows,
}

/// What one captured frame shows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Pattern {
    /// Projector full on.
    White,
    /// Projector full off (ambient only).
    Black,
    /// One Gray-code bit (0 = most significant), or its inverse.
    Gray {
        /// Coded axis.
        axis: Axis,
        /// Bit index, 0 = most significant.
        bit: u32,
        /// Number of bits for this axis.
        bits: u32,
        /// Whether this is the inverse frame.
        inverse: bool,
    },
    /// One step of an N-step phase shift.
    Phase {
        /// Coded axis.
        axis: Axis,
        /// Period in projector pixels.
        period_px: f64,
        /// Step index `k` in `0..steps`.
        step: u32,
        /// Number of steps N (≥ 3; ≥ 4 recommended).
        steps: u32,
    },
    /// Laser rig: all lasers off (the background frame).
    LaserOff,
    /// Laser rig: laser `index` on, the others off.
    Laser {
        /// Index into the rig's lasers.
        index: usize,
    },
    /// The view's colour: a colour frame under the work light, projector dark and lasers off, so every
    /// view sees the object under the same light (the texture scan Horus and FabScanPi take).
    Texture,
}

/// The binary-reflected Gray code of `n`.
pub fn gray(n: u32) -> u32 {
    n ^ (n >> 1)
}

/// The integer whose Gray code is `g`: the prefix XOR of its bits, in five branch-free steps.
pub fn gray_inverse(g: u32) -> u32 {
    let mut n = g ^ (g >> 16);
    n ^= n >> 8;
    n ^= n >> 4;
    n ^= n >> 2;
    n ^ (n >> 1)
}

/// Bits needed to code `size` columns or rows: `ceil(log2 size)` (OpenCV's `GrayCodePattern` count).
pub fn bits_for(size: u32) -> u32 {
    if size <= 1 { 0 } else { 32 - (size - 1).leading_zeros() }
}

impl Pattern {
    /// The value in [0, 1] projector pixel (`col`, `row`) shows; 0 for laser frames.
    pub fn pixel_value(&self, col: u32, row: u32) -> f64 {
        match *self {
            Pattern::White => 1.0,
            Pattern::Black | Pattern::LaserOff | Pattern::Laser { .. } | Pattern::Texture => 0.0,
            Pattern::Gray { axis, bit, bits, inverse } => {
                let c = if axis == Axis::Columns { col } else { row };
                let on = (gray(c) >> (bits - 1 - bit)) & 1 == 1;
                if on != inverse { 1.0 } else { 0.0 }
            }
            Pattern::Phase { axis, period_px, step, steps } => {
                let c = if axis == Axis::Columns { col } else { row } as f64;
                let arg = std::f64::consts::TAU * (c / period_px - step as f64 / steps as f64);
                0.5 + 0.5 * arg.cos()
            }
        }
    }

    /// The axis a projector pattern varies along; `None` for uniform and laser frames.
    pub fn axis(&self) -> Option<Axis> {
        match self {
            Pattern::Gray { axis, .. } | Pattern::Phase { axis, .. } => Some(*axis),
            _ => None,
        }
    }

    /// A short file-name stem: `white`, `gray_col_03_inv`, `phase_row_p16_2of4`, `laser1`.
    pub fn name(&self) -> String {
        let ax = |a: Axis| if a == Axis::Columns { "col" } else { "row" };
        match *self {
            Pattern::White => "white".into(),
            Pattern::Black => "black".into(),
            Pattern::Gray { axis, bit, inverse, .. } => {
                format!("gray_{}_{bit:02}{}", ax(axis), if inverse { "_inv" } else { "" })
            }
            Pattern::Phase { axis, period_px, step, steps } => {
                format!("phase_{}_p{period_px}_{step}of{steps}", ax(axis))
            }
            Pattern::LaserOff => "laser_off".into(),
            Pattern::Laser { index } => format!("laser{index}"),
            Pattern::Texture => "texture".into(),
        }
    }
}

/// A phase-shift set: N steps at one period along one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PhaseShift {
    /// Coded axis.
    pub axis: Axis,
    /// Period in projector pixels.
    pub period_px: f64,
    /// Number of steps.
    pub steps: u32,
}

/// The structured-light program: white, black, Gray-code column bits (each pattern then its inverse,
/// most significant first, as OpenCV's `GrayCodePattern` orders them), row bits the same way, then the
/// phase-shift sets.
pub fn structured_light_sequence(proj_width: u32, proj_height: u32, phase: &[PhaseShift]) -> Vec<Pattern> {
    let mut seq = vec![Pattern::White, Pattern::Black];
    for (axis, size) in [(Axis::Columns, proj_width), (Axis::Rows, proj_height)] {
        let bits = bits_for(size);
        for bit in 0..bits {
            for inverse in [false, true] {
                seq.push(Pattern::Gray { axis, bit, bits, inverse });
            }
        }
    }
    for p in phase {
        seq.extend((0..p.steps).map(|step| Pattern::Phase {
            axis: p.axis,
            period_px: p.period_px,
            step,
            steps: p.steps,
        }));
    }
    seq
}

/// The laser program: the background frame, then one frame per laser.
pub fn laser_sequence(lasers: usize) -> Vec<Pattern> {
    std::iter::once(Pattern::LaserOff).chain((0..lasers).map(|index| Pattern::Laser { index })).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gray_code_round_trips_and_neighbours_differ_in_one_bit() {
        for n in (0..5000u32).chain([u32::MAX, u32::MAX - 1, 1 << 31, 0x5555_5555]) {
            assert_eq!(gray_inverse(gray(n)), n);
        }
        for n in 0..5000u32 {
            assert_eq!((gray(n) ^ gray(n + 1)).count_ones(), 1);
        }
    }

    #[test]
    fn opencv_bit_counts() {
        // 1024×768: 10 + 10 bits → 40 pattern frames, 42 with white and black.
        assert_eq!((bits_for(1024), bits_for(768)), (10, 10));
        assert_eq!(structured_light_sequence(1024, 768, &[]).len(), 42);
        assert_eq!((bits_for(1), bits_for(2), bits_for(3), bits_for(1280)), (0, 1, 2, 11));
    }

    #[test]
    fn gray_frames_spell_each_column() {
        let seq = structured_light_sequence(1024, 768, &[]);
        for col in [0u32, 1, 511, 512, 1023] {
            let mut g = 0;
            for p in &seq {
                if let Pattern::Gray { axis: Axis::Columns, inverse: false, .. } = p {
                    g = (g << 1) | p.pixel_value(col, 0) as u32;
                }
            }
            assert_eq!(gray_inverse(g), col);
        }
    }
}
