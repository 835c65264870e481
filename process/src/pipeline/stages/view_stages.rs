//! The stages of one view: decoding and triangulation (structured light), line extraction
//! (laser), denoising, and the colours a view takes from its texture frame.

use super::StageError;
use crate::denoise::{DenoiseParams, DenoiseReport};
use crate::pipeline::records::{Fingerprint, StageCode, rig_part};
use crate::triangulate::grid_normals::estimate_normals;
use crate::triangulate::laser_line::{
    Background, LaserParams, RowWindows, extract_line, lit_side_windows, triangulate_line,
};
use rig::RangeGrid;
use rig::SparseView;
use rig::image::{Image8, ImageTransform};
use rig::math::Real;
use serde::Serialize;
use serde_json::json;

/// Decodes one view's structured-light frames into a projector map (see [`decode::decode_view`]).
pub fn decode(
    frames: &[(rig::Pattern, &rig::image::Image8)],
    projector_px: (u32, u32),
    params: &decode::structured_light::DecodeParams,
) -> Result<(crate::ProjectorMap, decode::structured_light::DecodeReport), StageError> {
    Ok(decode::structured_light::decode_view(frames, projector_px.0, projector_px.1, params)?)
}

/// Triangulates a decoded view into a range grid in the camera frame (mm) with grid normals: the
/// general ray–surface form of eq. 2.3 through `triangulator` (built once per rig), then normals
/// from grid neighbours no farther apart than `normal_max_jump_mm`.
pub fn triangulate(
    map: &crate::ProjectorMap,
    triangulator: &crate::triangulate::Triangulator,
    params: &crate::triangulate::TriangulateParams,
    normal_max_jump_mm: Real,
) -> Result<(RangeGrid, crate::pipeline::GridReport), StageError> {
    let camera = triangulator.camera_size();
    if (map.width, map.height) != (camera.0 as usize, camera.1 as usize) {
        return Err(StageError::MapSize { map: (map.width, map.height), camera });
    }
    let mut grid = triangulator.triangulate(map, params);
    let normals = estimate_normals(&mut grid, normal_max_jump_mm);
    let report = crate::pipeline::GridReport { points: grid.valid_count(), normals };
    Ok((grid, report))
}

/// Denoising a range grid: the filter (ch. 4), then grid normals estimated again where the grid had
/// them (the filter moves points, so the old normals no longer fit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DenoiseStage {
    /// The filter.
    pub filter: DenoiseParams,
    /// Grid neighbours farther apart than this (the grid's units) are not used for its normals.
    pub normal_max_jump: Real,
}

impl Default for DenoiseStage {
    fn default() -> Self {
        DenoiseStage { filter: DenoiseParams::default(), normal_max_jump: 2.0 }
    }
}

/// Denoises frame `current` of `frames` using the frames within `temporal` of it (eq. 4.6; 0 filters
/// the frame alone, eq. 4.3), and estimates its normals again where it had them.
pub fn denoise(
    frames: &[RangeGrid],
    current: usize,
    temporal: usize,
    params: &DenoiseStage,
) -> Result<(RangeGrid, DenoiseReport), StageError> {
    params.validate()?;
    let (mut clean, report) = crate::denoise::denoise_sequence(frames, current, temporal, &params.filter)?;
    if clean.normals.is_some() {
        estimate_normals(&mut clean, params.normal_max_jump);
    }
    Ok((clean, report))
}

/// The 8-bit colour of a colour (or grey) image at a sub-pixel position, bilinear; edges clamped.
pub fn colour_at(image: &rig::image::Image8, px: [f32; 2]) -> [u8; 3] {
    let (w, h) = (image.width as usize, image.height as usize);
    let x = (px[0] as Real).clamp(0.0, (w - 1) as Real);
    let y = (px[1] as Real).clamp(0.0, (h - 1) as Real);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as Real, y - y0 as Real);
    let nc = image.channels as usize;
    let at = |xx: usize, yy: usize, c: usize| image.data[(yy * w + xx) * nc + c.min(nc - 1)] as Real;
    std::array::from_fn(|c| {
        let top = at(x0, y0, c) * (1.0 - fx) + at(x1, y0, c) * fx;
        let bottom = at(x0, y1, c) * (1.0 - fx) + at(x1, y1, c) * fx;
        (top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8
    })
}

