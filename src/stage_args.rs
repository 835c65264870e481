//! The stages' options, shared: each group is flattened into its single-stage subcommand and into
//! `process`, and turned into the library's parameter type here, with the library's `Default` as the
//! only source of defaults. So `scanrig fuse X` and `scanrig process --until fuse` run the same
//! stage with the same settings.

use anyhow::{Result, bail};
use clap::Args;
use process::DecodeParams;
use process::denoise::{DenoiseParams, Direction, Similarity};
use process::merge::CropParams;
use process::pipeline::stages::{Base, DenoiseStage, FinishParams, FuseParams, ReconstructParams};
use process::reconstruct::adfft::AdFftParams;
use process::reconstruct::global_fft::FftParams;
use process::register::register_scan::{RegisterParams, Tolerance};
use process::remesh::RemeshParams;

/// Structured-light decoding.
#[derive(Args, Debug, Clone)]
pub struct DecodeOpts {
    /// Shadow threshold: white − black below this is not decoded (OpenCV's blackThreshold is 40).
    #[arg(long, default_value_t = DecodeParams::default().shadow_threshold)]
    pub shadow_threshold: f64,
    /// A pixel whose weakest Gray bit has |pattern − inverse| below this is dropped (OpenCV's
    /// whiteThreshold is 5).
    #[arg(long, default_value_t = DecodeParams::default().bit_threshold)]
    pub bit_threshold: u8,
    /// Without phase-shift frames, refine each Gray-code column to sub-pixel by a quadratic fitted to its
    /// decoded neighbours within this many camera pixels (2 to 16); 0 keeps whole projector pixels
    /// (OpenCV's GrayCodePattern result).
    #[arg(long, value_name = "PIXELS", default_value_t = DecodeParams::default().gray_fit_radius)]
    pub gray_fit_radius: usize,
}

impl DecodeOpts {
    /// The library's parameters, checked by the library ([`DecodeParams::validate`]).
    pub fn params(&self) -> Result<DecodeParams> {
        let p = DecodeParams {
            shadow_threshold: self.shadow_threshold,
            bit_threshold: self.bit_threshold,
            gray_fit_radius: self.gray_fit_radius,
            ..Default::default()
        };
        p.validate()?;
        Ok(p)
    }
}

/// The sizes a setting by hand starts from: the thesis's.
fn defaults() -> DenoiseParams {
    DenoiseParams::thesis()
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterArg {
    /// Non-local: patch similarity (thesis ch. 4).
    NonLocal,
    /// Bilateral: the point pair's similarity only.
    Bilateral,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectionArg {
    /// Along least-squares normals (additive noise).
    Normal,
    /// Along the line of sight (view-dependent noise: structured light, lasers).
    Sight,
}

/// Denoising (thesis ch. 4).
#[derive(Args, Debug, Clone)]
pub struct DenoiseOpts {
    /// The filter.
    #[arg(long, value_enum, default_value = "non-local")]
    pub filter: FilterArg,
    /// Displacement direction.
    #[arg(long, value_enum, default_value = "normal")]
    pub direction: DirectionArg,
    /// Neighbourhood N size (odd: 7 means 7x7). Default: chosen per grid from its measured noise and
    /// sampling; giving this, --patch, --iterations or --bandwidth sets the sizes by hand instead (the
    /// ones not given take the thesis's: N 7x7, patch 5x5, one pass, d and s of section 4.3.2).
    #[arg(long)]
    pub window: Option<usize>,
    /// Similarity patch O size (odd: 5 means 5x5). Default: chosen per grid (see --window).
    #[arg(long)]
    pub patch: Option<usize>,
    /// Filter passes. Default: chosen per grid (see --window).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Keep N the same size near holes and borders.
    #[arg(long)]
    pub no_adaptive: bool,
    /// Bandwidths d and s of eq. 4.4 in the file's units, as D,S (default: d = 0.75 μd of section 4.3.2,
    /// s from the grid's measured noise; with sizes set by hand, s = σs of section 4.3.2).
    #[arg(long, value_parser = parse_bandwidth)]
    pub bandwidth: Option<(f64, f64)>,
    /// Keep cells without a valid neighbour (they cannot be filtered, and are mostly flying pixels, so
    /// by default they are dropped).
    #[arg(long)]
    pub keep_isolated: bool,
}

fn default_patch() -> usize {
    match defaults().similarity {
        Similarity::NonLocal { half } => 2 * half + 1,
        Similarity::Bilateral => 5,
    }
}

use process::limits::MAX_WINDOW;

fn half(size: usize, what: &str) -> Result<usize> {
    if size < 3 || size.is_multiple_of(2) {
        bail!("--{what} must be an odd size of at least 3, got {size}");
    }
    if size > MAX_WINDOW {
        bail!("--{what} {size} is larger than the largest useful size, {MAX_WINDOW}");
    }
    Ok(size / 2)
}

impl DenoiseOpts {
    pub fn params(&self) -> Result<DenoiseStage> {
        let d = DenoiseStage::default();
        let by_hand =
            self.window.is_some() || self.patch.is_some() || self.iterations.is_some() || self.bandwidth.is_some();
        let thesis = defaults();
        let p = DenoiseStage {
            filter: DenoiseParams {
                window: half(self.window.unwrap_or(2 * thesis.window + 1), "window")?,
                similarity: match self.filter {
                    FilterArg::NonLocal => {
                        Similarity::NonLocal { half: half(self.patch.unwrap_or_else(default_patch), "patch")? }
                    }
                    FilterArg::Bilateral => Similarity::Bilateral,
                },
                direction: match self.direction {
                    DirectionArg::Sight => Direction::LineOfSight,
                    DirectionArg::Normal => Direction::Normal,
                },
                iterations: self.iterations.unwrap_or(thesis.iterations),
                adaptive: !self.no_adaptive,
                bandwidth: self.bandwidth,
                drop_isolated: !self.keep_isolated,
                from_noise: !by_hand,
                ..d.filter
            },
            ..d
        };
        p.validate()?;
        Ok(p)
    }
}

/// `D,S`: two positive numbers.
pub fn parse_bandwidth(text: &str) -> Result<(f64, f64), String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [d, s] = parts[..] else { return Err(format!("expected D,S (two numbers), got {text:?}")) };
    let num = |x: &str| match x.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("{x:?} is not a positive number")),
    };
    Ok((num(d)?, num(s)?))
}

