//! Each stage's parameters checked against [`crate::limits`], by name, before any work: the stage
//! function calls its params' `validate` first, and [`crate::ProcessParams::validate`] runs them all
//! before `process`'s first stage. The bounds and why they are what they are: the table in
//! [`crate::limits`].

use crate::denoise::Similarity;
use crate::limits::{
    ADFFT_DEPTHS, ADFFT_ERROR_RANGE, FFT_DEPTHS, MAX_FUSE_K, MAX_HEIGHT_MM, MAX_SAMPLES_PER_CELL, MAX_WINDOW,
    ParamError, bad, budget, check_padding, positive,
};
use crate::merge::CropParams;
use crate::pipeline::stages::{DenoiseStage, FinishParams, FuseParams, ReconstructParams};
use crate::register::register_scan::RegisterParams;
use crate::remesh::RemeshParams;
use rig::math::Real;

impl DenoiseStage {
    /// Checks the filter's sizes and passes ([`crate::limits`]'s table).
    pub fn validate(&self) -> Result<(), ParamError> {
        let f = &self.filter;
        let side = |half: usize, option| {
            if (1..=MAX_WINDOW / 2).contains(&half) {
                Ok(())
            } else {
                Err(bad(option, 2 * half + 1, format!("must be an odd size from 3 to {MAX_WINDOW}")))
            }
        };
        side(f.window, "--window")?;
        if let Similarity::NonLocal { half } = f.similarity {
            side(half, "--patch")?;
        }
        if !(1..=100).contains(&f.iterations) {
            return Err(bad("--iterations", f.iterations, "must be from 1 to 100"));
        }
        if let Some((d, s)) = f.bandwidth {
            positive("--bandwidth", d, "distance (d)")?;
            positive("--bandwidth", s, "distance (s)")?;
        }
        Ok(())
    }
}

impl FuseParams {
    /// Checks the kernel size alone ([`crate::limits`]'s table); [`FuseParams::validate_for`] also against a cloud.
    pub fn validate(&self) -> Result<(), ParamError> {
        let k = self.mean_shift.k;
        if !(6..=MAX_FUSE_K).contains(&k) {
            return Err(bad(
                "--k",
                k,
                format!("must be from 6 (a kernel fits a plane to its neighbours) to {MAX_FUSE_K}"),
            ));
        }
        Ok(())
    }

    /// [`FuseParams::validate`], and a kernel of at most half a cloud of `points` points: one spanning
    /// the cloud would fuse it into a single blob.
    pub fn validate_for(&self, points: usize) -> Result<(), ParamError> {
        self.validate()?;
        let k = self.mean_shift.k;
        if points >= k && k.saturating_mul(2) > points {
            return Err(bad(
                "--k",
                k,
                format!("is more than half the cloud's {points} points: every kernel would span the cloud"),
            ));
        }
        Ok(())
    }
}

impl CropParams {
    /// Checks the object cylinder ([`crate::limits`]'s table).
    pub fn validate(&self) -> Result<(), ParamError> {
        if let Some(r) = self.radius_mm {
            positive("--crop-radius", r, "distance in mm")?;
        }
        if !(self.min_height_mm.is_finite() && self.min_height_mm < MAX_HEIGHT_MM) {
            return Err(bad(
                "--crop-min-height",
                self.min_height_mm,
                format!("must be a height below {MAX_HEIGHT_MM} mm"),
            ));
        }
        Ok(())
    }
}

impl RegisterParams {
    /// Checks the correction tolerance ([`crate::limits`]'s table).
    pub fn validate(&self) -> Result<(), ParamError> {
        let t = &self.tolerance;
        if !(t.rotation_deg > 0.0 && t.rotation_deg <= 180.0) {
            return Err(bad("--max-correction-deg", t.rotation_deg, "must be an angle in (0, 180] degrees"));
        }
        positive("--max-correction-mm", t.shift_mm, "distance in mm")
    }
}

