//! The scene: parts (object, platter, boards, occluders), each a [`Surface`] with a pose, a mount and an
//! albedo, and the per-view posing that puts them all in the camera frame.
//!
//! # Conventions
//! A part on the [`Mount::Turntable`] is posed in the object frame (origin on the platter centre, z up
//! the axis) and turns with the platter; a [`Mount::Fixed`] part is posed in the camera frame.

use crate::surface::Surface;
use rig::math::{Isometry3, Point3, Real, Vector3};

/// Where a part is attached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mount {
    /// On the platter: posed in the object frame, turns with the view angle.
    Turntable,
    /// Fixed in the camera frame.
    Fixed,
}

/// What a part is, as written into the truth maps (`part.npy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum PartKind {
    /// The scanned object.
    Object = 1,
    /// The turntable's platter.
    Platter = 2,
    /// A calibration chessboard.
    Board = 3,
    /// Anything else (test occluders, a background).
    Other = 4,
}

/// How bright a part is (diffuse reflectance in [0, 1]).
#[derive(Debug, Clone, PartialEq)]
pub enum Albedo {
    /// The same everywhere.
    Constant(Real),
    /// Per mesh vertex, interpolated with the hit's barycentrics; `faces` are the mesh's triangles.
    PerVertex {
        /// The mesh's triangles.
        faces: Vec<[u32; 3]>,
        /// One albedo per vertex.
        values: Vec<Real>,
    },
    /// A chessboard on a plane part: squares of `square_mm` with the first inner corner at local
    /// `origin`, `cols × rows` inner corners, a light margin of one square around the squares.
    Checker {
        /// Square size (mm).
        square_mm: Real,
        /// Inner corners along x.
        cols: u32,
        /// Inner corners along y.
        rows: u32,
        /// Local coordinates of the first inner corner.
        origin: (Real, Real),
        /// Albedo of dark squares.
        dark: Real,
        /// Albedo of light squares and the margin.
        light: Real,
        /// ArUco markers in the light squares (a ChArUco board), or none.
        markers: Option<Markers>,
    },
}

/// The ArUco markers of a ChArUco board, as OpenCV lays them out: one centred in each light square
/// (the square diagonally outside the first inner corner is dark), numbered row by row over the
/// light squares from the board's top-left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Markers {
    /// A marker's side (mm), its black border included.
    pub size_mm: Real,
    /// Data bits along a side (4 for a 4×4 dictionary); a one-bit black border surrounds them.
    pub bits: usize,
    /// Each marker's bits, row-major from its top-left, black = 1 (the first bit the lowest).
    pub codes: &'static [u64],
}

impl Markers {
    /// Whether the marker in light square (i, j) of a board `squares_x` squares across is black at
    /// (u, v) ∈ [0, 1)² of that square; `None` outside the marker.
    fn black(&self, square_mm: Real, squares_x: i64, (i, j): (i64, i64), (u, v): (Real, Real)) -> Option<bool> {
        let id = ((j * squares_x + i) / 2) as usize;
        let code = *self.codes.get(id)?;
        let m = self.size_mm / square_mm;
        let (mu, mv) = ((u - (1.0 - m) / 2.0) / m, (v - (1.0 - m) / 2.0) / m);
        if !(0.0..1.0).contains(&mu) || !(0.0..1.0).contains(&mv) {
            return None;
        }
        let cells = self.bits + 2;
        let (cu, cv) = ((mu * cells as Real) as usize, (mv * cells as Real) as usize);
        if cu == 0 || cv == 0 || cu == cells - 1 || cv == cells - 1 {
            return Some(true);
        }
        Some((code >> ((cv - 1) * self.bits + cu - 1)) & 1 == 1)
    }
}

/// ∫₀ˣ of the square wave that is 1 on the cells `[2k, 2k + 1)` (the even ones) and 0 between.
fn even_cells_integral(x: Real) -> Real {
    let k = (x / 2.0).floor();
    k + (x - 2.0 * k).min(1.0)
}

/// The share of `[a, b]` lying in even cells and in odd cells, both counted only within `[lo, hi]`.
fn cell_shares(a: Real, b: Real, lo: Real, hi: Real) -> (Real, Real) {
    let (ca, cb) = (a.clamp(lo, hi), b.clamp(lo, hi));
    let even = even_cells_integral(cb) - even_cells_integral(ca);
    let odd = (cb - ca) - even;
    (even / (b - a), odd / (b - a))
}

impl Albedo {
    /// Whether [`Albedo::box_filtered`] differs from the point sample (edges a pixel can straddle).
    pub fn has_edges(&self) -> bool {
        matches!(self, Albedo::Checker { .. })
    }