/// Mean-shift fusion (thesis ch. 3).
#[derive(Args, Debug, Clone)]
pub struct FuseOpts {
    /// Neighbours per kernel (the adaptive kernel size).
    #[arg(long, default_value_t = FuseParams::default().mean_shift.k)]
    pub k: usize,
}

impl FuseOpts {
    pub fn params(&self) -> Result<FuseParams> {
        let d = FuseParams::default();
        let p =
            FuseParams { mean_shift: process::fuse::mean_shift::MeanShiftParams { k: self.k, ..d.mean_shift }, ..d };
        p.validate()?;
        Ok(p)
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodArg {
    /// The global FFT method (Kazhdan 2005): one N³ grid.
    Fft,
    /// Adaptive FFT with partition of unity (thesis 5.3): local solutions, memory along one plane.
    Adfft,
}

/// Reconstruction (thesis ch. 5).
#[derive(Args, Debug, Clone)]
pub struct ReconstructOpts {
    /// Reconstruction method.
    #[arg(long, value_enum, default_value = "fft")]
    pub method: MethodArg,
    /// Grid of 2^depth points per axis (AdFFT: the equivalent global grid); default 8 for fft, 9 for
    /// adfft.
    #[arg(long)]
    pub depth: Option<u32>,
    /// AdFFT: split octree cells whose samples lie farther than this from their local surface on
    /// average (cloud units; default half a grid cell).
    #[arg(long)]
    pub error: Option<f64>,
    /// AdFFT: build the grid no finer than the cells on the surface holding this many samples each on
    /// average, below --depth where the samples carry no finer detail (as Poisson's octree adapts);
    /// 0 keeps --depth whatever the samples.
    #[arg(long, value_name = "N")]
    pub samples_per_cell: Option<f64>,
    /// Refuse reconstructions estimated to need more memory than this, GB (and any the machine
    /// cannot hold).
    #[arg(long, default_value_t = FftParams::default().memory_budget as f64 / 1e9)]
    pub memory_budget: f64,
    /// Global method: the Gaussian low-pass's standard deviation, in grid cells (default 0.5); larger
    /// smooths noise and small detail away.
    #[arg(long)]
    pub smoothing_cells: Option<f64>,
    /// The base of an object standing on the platter, never seen: `flat` cuts the mesh at the platter
    /// plane (object z = 0) and caps it flat, closed, to print and stand on (the default on a turntable
    /// scan); `open` cuts it and leaves the base open; `closed` keeps the surface the reconstruction
    /// closed it with.
    #[arg(long, value_enum)]
    pub base: Option<BaseArg>,
    /// Remove surface farther than this from every point of the cloud (in the cloud's units: mm for
    /// a scan's): the parts the reconstruction made up where no sensor looked. The mesh stays
    /// manifold; off by default.
    #[arg(long, value_name = "DISTANCE")]
    pub trim: Option<f64>,
    /// With --trim: close each hole it leaves by a fan from its centre, so the mesh stays closed.
    #[arg(long, requires = "trim")]
    pub trim_fill: bool,
}

/// The base of an object on the platter.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseArg {
    /// Cut at the platter plane and cap flat.
    Flat,
    /// Cut at the platter plane, open.
    Open,
    /// As reconstructed.
    Closed,
}

impl ReconstructOpts {
    /// The base and trim, and whether the base was asked for by name (it needs a known platter).
    pub fn finish(&self) -> Result<(FinishParams, bool)> {
        let base = match self.base {
            None => FinishParams::default().base,
            Some(BaseArg::Flat) => Base::Flat,
            Some(BaseArg::Open) => Base::Open,
            Some(BaseArg::Closed) => Base::Closed,
        };
        let p = FinishParams { base, trim: self.trim, trim_fill: self.trim_fill };
        p.validate()?;
        Ok((p, self.base.is_some()))
    }