/// A range grid's colours from the view's texture frame (same size as the grid: camera pixels).
pub fn grid_colours(grid: &RangeGrid, texture: &rig::image::Image8) -> Option<Vec<[u8; 3]>> {
    if (texture.width as usize, texture.height as usize) != (grid.width, grid.height) {
        return None;
    }
    let w = grid.width;
    Some(
        (0..grid.points.len())
            .map(|i| if grid.valid[i] { colour_at(texture, [(i % w) as f32, (i / w) as f32]) } else { [0; 3] })
            .collect(),
    )
}

/// The decode stage's code version: raise it when decoding writes other bytes for the same frames (2:
/// every pattern swapped with its inverse is a fatal frame issue, so a map kept from before is judged
/// again).
pub const DECODE: StageCode = StageCode { stage: "decode", version: 2 };
/// The triangulate stage's code version.
pub const TRIANGULATE: StageCode = StageCode { stage: "triangulate", version: 1 };
/// The denoise stage's code version (2: sizes from each grid's measured noise by default; 3: hand
/// bandwidths that would move nothing are refused, where a grid kept from before was passed on).
pub const DENOISE: StageCode = StageCode { stage: "denoise", version: 3 };
/// The laser line stage's code version (extraction and triangulation of one laser's frame; 2: a texture
/// frame of another size than the camera's is no longer sampled, clamped, for colours).
pub const LASER_LINE: StageCode = StageCode { stage: "laser_line", version: 2 };

/// What a decoded map is made from besides its frames' content (added by the runner): the decoding
/// parameters, the projector's size and how the frames are turned on reading.
pub fn decode_fingerprint(
    params: &decode::structured_light::DecodeParams,
    projector_px: (u32, u32),
    image: &ImageTransform,
) -> Fingerprint {
    Fingerprint::new(
        DECODE,
        json!({"decode": params, "projector_px": [projector_px.0, projector_px.1], "rig.image": image}),
    )
}

/// What a view's range grid is made from besides its map and texture frame: the triangulation and
/// normal parameters, and the camera and projector exactly as the rig describes them.
pub fn triangulate_fingerprint(
    params: &crate::triangulate::TriangulateParams,
    normal_max_jump_mm: Real,
    camera: &rig::PinholeCamera,
    projector: &rig::Projector,
) -> Fingerprint {
    Fingerprint::new(
        TRIANGULATE,
        json!({
            "triangulate": params,
            "normal_max_jump_mm": normal_max_jump_mm,
            "rig.camera": rig_part(camera),
            "rig.projector": rig_part(projector),
        }),
    )
}

/// What a denoised grid is made from besides its grid: the filter's parameters.
pub fn denoise_fingerprint(params: &DenoiseStage) -> Fingerprint {
    Fingerprint::new(DENOISE, json!({ "denoise": params }))
}

/// What a laser's line in one view is made from besides its frames and texture: the extraction
/// parameters, the camera, how frames are turned, the laser and the working volume searched.
pub fn laser_line_fingerprint(params: &LaserParams, rig: &rig::Rig, laser: &rig::Laser) -> Fingerprint {
    Fingerprint::new(
        LASER_LINE,
        json!({
            "laser": params,
            "rig.camera": rig_part(&rig.camera),
            "rig.image": rig.image,
            "rig.laser": rig_part(laser),
            "rig.working_volume": rig_part(&rig.working_volume()),
        }),
    )
}