impl ReconstructParams {
    /// Checks depth, memory budget, smoothing and error ([`crate::limits`]'s table).
    pub fn validate(&self) -> Result<(), ParamError> {
        match self {
            ReconstructParams::Fft(p) => {
                if !FFT_DEPTHS.contains(&p.depth) {
                    return Err(bad(
                        "--depth",
                        p.depth,
                        format!(
                            "the global method takes {}–{} (2^depth grid points per axis); use --method adfft for finer",
                            FFT_DEPTHS.start(),
                            FFT_DEPTHS.end()
                        ),
                    ));
                }
                if !(p.smoothing_cells > 0.0 && p.smoothing_cells <= 64.0) {
                    return Err(bad(
                        "--smoothing-cells",
                        p.smoothing_cells,
                        "must be a positive number of cells up to 64",
                    ));
                }
                check_padding(p.padding)?;
                budget(p.memory_budget)
            }
            ReconstructParams::Adfft(p) => {
                if !ADFFT_DEPTHS.contains(&p.depth) {
                    return Err(bad(
                        "--depth",
                        p.depth,
                        format!(
                            "AdFFT takes {}–{}: its blend visits all 2^(3·depth) points of the equivalent grid \
                             where the samples carry that much detail (11: 8.6·10⁹ points, tens of minutes)",
                            ADFFT_DEPTHS.start(),
                            ADFFT_DEPTHS.end()
                        ),
                    ));
                }
                if let Some(e) = p.error {
                    positive("--error", e, "distance")?;
                }
                if !(0.0..=MAX_SAMPLES_PER_CELL).contains(&p.samples_per_cell) {
                    return Err(bad(
                        "--samples-per-cell",
                        p.samples_per_cell,
                        format!("must be a number from 0 (keep --depth) to {MAX_SAMPLES_PER_CELL}"),
                    ));
                }
                p.check_fields()?;
                budget(p.memory_budget)
            }
        }
    }

    /// [`ReconstructParams::validate`], and AdFFT's `--error` against a cloud `diagonal` across
    /// ([`ADFFT_ERROR_RANGE`]).
    pub fn validate_for(&self, diagonal: Real) -> Result<(), ParamError> {
        self.validate()?;
        if let ReconstructParams::Adfft(p) = self
            && let Some(e) = p.error
            && diagonal > 0.0
        {
            let (lo, hi) = (ADFFT_ERROR_RANGE.0 * diagonal, ADFFT_ERROR_RANGE.1 * diagonal);
            if !(lo..=hi).contains(&e) {
                return Err(bad(
                    "--error",
                    e,
                    format!("for a cloud {diagonal:.4} across it must be from {lo:.3e} to {hi:.4} (cloud units)"),
                ));
            }
        }
        Ok(())
    }
}

impl crate::ProcessParams {
    /// Every stage's parameters at once ([`crate::limits`]): `process_scan` calls it before its
    /// first stage, so an option a late stage cannot use is refused before minutes of early ones.
    pub fn validate(&self) -> Result<(), ParamError> {
        // Decoding's limits live with the decoder (decode crate); the same refusal, as a ParamError.
        if let Err(crate::DecodeError::Param(e)) = self.decode.validate() {
            return Err(e);
        }
        if let Some(d) = &self.denoise {
            d.validate()?;
        }
        self.crop.validate()?;
        self.register.validate()?;
        self.fuse.validate()?;
        self.reconstruct.validate()?;
        self.finish.validate()?;
        self.remesh.validate()
    }
}

impl FinishParams {
    /// Checks the trim distance ([`crate::limits`]'s table).
    pub fn validate(&self) -> Result<(), ParamError> {
        match self.trim {
            Some(t) => positive("--trim", t, "distance (mm)"),
            None => Ok(()),
        }
    }
}

impl crate::pipeline::stages::MeshParams {
    /// Checks the finish and the two heights the mesh is cut at (a NaN height would cut nothing or
    /// everything, in silence).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.finish.validate()?;
        for (name, z) in [("platter_z", self.platter_z), ("top_z", self.top_z)] {
            if let Some(z) = z.filter(|z| !z.is_finite()) {
                return Err(bad(name, z, "must be a finite height (the cloud's units)"));
            }
        }
        Ok(())
    }
}

