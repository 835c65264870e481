//! Calibration captures: a chessboard at given poses, or standing on the turntable and swept through
//! angles, photographed lit, under the full structured-light program, and with each laser on it — the
//! captures `calib` estimates a rig from, with the true board poses and corner pixels as truth.
//!
//! # Conventions
//! The board frame has its origin on the first inner corner, x along a row of corners, y down the
//! columns, z out of the printed face; inner corner (i, j) is at (i·square, j·square, 0), listed
//! row-major (i fastest), as OpenCV's `findChessboardCorners` orders them.

use crate::Error;
use crate::config::SimConfig;
use crate::geometry::{pixel_rays, view_geometry};
use crate::scan::{ScanOptions, ScanReport, fresh_manifest, lights_for, program, write_view};
use crate::scene::{Albedo, Markers, Mount, Part, PartKind, Scene};
use crate::surface::Rectangle;
use rig::Method;
use rig::math::{Isometry3, Point3, Real, Translation3, UnitQuaternion, Vector3};
use rig::npy::{NpyArray, NpyData};
use rig::scan_folder::Manifest;
use std::path::Path;
use std::time::Instant;

/// A printed chessboard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners down a column.
    pub rows: u32,
    /// Square size (mm).
    pub square_mm: Real,
    /// ArUco markers in its light squares: a ChArUco board (`cols + 1` × `rows + 1` squares).
    pub markers: Option<Markers>,
}

impl Board {
    /// A plain chessboard of `cols × rows` inner corners.
    pub fn chessboard(cols: u32, rows: u32, square_mm: Real) -> Board {
        Board { cols, rows, square_mm, markers: None }
    }

    /// A ChArUco board of `squares_x × squares_y` squares with `marker_mm` markers from a
    /// dictionary of `bits × bits` markers (`codes` as [`Markers::codes`]).
    pub fn charuco(
        squares_x: u32,
        squares_y: u32,
        square_mm: Real,
        marker_mm: Real,
        bits: usize,
        codes: &'static [u64],
    ) -> Board {
        Board {
            cols: squares_x - 1,
            rows: squares_y - 1,
            square_mm,
            markers: Some(Markers { size_mm: marker_mm, bits, codes }),
        }
    }

    /// The inner corners in the board frame, row-major.
    pub fn corners(&self) -> Vec<Point3> {
        (0..self.rows)
            .flat_map(|j| {
                (0..self.cols).map(move |i| Point3::new(i as Real * self.square_mm, j as Real * self.square_mm, 0.0))
            })
            .collect()
    }

    /// The board's centre in its own frame.
    fn centre(&self) -> Vector3 {
        Vector3::new((self.cols as Real - 1.0) / 2.0, (self.rows as Real - 1.0) / 2.0, 0.0) * self.square_mm
    }

    /// The board as a scene part at `pose` (board frame → mount frame): the squares plus a light margin
    /// of one square.
    pub fn part(&self, pose: Isometry3, mount: Mount) -> Part {
        let s = self.square_mm;
        let c = self.centre();
        Part {
            kind: PartKind::Board,
            surface: Box::new(Rectangle {
                half_width: (self.cols as Real + 3.0) * s / 2.0,
                half_height: (self.rows as Real + 3.0) * s / 2.0,
            }),
            pose: pose * Translation3::from(c),
            mount,
            albedo: Albedo::Checker {
                square_mm: s,
                cols: self.cols,
                rows: self.rows,
                origin: (-c.x, -c.y),
                dark: 0.05,
                light: 0.85,
                markers: self.markers,
            },
        }
    }
}

/// Where the board is in each view: first held up at fixed poses, then standing on the platter and
/// swept through angles (either list may be empty).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoardPoses {
    /// Fixed poses in the camera frame (camera_from_board), one view each, away from the turntable.
    pub held: Vec<Isometry3>,
    /// Turntable angles (degrees) of the board standing on the platter, facing the camera at 0°.
    pub sweep: Vec<Real>,
    /// A card held over part of the board in the held views, by view (missing or `None`: none).
    pub covers: Vec<Option<Cover>>,
}

/// A plain grey card held just in front of a board, over part of it — a hand or a clamp — so the
/// corners under it are not seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cover {
    /// Its corner nearest the board's origin, in squares of the board frame (corner (i, j) is at
    /// (i, j)).
    pub from: (Real, Real),
    /// The opposite corner, in squares.
    pub to: (Real, Real),
}