/// Where laser `laser`'s line is searched: the image rows of the working volume, on the camera's side
/// of the axis ([`lit_side_windows`]), and what computing them warns of. A rig that does not know its
/// volume is searched whole, with a warning; a plane that meets the volume nowhere in view is a rig
/// of another scanner (or a mistyped plane) and fails unless `force`.
pub fn laser_windows(
    rig: &rig::Rig,
    laser: &rig::Laser,
    params: &LaserParams,
    force: bool,
) -> Result<(Option<RowWindows>, Vec<String>), StageError> {
    let Some(volume) = rig.working_volume() else {
        let warning = format!(
            "laser `{}`: the rig has no working volume ([turntable] with platter_radius_mm), so its line is searched \
             in the whole image and a reflection on the scanner's walls can be taken for the object",
            laser.name
        );
        return Ok((None, vec![warning]));
    };
    // The camera's side of the axis only: the far half of the plane holds no line of the object.
    let found = lit_side_windows(&rig.camera, &laser.plane, &volume, params.volume_margin_mm, params.past_axis_mm);
    if found.rows_open() > 0 {
        return Ok((Some(found), Vec::new()));
    }
    let what = format!(
        "laser `{}`'s plane meets the working volume (platter radius {} mm, height {} mm above the turntable axis \
         point) nowhere in the camera's view",
        laser.name, volume.radius_mm, volume.height_mm
    );
    if force {
        return Ok((None, vec![format!("{what}: its line is searched in the whole image (--force)")]));
    }
    let hint = "check the laser's normal and distance_mm and the [turntable] in rig.toml (a rig of another scanner?); \
                --force searches the whole image"
        .into();
    Err(StageError::Implausible { what, hint })
}

/// A view's texture frame where it is the camera's size; another size cannot be matched to the
/// camera's pixels, so it is not used (the view has no colour) and the second value says why.
pub fn fitting_texture<'a>(
    texture: Option<&'a Image8>,
    camera: &rig::PinholeCamera,
) -> (Option<&'a Image8>, Option<String>) {
    match texture {
        Some(t) if (t.width, t.height) != (camera.width, camera.height) => {
            let why = format!(
                "its texture frame is {}x{}, not the camera's {}x{}: the view has no colour",
                t.width, t.height, camera.width, camera.height
            );
            (None, Some(why))
        }
        other => (other, None),
    }
}

/// One laser's frames of one view, as the camera sees them (turned as the rig's `[image]` says).
#[derive(Debug, Clone, Copy)]
pub struct LaserFrames<'a> {
    /// The frame with the laser on.
    pub on: &'a Image8,
    /// The same view with every laser off, where the capture took one (FabScanPi and other scanners
    /// record none: the background is then estimated from the laser frame itself).
    pub off: Option<&'a Image8>,
    /// The view's texture frame, whose colours the points take.
    pub texture: Option<&'a Image8>,
}

/// Laser line extraction and triangulation: the line's centre in each row of `frames.on` within
/// `windows` (`None`: the whole image), in the laser's colour, each camera ray through one against
/// the laser's plane (eq. 2.3's general form); the points in the camera frame, coloured from the
/// texture frame where there is one. `laser` is the laser's index in the rig and the laser.
pub fn laser_line(
    frames: &LaserFrames,
    camera: &rig::PinholeCamera,
    laser: (usize, &rig::Laser),
    windows: Option<&RowWindows>,
    params: &LaserParams,
) -> Result<(SparseView, crate::pipeline::LaserViewReport), StageError> {
    let size = (camera.width, camera.height);
    let frame_sizes = [Some(frames.on), frames.off].into_iter().flatten().map(|i| (i.width, i.height));
    if let Some((w, h)) = frame_sizes.into_iter().find(|&s| s != size) {
        return Err(StageError::MapSize { map: (w as usize, h as usize), camera: size });
    }
    let background = frames.off.map_or(Background::Estimated, Background::Frame);
    let (peaks, line) = extract_line(frames.on, background, laser.1.colour, windows, params, |_, _| true);
    let mut points = triangulate_line(&peaks, camera, &laser.1.plane);
    if let Some(t) = frames.texture {
        points.colors = Some(points.pixels.iter().map(|&px| colour_at(t, px)).collect());
    }
    let report = crate::pipeline::LaserViewReport { laser: laser.0, line, points: points.len() };
    Ok((points, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_texture_of_another_size_is_not_used_and_says_why() {
        let camera = rig::PinholeCamera::ideal(64, 48, 60.0);
        let (fits, other) = (Image8::gray(64, 48, vec![0; 64 * 48]), Image8::gray(32, 24, vec![0; 32 * 24]));
        let (t, why) = fitting_texture(Some(&fits), &camera);
        assert!(t.is_some() && why.is_none());
        let (t, why) = fitting_texture(Some(&other), &camera);
        assert!(t.is_none() && why.unwrap().contains("32x24, not the camera's 64x48"));
        assert_eq!(fitting_texture(None, &camera), (None, None));
    }
}
