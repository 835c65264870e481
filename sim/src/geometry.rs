//! Per-view geometry: one camera ray per pixel cast into the posed scene, with what every frame of the
//! view needs — the hit, its normal and albedo, where the projector lights it and whether the projector
//! and each laser emitter can see it (shadow rays). Computed once per view; every frame reuses it.

use crate::config::SimConfig;
use crate::scene::{PosedScene, Scene};
use rayon::prelude::*;
use rig::math::{Isometry3, Point2, Point3, Real, Vector3};

/// Shadow rays start this far (mm) from the surface so a surface does not shadow itself by rounding.
const SHADOW_EPS: Real = 1e-4;

/// The unit ray direction through every pixel (camera frame, row-major); NaN where the lens model has no
/// ray. Depends only on the camera: compute once per scan.
pub fn pixel_rays(cam: &rig::PinholeCamera) -> Vec<Vector3> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let px = Point2::new((i % w) as Real, (i / w) as Real);
            cam.unproject(px).map(|d| d.into_inner()).unwrap_or_else(|| Vector3::repeat(Real::NAN))
        })
        .collect()
}

/// What one view's camera sees, per pixel (row-major, `width · height` entries each).
#[derive(Debug, Clone)]
pub struct ViewGeometry {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The part hit ([`crate::scene::PartKind`] as a byte), 0 for nothing.
    pub kind: Vec<u8>,
    /// The hit in the camera frame (mm); NaN where nothing is hit.
    pub point: Vec<Point3>,
    /// Unit normal facing the camera (camera frame).
    pub normal: Vec<Vector3>,
    /// Albedo at the hit.
    pub albedo: Vec<f32>,
    /// The object's colour tint at the hit ([`crate::colour::tint`]); white elsewhere, and everywhere
    /// when the config's object has no colour.
    pub tint: Vec<[f32; 3]>,
    /// Projector pixel coordinates of the hit where the projector lights it; NaN otherwise.
    pub projector: Vec<Point2>,
    /// cos(angle between normal and the direction to the projector) where lit, else 0.
    pub projector_cos: Vec<f32>,
    /// Per laser: signed distance of the hit from the laser plane (mm).
    pub laser_distance: Vec<Vec<f32>>,
    /// Per laser: cos(angle to the emitter) where the emitter sees the hit, else 0.
    pub laser_cos: Vec<Vec<f32>>,
}

/// Casts every pixel's ray for the view `camera_from_object`.
pub fn view_geometry(scene: &Scene, cfg: &SimConfig, rays: &[Vector3], camera_from_object: &Isometry3) -> ViewGeometry {
    let cam = &cfg.rig.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let posed = scene.view(camera_from_object);
    let mut per_pixel: Vec<Pixel> = rays.par_iter().map(|dir| shade_geometry(&posed, cfg, dir)).collect();
    if scene.parts.iter().any(|p| p.albedo.has_edges()) {
        box_filter_albedo(scene, &mut per_pixel, w, h);
    }
    let object_from_camera = camera_from_object.inverse();
    let object = crate::scene::PartKind::Object as u8;
    // Each column gathered on every core (a pixel's fields copied one by one were a single thread's
    // work per view).
    // Each laser's columns: the plane's distance, and the emitter's shadow ray only near the plane
    // (only there can a point be lit). Nothing hit: NaN and 0.
    let (laser_distance, laser_cos): (Vec<Vec<f32>>, Vec<Vec<f32>>) = cfg
        .rig
        .lasers
        .iter()
        .zip(&cfg.lasers)
        .map(|(laser, emitter)| {
            let distance: Vec<Real> = per_pixel
                .par_iter()
                .map(|p| if p.part.is_some() { laser.plane.signed_distance(&p.point) } else { Real::NAN })
                .collect();
            let origin = Point3::from(emitter.origin_mm);
            let cos = per_pixel
                .par_iter()
                .zip(&distance)
                .map(|(p, d)| {
                    if p.part.is_some() && d.abs() < 4.0 * emitter.line_width_mm {
                        lit_cos(&posed, &p.point, &p.normal, &origin)
                    } else {
                        0.0
                    }
                })
                .collect();
            (distance.par_iter().map(|&d| d as f32).collect(), cos)
        })
        .unzip();
    ViewGeometry {
        width: w,
        height: h,
        kind: per_pixel.par_iter().map(|p| p.kind).collect(),
        point: per_pixel.par_iter().map(|p| p.point).collect(),
        normal: per_pixel.par_iter().map(|p| p.normal).collect(),
        albedo: per_pixel.par_iter().map(|p| p.albedo).collect(),
        tint: per_pixel
            .par_iter()
            .map(|p| {
                if cfg.scene.object_colour && p.kind == object {
                    crate::colour::tint(&(object_from_camera * p.point)).map(|t| t as f32)
                } else {
                    [1.0; 3]
                }
            })
            .collect(),
        projector: per_pixel.par_iter().map(|p| p.projector).collect(),
        projector_cos: per_pixel.par_iter().map(|p| p.projector_cos).collect(),
        laser_distance,
        laser_cos,
    }
}