impl Cover {
    /// The card as a scene part over `board` at `pose` (camera from board), 3 mm in front of it.
    fn part(&self, board: &Board, pose: Isometry3) -> Part {
        let s = board.square_mm;
        let (x0, x1) = (self.from.0.min(self.to.0) * s, self.from.0.max(self.to.0) * s);
        let (y0, y1) = (self.from.1.min(self.to.1) * s, self.from.1.max(self.to.1) * s);
        // The board frame's +z (x × y, with y down the columns) points away from a camera that reads
        // the board the right way round: the card is at −z.
        let centre = Vector3::new((x0 + x1) / 2.0, (y0 + y1) / 2.0, -3.0);
        Part {
            kind: PartKind::Other,
            surface: Box::new(Rectangle { half_width: (x1 - x0) / 2.0, half_height: (y1 - y0) / 2.0 }),
            pose: pose * Translation3::from(centre),
            mount: Mount::Fixed,
            albedo: Albedo::Constant(0.4),
        }
    }
}

impl BoardPoses {
    /// Only held poses.
    pub fn held(poses: Vec<Isometry3>) -> Self {
        BoardPoses { held: poses, sweep: Vec::new(), covers: Vec::new() }
    }

    /// Only a sweep on the turntable.
    pub fn sweep(angles_deg: Vec<Real>) -> Self {
        BoardPoses { held: Vec::new(), sweep: angles_deg, covers: Vec::new() }
    }
}

/// A spread of board poses for camera calibration: the board centred `distance_mm` ahead, tilted up to
/// ±35° about both image axes and turned in its plane, so Zhang's method sees well-conditioned views.
pub fn default_fixed_poses(board: &Board, distance_mm: Real, count: usize) -> Vec<Isometry3> {
    let c = board.centre();
    (0..count)
        .map(|k| {
            let a = k as Real / count.max(1) as Real * std::f64::consts::TAU;
            let tilt_x = 35f64.to_radians() * a.sin();
            let tilt_y = 35f64.to_radians() * (a * 2.0 + 0.7).cos();
            let roll = 12f64.to_radians() * (a * 3.0).sin();
            let rot = UnitQuaternion::from_euler_angles(tilt_x, tilt_y, roll);
            // Drift the centre around the image so corners cover the lens's edges too.
            let centre = Point3::new(0.18 * distance_mm * a.cos(), 0.12 * distance_mm * (a * 2.0).sin(), distance_mm);
            Isometry3::from_parts(Translation3::from(centre.coords - rot * c), rot)
        })
        .collect()
}

/// How far in front of the turntable axis a standing board's face is (mm). A face through the axis
/// would meet every laser plane (which contain the axis) in the same line at every angle, and a line
/// does not determine a plane; real stands hold the board off the axis too.
pub const STAND_OFFSET_MM: Real = 40.0;

/// The board standing on the platter in the object frame: its bottom margin on z = 0, centred across
/// the axis and [`STAND_OFFSET_MM`] in front of it, facing the camera (−y of the object frame) at 0°.
pub fn standing_on_platter(board: &Board) -> Isometry3 {
    let s = board.square_mm;
    let c = board.centre();
    // Rows run down the standing board: board x is object x, board y is object −z, and so board z =
    // x × y is object +y, away from the camera (the simulator prints both faces).
    let rot = UnitQuaternion::from_basis_unchecked(&[Vector3::x(), -Vector3::z(), Vector3::y()]);
    let height = (board.rows as Real + 1.0) * s; // the bottom margin's lower edge touches the platter
    Isometry3::from_parts(Translation3::new(-c.x, -STAND_OFFSET_MM, height), rot)
}

/// The scene of a board capture: held at `held` (camera_from_board) in front of the camera, or, for
/// `None`, standing on the platter ([`standing_on_platter`]) and turning with it.
pub fn board_scene(cfg: &SimConfig, board: &Board, held: Option<Isometry3>) -> Scene {
    let mut scene = Scene::default();
    // A board at fixed poses is held up in front of the camera, away from the turntable: with
    // the platter in the scene it hid the lower corners of most default poses.
    if cfg.scene.platter_radius_mm > 0.0 && cfg.rig.turntable.is_some() && held.is_none() {
        scene.parts.push(Part {
            kind: PartKind::Platter,
            surface: Box::new(crate::surface::Disc { radius: cfg.scene.platter_radius_mm }),
            pose: Isometry3::identity(),
            mount: Mount::Turntable,
            albedo: Albedo::Constant(cfg.scene.platter_albedo),
        });
    }
    match held {
        Some(p) => scene.parts.push(board.part(p, Mount::Fixed)),
        None => scene.parts.push(board.part(standing_on_platter(board), Mount::Turntable)),
    }
    scene
}

