//! Per-scan non-local denoising of range grids (thesis ch. 4), static and time-varying, with the
//! bilateral filter in the same framework as the baseline the thesis compares to.
//!
//! Every valid point moves along its displacement direction `d_i` — the normal for additive noise, the
//! line of sight for view-dependent noise — by the weighted mean of its neighbours' offsets from the
//! plane through it (eq. 4.3). The weights are a distance term Φ_d and a similarity term Φ_s (eq. 4.4):
//! non-local similarity compares whole patches around the two points (eq. 4.5), bilateral similarity
//! only the two points. Sequences add neighbours from nearby frames with frame weights Ψ (eq. 4.6).
//!
//! Parts: [`noise`] (each grid's noise and sampling, which choose the filter's sizes by default),
//! [`directions`] (least-squares normals or lines of sight), [`bandwidth`] (automatic d and s,
//! section 4.3.2), `patch` (patch similarity by streaming box sums, so its cost stops growing with the
//! patch size: about 0.043 s per 640 × 480 grid at 3 × 3, 0.071–0.074 s from 11 × 11 to 21 × 21), `weights` (eq. 4.4's weights, vectorised), `planes` (the single-precision layout they
//! run on), [`filter`] (the weighted averages of eqs. 4.3 and 4.6).

pub mod bandwidth;
pub mod directions;
pub mod filter;
pub mod noise;
mod patch;
mod planes;
mod weights;

pub use filter::{denoise, denoise_sequence};

use rig::math::Real;
use serde::Serialize;

/// Which way points may move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Along the least-squares normal: additive noise.
    Normal,
    /// Along the line of sight to the sensor: view-dependent noise (structured light, laser).
    LineOfSight,
}

/// How similar two points are judged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Similarity {
    /// Eq. 4.5: the mean squared height difference of the two `(2·half + 1)²` patches.
    NonLocal {
        /// Half-size of the similarity patch O (2 gives the thesis's 5 × 5).
        half: usize,
    },
    /// The bilateral filter: the height difference of the two points alone.
    Bilateral,
}

/// Parameters of the filter. `Default` chooses the sizes from each grid's measured noise
/// ([`DenoiseParams::sized_for`]); its fixed fields are the thesis's setting (N 7 × 7, O 5 × 5, normals,
/// one pass, adaptive neighbourhoods, automatic bandwidths), used as they are with `from_noise: false`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DenoiseParams {
    /// Half-size of the neighbourhood N (3 gives 7 × 7).
    pub window: usize,
    /// The similarity measure.
    pub similarity: Similarity,
    /// The displacement direction.
    pub direction: Direction,
    /// Passes of the filter.
    pub iterations: usize,
    /// Shrink N stepwise near holes and borders (section 4.3.2).
    pub adaptive: bool,
    /// Bandwidths (d, s) in the grid's units; `None` estimates them from random samples.
    pub bandwidth: Option<(Real, Real)>,
    /// Half-size of the least-squares window for normals (1 gives 3 × 3).
    pub normal_window: usize,
    /// Seed of the bandwidth samples.
    pub seed: u64,
    /// Sequences: displacement directions come from the mean of the frames within this many of the
    /// current one (at least the filter's own span). Normals of one noisy frame tilt from frame to
    /// frame and push points sideways; on the test wall, flicker against per-frame filtering was
    /// 0.82 × from single-frame normals, 0.49 × / 0.41 × / 0.38 × from means over ±1 / ±2 / ±3.
    pub direction_frames: usize,
    /// Drop cells without a valid 8-neighbour before filtering. Eq. 4.3 cannot move a lone cell (its
    /// neighbourhood is itself), and on real scanners lone cells are mostly flying pixels: the Stanford
    /// bunny's `ear_back` holds one 79 mm from the surface, 42 % of the ten scans' squared error.
    pub drop_isolated: bool,
    /// Choose `window`, `normal_window`, the patch, the passes and the similarity bandwidth s per grid
    /// from its measured noise and sampling ([`noise`], [`DenoiseParams::sized_for`]); the fields here
    /// are then used only for a grid too small to measure, and for sequences (`denoise_sequence` with
    /// neighbouring frames), where the thesis's setting measured better. Explicit `bandwidth` still wins.
    pub from_noise: bool,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        DenoiseParams {
            window: 3,
            similarity: Similarity::NonLocal { half: 2 },
            direction: Direction::Normal,
            iterations: 1,
            adaptive: true,
            bandwidth: None,
            normal_window: 1,
            seed: 1,
            direction_frames: 2,
            drop_isolated: true,
            from_noise: true,
        }
    }
}

/// How many times the deviation two cells out ([`noise::NoiseLevel::sigma_wide`]) the similarity
/// bandwidth s is, when sizes follow the noise. Chosen on two kinds of data with the rest of the rule
/// (`tests/process/denoise.rs`): the Stanford bunny's ten real scans, median / RMS distance to bun_zipper
/// 0.0518 / 0.1364 mm at 3× and 0.0516 / 0.1332 at 4× (2× σ, not σ_wide: 0.0534 / 0.1458; one setting by
/// hand reached 0.0512 / 0.1289), and simulated grids with white noise, fandisk RMS 0.0772 mm at 3× and
/// 0.0796 at 4× (2× σ: 0.0730). 3× is the compromise.
pub const S_PER_SIGMA_WIDE: Real = 3.0;

impl DenoiseParams {
    /// The thesis's fixed setting (N 7 × 7, O 5 × 5, one pass, automatic d and s of section 4.3.2),
    /// not sized from the noise.
    pub fn thesis() -> Self {
        DenoiseParams { from_noise: false, ..Default::default() }
    }