impl RemeshParams {
    /// Checks spacing, feature angle and weight alone ([`crate::limits`]'s table); the spacing is held against the
    /// mesh's size by the remesher.
    pub fn validate(&self) -> Result<(), ParamError> {
        if let Some(s) = self.spacing {
            positive("--spacing", s, "distance")?;
        }
        if let Some(a) = self.feature_angle
            && !(0.0..=180.0).contains(&a)
        {
            return Err(bad("--features", a, "must be an angle from 0 to 180 degrees"));
        }
        positive("--weight", self.weight, "weight")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_and_each_limit_names_its_option() {
        assert!(DenoiseStage::default().validate().is_ok());
        assert!(FuseParams::default().validate().is_ok());
        assert!(CropParams::default().validate().is_ok());
        assert!(RegisterParams::default().validate().is_ok());
        assert!(ReconstructParams::default().validate().is_ok());
        assert!(FinishParams::default().validate().is_ok());
        assert!(RemeshParams::default().validate().is_ok());

        let mut f = FuseParams::default();
        f.mean_shift.k = 43_000;
        assert_eq!(f.validate().unwrap_err().option, "--k");
        f.mean_shift.k = 30;
        assert!(f.validate_for(43_001).is_ok());
        assert!(f.validate_for(50).unwrap_err().to_string().contains("half the cloud"));

        let crop = CropParams { min_height_mm: 1e9, ..Default::default() };
        assert_eq!(crop.validate().unwrap_err().option, "--crop-min-height");
        let crop = CropParams { radius_mm: Some(Real::NAN), ..Default::default() };
        assert_eq!(crop.validate().unwrap_err().option, "--crop-radius");

        let r = crate::reconstruct::global_fft::FftParams { depth: 30, ..Default::default() };
        let e = ReconstructParams::Fft(r).validate().unwrap_err();
        assert!(e.option == "--depth" && e.to_string().contains("30"), "{e}");
        // The library's own fields, which no option sets, by their names.
        let ad = crate::reconstruct::adfft::AdFftParams::default();
        for (bad_one, field) in [
            (crate::reconstruct::adfft::AdFftParams { padding: Real::NAN, ..ad }, "padding"),
            (crate::reconstruct::adfft::AdFftParams { padding: -0.1, ..ad }, "padding"),
            (crate::reconstruct::adfft::AdFftParams { scale: 0.5, ..ad }, "scale"),
            (crate::reconstruct::adfft::AdFftParams { coarse_weight: Real::INFINITY, ..ad }, "coarse_weight"),
            (crate::reconstruct::adfft::AdFftParams { test_fraction: 0.0, ..ad }, "test_fraction"),
            (crate::reconstruct::adfft::AdFftParams { min_component: Real::NAN, ..ad }, "min_component"),
            (crate::reconstruct::adfft::AdFftParams { coarse_depth: 30, ..ad }, "coarse_depth"),
        ] {
            assert_eq!(ReconstructParams::Adfft(bad_one).validate().unwrap_err().option, field);
        }
        let r = crate::reconstruct::global_fft::FftParams { padding: 2.0, ..Default::default() };
        assert_eq!(ReconstructParams::Fft(r).validate().unwrap_err().option, "padding");
        let finish = FinishParams { trim: Some(-1.0), ..Default::default() };
        assert_eq!(finish.validate().unwrap_err().option, "--trim");
        let remesh = RemeshParams { spacing: Some(Real::INFINITY), ..Default::default() };
        assert_eq!(remesh.validate().unwrap_err().option, "--spacing");

        // process checks the last stage's options before the first stage runs.
        assert!(crate::ProcessParams::default().validate().is_ok());
        let late = crate::ProcessParams { remesh, ..Default::default() };
        assert_eq!(late.validate().unwrap_err().option, "--spacing");
    }
}
