//! Per-scan non-local denoising of range grids (thesis ch. 4), static and time-varying, with the
//! bilateral filter in the same framework as the baseline the thesis compares to.
//!
//! Every valid point moves along its displacement direction `d_i` — the normal for additive noise, the
//! line of sight for view-dependent noise — by the weighted mean of its neighbours' offsets from the
//! plane through it (eq. 4.3). The weights are a distance term Φ_d and a similarity term Φ_s (eq. 4.4):
//! non-local similarity compares whole patches around the two points (eq. 4.5), bilateral similarity
//! only the two points. Sequences add neighbours from nearby frames with frame weights Ψ (eq. 4.6).
//!
//! Parts: [`directions`] (least-squares normals or lines of sight), [`bandwidth`] (automatic d and s,
//! section 4.3.2), `patch` (patch similarity by streaming box sums, so its cost stops growing with the
//! patch size: about 0.043 s per 640 × 480 grid at 3 × 3, 0.071–0.074 s from 11 × 11 to 21 × 21), `weights` (eq. 4.4's weights, vectorised), `planes` (the single-precision layout they
//! run on), [`filter`] (the weighted averages of eqs. 4.3 and 4.6).

pub mod bandwidth;
pub mod directions;
pub mod filter;
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

/// Parameters of the filter. `Default` is the thesis's setting: N 7 × 7, O 5 × 5, normals, one pass,
/// adaptive neighbourhoods, automatic bandwidths.
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
        }
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
}

/// A grid the filter cannot work on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
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
}
