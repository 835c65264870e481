//! The limits of every stage's parameters, in one place. Each stage's params type has a `validate`
//! (in [`crate::validate`], against the bounds here) that its stage function calls first, before any
//! work, and [`crate::ProcessParams::validate`] runs them all before `process`'s first stage — so a value that cannot be right is refused in
//! milliseconds with the option's name, whether it came from the command line, Python or Rust.
//! The command line and the bindings re-state none of these checks.
//!
//! | option | limit | why |
//! |---|---|---|
//! | `--shadow-threshold`, `--gray-fit-radius` | see `decode::DecodeParams::validate` | the decoder owns them |
//! | `--k` (fusion) | 6 ..= [`MAX_FUSE_K`](crate::limits::MAX_FUSE_K), and at most half the cloud | a kernel fits a plane to its neighbours; one that spans the cloud fuses it into a blob |
//! | `--window`, `--patch` | odd, 3 ..= [`MAX_WINDOW`](crate::limits::MAX_WINDOW) | the filter's work grows with the square; past it a grid's surface is not locally flat |
//! | `--iterations` | 1 ..= 100 | |
//! | `--crop-radius` | > 0, finite | |
//! | `--crop-min-height` | finite, below [`MAX_HEIGHT_MM`](crate::limits::MAX_HEIGHT_MM) | |
//! | `--max-correction-deg` / `-mm` | (0, 180] / > 0 finite | |
//! | `--depth` (fft) | [`FFT_DEPTHS`](crate::limits::FFT_DEPTHS) | 2^11 per axis is 64 GB of grid |
//! | `--depth` (adfft) | [`ADFFT_DEPTHS`](crate::limits::ADFFT_DEPTHS) | |
//! | `--memory-budget` | > 0, finite | |
//! | `--smoothing-cells` | (0, 64] | |
//! | `--error` | > 0, finite | |
//! | `--trim` | > 0, finite | |
//! | `--spacing` | > 0, finite; against the mesh: 1/[`MAX_SPACING_RATIO`](crate::remesh::quad_remesh::MAX_SPACING_RATIO) of the default up to half the diagonal | |
//! | `--features` | [0, 180] degrees | |
//! | `--weight` | > 0, finite | |
//! | `padding` (library, Python's distributed jobs) | [0, 1] of the cube's edge | below 0 the cube cuts samples off; past 1 the grid is mostly empty |
//! | AdFFT's `scale`, `coarse_weight`, `test_fraction`, `min_points`, `min_component`, `smoothing_cells`, `test_depth`, `coarse_depth` (library) | see [`AdFftParams::check_fields`](crate::reconstruct::adfft::AdFftParams::check_fields) | a NaN or a support smaller than its cell went on into the grid unchecked, far from where the value was set |

use rig::math::Real;

/// Largest neighbourhood or patch side of the denoising filter.
pub const MAX_WINDOW: usize = 31;
/// Largest number of neighbours a fusion kernel may take.
pub const MAX_FUSE_K: usize = 1000;
/// Highest crop floor, mm: no turntable holds an object taller than this.
pub const MAX_HEIGHT_MM: Real = 10_000.0;
/// Grid depths the global FFT method accepts.
pub const FFT_DEPTHS: std::ops::RangeInclusive<u32> = 2..=10;
/// Equivalent-grid depths AdFFT accepts. Past the samples' detail the grid stops at the depth they
/// carry ([`AdFftParams::samples_per_cell`](crate::reconstruct::adfft::AdFftParams)); forced to the
/// full depth, the blend visits every point of the 2^(3·depth) grid: depth 10 (10⁹ points) took 88 s
/// and 1.6 GB on the bunny on 2 cores, 11 would take eight times that, 12 is out of reach.
pub const ADFFT_DEPTHS: std::ops::RangeInclusive<u32> = 6..=11;
/// The most samples per surface cell AdFFT's grid may be asked to hold: past it even a dense scan's
/// grid would drop to the coarsest depth.
pub const MAX_SAMPLES_PER_CELL: Real = 1000.0;
/// AdFFT's `--error`, as a fraction of the cloud's bounding-box diagonal: below the smallest every
/// cell splits to the finest depth, above the largest none does.
pub const ADFFT_ERROR_RANGE: (Real, Real) = (1e-7, 0.1);

/// AdFFT's support scale (the thesis's c is 1.8): at least the cell itself.
pub const ADFFT_SCALE: std::ops::RangeInclusive<Real> = 1.0..=4.0;
/// AdFFT's low-pass, in cells (the global method's `--smoothing-cells` also stops at 64).
pub const ADFFT_SMOOTHING_CELLS: std::ops::RangeInclusive<Real> = 0.0..=64.0;

pub use rig::limits::ParamError;

pub(crate) fn bad(option: &'static str, value: impl std::fmt::Display, why: impl Into<String>) -> ParamError {
    ParamError { option, value: value.to_string(), why: why.into() }
}

pub(crate) fn positive(option: &'static str, x: Real, what: &str) -> Result<(), ParamError> {
    if x > 0.0 && x.is_finite() { Ok(()) } else { Err(bad(option, x, format!("must be a positive {what}"))) }
}
/// The reconstruction's bounding-cube margin: a fraction of the cube's edge on each side.
pub(crate) fn check_padding(padding: Real) -> Result<(), ParamError> {
    if (0.0..=1.0).contains(&padding) {
        Ok(())
    } else {
        Err(bad("padding", padding, "must be a fraction of the bounding cube's edge from 0 to 1"))
    }
}

/// A memory budget: a positive number of bytes.
pub(crate) fn budget(bytes: u64) -> Result<(), ParamError> {
    if bytes == 0 {
        return Err(bad("--memory-budget", 0, "must be a positive number of GB"));
    }
    Ok(())
}