/// Replaces point-sampled albedo with its mean over each pixel's footprint on parts whose albedo has
/// edges (the chessboard): the footprint is the box spanned by the surface coordinates of the
/// pixel's neighbours on the same part (half a pixel either way).
fn box_filter_albedo(scene: &Scene, px: &mut [Pixel], w: usize, h: usize) {
    let filtered: Vec<(usize, f32)> = (0..w * h)
        .into_par_iter()
        .filter_map(|i| {
            let part = px[i].part?;
            let albedo = &scene.parts[part].albedo;
            if !albedo.has_edges() {
                return None;
            }
            let (r, c) = (i / w, i % w);
            let uv = px[i].uv;
            // Surface coordinates per pixel step along a row and down a column, from whichever
            // neighbours are on the same part.
            let step = |a: Option<usize>, b: Option<usize>| -> Option<(Real, Real)> {
                let on = |k: Option<usize>| k.and_then(|k| (px[k].part == Some(part)).then_some(px[k].uv));
                match (on(a), on(b)) {
                    (Some(p), Some(q)) => Some(((q.1 - p.1) / 2.0, (q.2 - p.2) / 2.0)),
                    (Some(p), None) => Some((uv.1 - p.1, uv.2 - p.2)),
                    (None, Some(q)) => Some((q.1 - uv.1, q.2 - uv.2)),
                    (None, None) => None,
                }
            };
            let du = step((c > 0).then(|| i - 1), (c + 1 < w).then(|| i + 1))?;
            let dv = step((r > 0).then(|| i - w), (r + 1 < h).then(|| i + w))?;
            let half_u = 0.5 * (du.0.abs() + dv.0.abs());
            let half_v = 0.5 * (du.1.abs() + dv.1.abs());
            Some((i, albedo.box_filtered(uv, half_u, half_v) as f32))
        })
        .collect();
    for (i, a) in filtered {
        px[i].albedo = a;
    }
}

struct Pixel {
    part: Option<usize>,
    uv: (u32, Real, Real),
    kind: u8,
    point: Point3,
    normal: Vector3,
    albedo: f32,
    projector: Point2,
    projector_cos: f32,
}

/// Whether a light at `source` reaches `p` (normal `n`), and the cosine it arrives at.
fn lit_cos(scene: &PosedScene<'_>, p: &Point3, n: &Vector3, source: &Point3) -> f32 {
    let to = source - p;
    let dist = to.norm();
    let dir = to / dist;
    let cos = n.dot(&dir);
    if cos <= 0.0 || scene.occluded(p, &dir, SHADOW_EPS, dist - SHADOW_EPS) { 0.0 } else { cos as f32 }
}

fn shade_geometry(scene: &PosedScene<'_>, cfg: &SimConfig, dir: &Vector3) -> Pixel {
    let nan = Real::NAN;
    let mut px = Pixel {
        part: None,
        uv: (0, nan, nan),
        kind: 0,
        point: Point3::new(nan, nan, nan),
        normal: Vector3::zeros(),
        albedo: 0.0,
        projector: Point2::new(nan, nan),
        projector_cos: 0.0,
    };
    if !dir.x.is_finite() {
        return px;
    }
    let Some(hit) = scene.cast(&Point3::origin(), dir, 0.0, Real::INFINITY) else { return px };
    let p = Point3::from(dir * hit.t);
    px.kind = hit.kind as u8;
    px.part = Some(hit.part);
    px.uv = hit.uv;
    px.point = p;
    px.normal = hit.normal;
    px.albedo = hit.albedo as f32;
    if let Some(proj) = &cfg.rig.projector
        && let Some(uv) = proj.project(&p).filter(|uv| proj.lens.contains(*uv))
    {
        let cos = lit_cos(scene, &p, &hit.normal, &proj.center_in_camera());
        if cos > 0.0 {
            px.projector = uv;
            px.projector_cos = cos;
        }
    }
    px
}