/// Simulates calibration captures of `board` into `out`: one view per pose (fixed poses without the
/// platter, which a hand-held board is away from), frames as the rig's
/// program (structured light if it has a projector, then laser-off and one frame per laser), and in
/// `truth/view_NNN/` besides the usual maps `board_pose.npy` (4×4 camera_from_board) and `corners.npy`
/// (N×2 distorted pixel positions of the inner corners, row-major; NaN behind the camera).
pub fn simulate_board(
    cfg: &SimConfig,
    board: &Board,
    poses: &BoardPoses,
    opts: ScanOptions,
    out: &Path,
    mut progress: impl FnMut(usize, usize),
) -> Result<ScanReport, Error> {
    simulate_board_dyn(cfg, board, poses, opts, out, &mut progress)
}

/// [`simulate_board`]'s body, compiled once here rather than into every caller's crate.
fn simulate_board_dyn(
    cfg: &SimConfig,
    board: &Board,
    poses: &BoardPoses,
    opts: ScanOptions,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ScanReport, Error> {
    let start = Instant::now();
    let patterns = program(cfg, Method::Board)?;
    let (angles, fixed): (Vec<Real>, Vec<Option<Isometry3>>) =
        poses.held.iter().map(|&q| (0.0, Some(q))).chain(poses.sweep.iter().map(|&a| (a, None))).unzip();
    if angles.is_empty() {
        return Err(Error::Setup("no board poses given".into()));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::File(rig::Error::io(out, e)))?;
    crate::scan::scan_rig(cfg).write(&out.join("rig.toml"))?;
    let mut manifest: Manifest = fresh_manifest(cfg, Method::Board, opts.seed, &angles, &patterns);
    for (view, f) in manifest.views.iter_mut().zip(&fixed) {
        view.held = f.is_some();
    }
    manifest.write(out)?;
    let lights = lights_for(cfg, &patterns);
    let rays = pixel_rays(&cfg.rig.camera);
    let mut report = ScanReport { views: angles.len(), ..Default::default() };
    for (v, (&angle, fixed)) in angles.iter().zip(&fixed).enumerate() {
        let t0 = Instant::now();
        let mut scene = board_scene(cfg, board, *fixed);
        let view_pose = crate::scan::view_pose(cfg, angle);
        let camera_from_board = match fixed {
            Some(p) => {
                if let Some(Some(cover)) = poses.covers.get(v) {
                    scene.parts.push(cover.part(board, *p));
                }
                *p
            }
            None => view_pose * standing_on_platter(board),
        };
        let g = view_geometry(&scene, cfg, &rays, &view_pose);
        let t1 = Instant::now();
        write_view(out, cfg, &g, &lights, &manifest.views[v].frames.clone(), opts, v, &view_pose)?;
        if opts.truth {
            let dir = out.join(rig::scan_folder::ScanLayout::truth(v));
            let m = camera_from_board.to_homogeneous();
            let pose = NpyArray { shape: vec![4, 4], data: NpyData::F64(m.transpose().iter().copied().collect()) };
            rig::npy::write(&dir.join("board_pose.npy"), &pose)?;
            let px: Vec<f64> = board
                .corners()
                .iter()
                .flat_map(|c| match cfg.rig.camera.project(&(camera_from_board * c)) {
                    Some(p) => [p.x, p.y],
                    None => [f64::NAN; 2],
                })
                .collect();
            let n = px.len() / 2;
            rig::npy::write(&dir.join("corners.npy"), &NpyArray { shape: vec![n, 2], data: NpyData::F64(px) })?;
        }
        manifest.complete_view(out, v)?;
        report.add_view(t0, t1, patterns.len());
        progress(v + 1, angles.len());
    }
    manifest.write(out)?;
    Ok(report.finish(start))
}