    /// The mean albedo over the box `uv ± (half_u, half_v)` in the surface's coordinates: what a pixel
    /// whose footprint is that box integrates. A point-sampled checker steps by a whole square's contrast
    /// within a pixel, which is aliasing no lens and sensor produce, and it biased corner positions
    /// by a tenth of a pixel; the box filter of a checker is exact and cheap (it is separable).
    pub fn box_filtered(&self, uv: (u32, Real, Real), half_u: Real, half_v: Real) -> Real {
        match self {
            Albedo::Checker { square_mm, cols, rows, origin, dark, light, markers } if half_u > 0.0 && half_v > 0.0 => {
                // Square units, shifted so square (i, j) spans [i, i + 1) × [j, j + 1), i, j from 0.
                let (x, y) = ((uv.1 - origin.0) / square_mm + 1.0, (uv.2 - origin.1) / square_mm + 1.0);
                let (hx, hy) = (half_u / square_mm, half_v / square_mm);
                let (ex, ox) = cell_shares(x - hx, x + hx, 0.0, *cols as Real + 1.0);
                let (ey, oy) = cell_shares(y - hy, y + hy, 0.0, *rows as Real + 1.0);
                // Dark where i + j is even: both even or both odd.
                let dark_share = ex * ey + ox * oy;
                let checker = light + (dark - light) * dark_share;
                let Some(m) = markers else { return checker };
                // The markers' share of the box by 4 × 4 samples; the checker's stays exact.
                let mut marker_dark = 0.0;
                for a in 0..4 {
                    for b in 0..4 {
                        let (sx, sy) = (x - hx + (a as Real + 0.5) * hx / 2.0, y - hy + (b as Real + 0.5) * hy / 2.0);
                        let (i, j) = (sx.floor() as i64, sy.floor() as i64);
                        let inside = i >= 0 && j >= 0 && i <= *cols as i64 && j <= *rows as i64;
                        if inside && (i + j) % 2 == 1 {
                            let square = (sx - i as Real, sy - j as Real);
                            if m.black(*square_mm, *cols as i64 + 1, (i, j), square) == Some(true) {
                                marker_dark += 1.0 / 16.0;
                            }
                        }
                    }
                }
                checker + (dark - light) * marker_dark
            }
            _ => self.at(uv),
        }
    }

    fn at(&self, uv: (u32, Real, Real)) -> Real {
        match self {
            Albedo::Constant(a) => *a,
            Albedo::PerVertex { faces, values } => {
                let f = faces[uv.0 as usize];
                let (u, v) = (uv.1, uv.2);
                (1.0 - u - v) * values[f[0] as usize] + u * values[f[1] as usize] + v * values[f[2] as usize]
            }
            Albedo::Checker { square_mm, cols, rows, origin, dark, light, markers } => {
                let (x, y) = ((uv.1 - origin.0) / square_mm, (uv.2 - origin.1) / square_mm);
                // Squares span x ∈ [−1, cols] and y ∈ [−1, rows] in square units; the rest is margin.
                let inside = x >= -1.0 && y >= -1.0 && x < *cols as Real && y < *rows as Real;
                let (i, j) = ((x + 1.0).floor() as i64, (y + 1.0).floor() as i64);
                let square = (x + 1.0 - i as Real, y + 1.0 - j as Real);
                let marked = || markers.and_then(|m| m.black(*square_mm, *cols as i64 + 1, (i, j), square));
                if inside && ((i + j) % 2 == 0 || marked() == Some(true)) { *dark } else { *light }
            }
        }
    }
}

/// One thing in the scene.
pub struct Part {
    /// What it is (for truth maps).
    pub kind: PartKind,
    /// Its shape in its local frame.
    pub surface: Box<dyn Surface>,
    /// Local frame → mount frame.
    pub pose: Isometry3,
    /// What it is attached to.
    pub mount: Mount,
    /// Its reflectance.
    pub albedo: Albedo,
}

/// All parts of a scene.
#[derive(Default)]
pub struct Scene {
    /// The parts.
    pub parts: Vec<Part>,
}

/// A hit in the camera frame of one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHit {
    /// Distance along the ray.
    pub t: Real,
    /// Unit geometric normal in the camera frame, turned to face the ray's origin.
    pub normal: Vector3,
    /// Albedo at the hit.
    pub albedo: Real,
    /// Which part.
    pub kind: PartKind,
    /// Its index in the scene's parts.
    pub part: usize,
    /// Where on the part's surface (the surface's own coordinates).
    pub uv: (u32, Real, Real),
}

/// The scene for one view: every part's pose in that view's camera frame.
pub struct PosedScene<'a> {
    scene: &'a Scene,
    poses: Vec<Isometry3>,
}

impl Scene {
    /// Poses every part for the view whose object frame maps to the camera by `camera_from_object`.
    pub fn view(&self, camera_from_object: &Isometry3) -> PosedScene<'_> {
        let poses = self
            .parts
            .iter()
            .map(|p| match p.mount {
                Mount::Turntable => camera_from_object * p.pose,
                Mount::Fixed => p.pose,
            })
            .collect();
        PosedScene { scene: self, poses }
    }
}