    pub fn params(&self) -> Result<ReconstructParams> {
        // GB → bytes: a NaN, negative or infinite budget becomes 0 (refused by the library), and a
        // huge one saturates.
        if !(self.memory_budget > 0.0 && self.memory_budget.is_finite()) {
            bail!("--memory-budget {}: must be a positive number of GB", self.memory_budget);
        }
        let p = match self.method {
            MethodArg::Fft => {
                if self.error.is_some() {
                    bail!("--error steers AdFFT's octree; the global method (--method fft) has none");
                }
                if self.samples_per_cell.is_some() {
                    bail!("--samples-per-cell adapts AdFFT's grid; the global method (--method fft) keeps --depth");
                }
                let d = FftParams::default();
                ReconstructParams::Fft(FftParams {
                    depth: self.depth.unwrap_or(d.depth),
                    smoothing_cells: self.smoothing_cells.unwrap_or(d.smoothing_cells),
                    memory_budget: (self.memory_budget * 1e9) as u64,
                    ..d
                })
            }
            MethodArg::Adfft => {
                if self.smoothing_cells.is_some() {
                    bail!("--smoothing-cells is the global method's (--method fft); AdFFT smooths per octree cell");
                }
                let d = AdFftParams::default();
                ReconstructParams::Adfft(AdFftParams {
                    depth: self.depth.unwrap_or(d.depth),
                    error: self.error,
                    samples_per_cell: self.samples_per_cell.unwrap_or(d.samples_per_cell),
                    memory_budget: (self.memory_budget * 1e9) as u64,
                    ..d
                })
            }
        };
        p.validate()?;
        Ok(p)
    }
}

/// Quad remeshing (thesis ch. 6).
#[derive(Args, Debug, Clone)]
pub struct RemeshOpts {
    /// Distance between neighbouring streamlines: the quad size (default 1 % of the bounding-box
    /// diagonal).
    #[arg(long)]
    pub spacing: Option<f64>,
    /// Creases folding by more than this many degrees become feature lines the quads follow.
    #[arg(long, default_value_t = RemeshParams::default().feature_angle.unwrap_or(30.0))]
    pub features: f64,
    /// Follow no creases.
    #[arg(long)]
    pub no_features: bool,
    /// Weight of the line constraints against the Laplace equation.
    #[arg(long, default_value_t = RemeshParams::default().weight)]
    pub weight: f64,
    /// Keep the n-gons at T-junctions instead of splitting them into quads and a triangle.
    #[arg(long)]
    pub keep_polygons: bool,
}

impl RemeshOpts {
    pub fn params(&self) -> Result<RemeshParams> {
        let p = RemeshParams {
            spacing: self.spacing,
            feature_angle: (!self.no_features).then_some(self.features),
            weight: self.weight,
            split_polygons: !self.keep_polygons,
            ..Default::default()
        };
        p.validate()?;
        Ok(p)
    }
}

/// The object cylinder views are cropped to before merging and registration.
#[derive(Args, Debug, Clone)]
pub struct CropOpts {
    /// Keep points within this radius of the turntable axis, mm (default: the rig's platter radius).
    #[arg(long, allow_hyphen_values = true)]
    pub crop_radius: Option<f64>,
    /// Keep points at least this high above the platter, mm.
    #[arg(long, default_value_t = CropParams::default().min_height_mm, allow_hyphen_values = true)]
    pub crop_min_height: f64,
}

impl CropOpts {
    pub fn params(&self) -> Result<CropParams> {
        let p = CropParams { radius_mm: self.crop_radius, min_height_mm: self.crop_min_height, ..Default::default() };
        p.validate()?;
        Ok(p)
    }
}

/// Registration: how far it may move a view from its turntable pose, and whether to go on past that.
#[derive(Args, Debug, Clone)]
pub struct RegisterOpts {
    /// Largest rotation registration may give a view, degrees: beyond it the correction is refused.
    #[arg(long, default_value_t = Tolerance::default().rotation_deg, allow_hyphen_values = true)]
    pub max_correction_deg: f64,
    /// Largest movement registration may give a view, mm: beyond it the correction is refused.
    #[arg(long, default_value_t = Tolerance::default().shift_mm, allow_hyphen_values = true)]
    pub max_correction_mm: f64,
    /// Go on past results that cannot be right (frames that contradict themselves when decoding, a
    /// refused registration correction, a view that fits the others far worse than they fit each
    /// other, a mesh its cloud does not support — far from it, inside out, facing against its
    /// normals, leaving samples out, coarsened by points apart from the object —, a quad remesh that
    /// joins a thin part's sides), with a warning.
    #[arg(long)]
    pub force: bool,
}

impl RegisterOpts {
    pub fn params(&self) -> Result<RegisterParams> {
        let p = RegisterParams {
            tolerance: Tolerance { rotation_deg: self.max_correction_deg, shift_mm: self.max_correction_mm },
            ..Default::default()
        };
        p.validate()?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct All {
        #[command(flatten)]
        decode: DecodeOpts,
        #[command(flatten)]
        denoise: DenoiseOpts,
        #[command(flatten)]
        fuse: FuseOpts,
        #[command(flatten)]
        reconstruct: ReconstructOpts,
        #[command(flatten)]
        remesh: RemeshOpts,
        #[command(flatten)]
        crop: CropOpts,
        #[command(flatten)]
        register: RegisterOpts,
    }

    #[test]
    fn no_options_give_the_library_defaults() {
        let a = All::parse_from(["x"]);
        assert_eq!(a.decode.params().unwrap(), DecodeParams::default());
        assert_eq!(a.denoise.params().unwrap(), DenoiseStage::default());
        assert_eq!(a.fuse.params().unwrap(), FuseParams::default());
        assert_eq!(a.reconstruct.params().unwrap(), ReconstructParams::default());
        assert_eq!(a.remesh.params().unwrap(), RemeshParams::default());
        assert_eq!(a.crop.params().unwrap(), CropParams::default());
        assert_eq!(a.register.params().unwrap(), RegisterParams::default());
        for bad in [["--max-correction-deg", "0"], ["--max-correction-deg", "NaN"], ["--max-correction-mm", "-1"]] {
            assert!(All::parse_from(["x", bad[0], bad[1]]).register.params().is_err(), "{bad:?}");
        }
        let a = All::parse_from(["x", "--method", "adfft"]);
        assert_eq!(a.reconstruct.params().unwrap(), ReconstructParams::Adfft(AdFftParams::default()));
    }

    #[test]
    fn bandwidths_parse_or_say_what_is_wrong() {
        assert_eq!(parse_bandwidth("0.5, 0.1"), Ok((0.5, 0.1)));
        for bad in ["", "1", "1,2,3", "a,1", "0,1", "1,-2", "inf,1", "NaN,1"] {
            assert!(parse_bandwidth(bad).is_err(), "{bad:?}");
        }
        // Any text: a pair of positive finite numbers or an error, never a panic.
        let mut rng = fixtures::Lcg::new(7);
        for _ in 0..20_000 {
            let len = rng.next_u64() % 12;
            let text: String =
                (0..len).map(|_| b"0123456789.,-e +x"[(rng.next_u64() >> 33) as usize % 17] as char).collect();
            if let Ok((d, b)) = parse_bandwidth(&text) {
                assert!(d > 0.0 && b > 0.0 && d.is_finite() && b.is_finite(), "{text:?}");
            }
        }
    }
}