    /// The filter's sizes for a grid of this noise level, and the similarity bandwidth s to use with
    /// them (`None`: section 4.3.2's σ_s; the distance bandwidth d stays its 0.75·μ_d of the chosen
    /// neighbourhood).
    ///
    /// - N grows with the noise over the sampling, q = σ/h: each sample carries more noise, so more
    ///   samples are averaged; half-size `round(3.5·√q)` from 1 to 5 (3 × 3 below q = 0.18, 5 × 5 to
    ///   0.51, 7 × 7 to 1.0). The bunny's real scans read q ≈ 0.07 (3 × 3 was their best by hand, 7 × 7
    ///   shrank their curves), the simulator's σ = 0.002 of the diagonal q ≈ 0.68 (7 × 7 best, 9 × 9
    ///   worse).
    /// - Normals from 3 × 3 cells below q = 0.25, from 5 × 5 above: at q ≈ 0.7 the 3 × 3 normals tilt so
    ///   far that displacing along them moved points sideways (the simulator's RMS 0.19 against 0.097 mm).
    /// - Two passes and a 3 × 3 patch: best of one to three passes and 3 × 3 or 5 × 5 patches on both.
    /// - s = [`S_PER_SIGMA_WIDE`]·σ_wide: patches that differ by no more than the grid's own noise at
    ///   the patch's scale are averaged. On white noise σ_wide ≈ σ; where the scanner's error is
    ///   correlated over cells (the bunny's: 0.64 from one cell to the next) it reads 1.6 σ, and a
    ///   similarity tuned to σ alone would refuse neighbours the error made different.
    /// - Along lines of sight (view-dependent noise, thesis §4.4) q is measured along the rays
    ///   ([`noise::NoiseLevel::sight`]) and the rest is the thesis's: a 5 × 5 patch, one pass, σ_s. On
    ///   the simulator's noise along the rays that read 0.1216 mm against 0.1340 for the normals' choice.
    pub fn sized_for(&self, level: &noise::NoiseLevel) -> (DenoiseParams, Option<Real>) {
        // Along the line of sight the noise is measured along the rays: σ along the normal over the
        // cosine between them.
        let sight = self.direction == Direction::LineOfSight;
        let along = if sight { level.sight } else { 1.0 };
        let q = level.ratio() * along;
        let window = (3.5 * q.sqrt()).round().clamp(1.0, 5.0) as usize;
        let (half, iterations, s) =
            if sight { (2, 1, None) } else { (1, 2, Some(S_PER_SIGMA_WIDE * level.sigma_wide)) };
        let p = DenoiseParams {
            window,
            normal_window: if q < 0.25 { 1 } else { 2 },
            iterations,
            similarity: match self.similarity {
                Similarity::NonLocal { .. } => Similarity::NonLocal { half },
                Similarity::Bilateral => Similarity::Bilateral,
            },
            from_noise: false,
            ..*self
        };
        (p, s)
    }
}

/// What a denoising run did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct DenoiseReport {
    /// Valid points filtered.
    pub points: usize,
    /// Lone cells dropped before filtering (see [`DenoiseParams::drop_isolated`]).
    pub isolated_dropped: usize,
    /// Distance bandwidth d of each pass, in the grid's units (mm for scanrig's own grids, metres
    /// for the Stanford scans).
    pub d: Vec<Real>,
    /// Similarity bandwidth s of each pass, in the grid's units.
    pub s: Vec<Real>,
    /// RMS displacement of each pass, in the grid's units.
    pub rms_displacement: Vec<Real>,
    /// Seconds spent on displacement directions (normals), over all passes.
    pub seconds_directions: Real,
    /// Seconds spent estimating bandwidths.
    pub seconds_bandwidth: Real,
    /// Seconds spent in the weighted averages (eqs. 4.3 / 4.6).
    pub seconds_filter: Real,
    /// Seconds in all.
    pub seconds: Real,
    /// The grid's measured noise, where the sizes followed it.
    #[serde(default)]
    pub noise: Option<noise::NoiseLevel>,
    /// The neighbourhood N's half-size that ran.
    #[serde(default)]
    pub window: usize,
    /// The similarity patch's half-size that ran (0 for the bilateral filter).
    #[serde(default)]
    pub patch: usize,
    /// Passes that ran.
    #[serde(default)]
    pub iterations: usize,
}

/// A grid the filter cannot work on, or bandwidths it cannot use on it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DenoiseError {
    /// Too few valid points to estimate anything.
    #[error("the range grid has {0} valid points; denoising needs at least 16")]
    TooFewPoints(usize),
    /// Frames of a sequence differ in size.
    #[error("frame {frame} is {w}×{h}, the current frame {cw}×{ch}")]
    SizeMismatch {
        /// The frame.
        frame: usize,
        /// Its width.
        w: usize,
        /// Its height.
        h: usize,
        /// The current frame's width.
        cw: usize,
        /// The current frame's height.
        ch: usize,
    },
    /// The current frame index is not in the sequence.
    #[error("frame {0} is not in the sequence")]
    NoSuchFrame(usize),
    /// A bandwidth given by hand so small against this grid that the neighbours' weights all but
    /// vanish and the filter would barely move anything (most often a value in the wrong unit).
    #[error(
        "bandwidth {which} = {given:.3e} is under a quarter of this grid's own {which} ({own:.3e}, in the \
         grid's units): the neighbours would weigh next to nothing and the filter would barely move \
         anything; give at least {least:.3e}"
    )]
    BandwidthTooSmall {
        /// "d" (distance) or "s" (similarity).
        which: &'static str,
        /// The value given.
        given: Real,
        /// The automatic value of section 4.3.2 on this grid.
        own: Real,
        /// The smallest value accepted.
        least: Real,
    },
}