impl PosedScene<'_> {
    /// The nearest hit with `t ∈ (t_min, t_max)` of a camera-frame ray.
    pub fn cast(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<SceneHit> {
        let mut best: Option<(usize, crate::surface::LocalHit)> = None;
        let mut limit = t_max;
        for (i, (part, pose)) in self.scene.parts.iter().zip(&self.poses).enumerate() {
            if let Some(h) = part.surface.cast(pose, origin, dir, t_min, limit) {
                limit = h.t;
                best = Some((i, h));
            }
        }
        let (i, h) = best?;
        let part = &self.scene.parts[i];
        let normal = if h.normal.dot(dir) > 0.0 { -h.normal } else { h.normal };
        Some(SceneHit { t: h.t, normal, albedo: part.albedo.at(h.uv), kind: part.kind, part: i, uv: h.uv })
    }

    /// Whether a camera-frame ray hits anything with `t ∈ (t_min, t_max)` (shadow rays).
    pub fn occluded(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> bool {
        self.scene.parts.iter().zip(&self.poses).any(|(part, pose)| {
            let inv = pose.inverse();
            part.surface.occluded_local(&(inv * origin), &(inv * dir), t_min, t_max)
        })
    }
}

impl Scene {
    /// The turntable scene: the platter (a disc at the object frame's z = 0) and the object on it.
    pub fn on_turntable(cfg: &crate::SimConfig, object: &rig::TriMesh, albedo: Albedo) -> Scene {
        let mut parts = Vec::new();
        if cfg.scene.platter_radius_mm > 0.0 {
            parts.push(Part {
                kind: PartKind::Platter,
                surface: Box::new(crate::surface::Disc { radius: cfg.scene.platter_radius_mm }),
                pose: Isometry3::identity(),
                mount: Mount::Turntable,
                albedo: Albedo::Constant(cfg.scene.platter_albedo),
            });
        }
        parts.push(Part {
            kind: PartKind::Object,
            surface: Box::new(crate::surface::MeshSurface::new(object)),
            pose: Isometry3::identity(),
            mount: Mount::Turntable,
            albedo,
        });
        parts.extend(enclosure(cfg));
        Scene { parts }
    }
}

/// The scanner's enclosure, where the config has one: a back wall facing the camera beyond the
/// turntable, and a floor below the platter. Both are fixed (they do not turn with the platter) and
/// both catch the lasers' and the projector's light, as a real scanner's walls and table do.
fn enclosure(cfg: &crate::SimConfig) -> Vec<Part> {
    let mut parts = Vec::new();
    let Some(axis) = cfg.rig.turntable else { return parts };
    let sc = &cfg.scene;
    // The object frame at θ = 0: z up the axis, y from the camera toward the axis.
    let camera_from_object = axis.camera_from_object(0.0);
    let albedo = Albedo::Constant(sc.wall_albedo);
    if sc.wall_distance_mm > 0.0 {
        // Local z (the rectangle's normal) turned to face the camera (object −y).
        let facing = rig::math::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
        let at = Isometry3::from_parts(
            rig::math::Translation3::new(0.0, sc.wall_distance_mm, 0.0),
            rig::math::UnitQuaternion::from_rotation_matrix(&facing),
        );
        parts.push(Part {
            kind: PartKind::Other,
            surface: Box::new(crate::surface::Rectangle { half_width: 1000.0, half_height: 1000.0 }),
            pose: camera_from_object * at,
            mount: Mount::Fixed,
            albedo: albedo.clone(),
        });
    }
    if sc.floor {
        parts.push(Part {
            kind: PartKind::Other,
            surface: Box::new(crate::surface::Disc { radius: 2000.0 }),
            pose: camera_from_object * Isometry3::translation(0.0, 0.0, -10.0),
            mount: Mount::Fixed,
            albedo,
        });
    }
    parts
}

impl Scene {
    /// Whether the scene holds parts other than the object and platter (an enclosure).
    pub fn has_enclosure(&self) -> bool {
        self.parts.iter().any(|p| p.kind == PartKind::Other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn board() -> Albedo {
        Albedo::Checker { square_mm: 10.0, cols: 3, rows: 2, origin: (0.0, 0.0), dark: 0.1, light: 0.9, markers: None }
    }

    #[test]
    fn a_box_filtered_checker_averages_what_the_box_covers() {
        let b = board();
        // Inside one square the filter is the point sample: square (0, 0) (x, y ∈ [−10, 0)) is dark.
        assert!((b.box_filtered((0, -5.0, -5.0), 2.0, 2.0) - 0.1).abs() < 1e-12);
        assert!((b.box_filtered((0, 5.0, -5.0), 2.0, 2.0) - 0.9).abs() < 1e-12);
        // Centred on an inner corner: two dark and two light quarters.
        assert!((b.box_filtered((0, 0.0, 0.0), 2.0, 2.0) - 0.5).abs() < 1e-12);
        // Straddling a vertical edge by a quarter: a quarter dark.
        assert!((b.box_filtered((0, 1.0, -5.0), 2.0, 2.0) - (0.9 - 0.8 * 0.25)).abs() < 1e-12);
        // Half on the last (dark) square, half on the light margin beyond it (x ≥ 30).
        assert!((b.box_filtered((0, 30.0, 5.0), 2.0, 2.0) - 0.5).abs() < 1e-12);
    }
}
