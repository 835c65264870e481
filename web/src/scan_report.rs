//! `processed/report.html`: what a `process` run made, to look at — summary and warnings, every
//! view's depth and coverage, denoising and registration across views, the fused cloud and the mesh
//! in 3D, the mesh's error against the truth for simulated scans, and links to every output.

use crate::PageError;
use crate::escape::esc;
use crate::page::{Page, facts, file_links, warnings};
use crate::picture::{object_range, png_url};
use crate::plot::{bars, colour_bar, histogram, num, series};
use crate::scene::{Scene, count};
use process::ProcessReport;
use process::merge::views::turntable_pose;
use process::mesh_distance::MeshDistance;
use process::pipeline::layout::{self, Layout};
use process::preview::turbo;
use rayon::prelude::*;
use rig::math::Real;
use rig::{Method, Rig};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The report page's file name in the processed folder.
pub const REPORT_HTML: &str = "report.html";
/// Thumbnail width of the depth images (px).
const THUMB: u32 = 200;

/// What the page showed, for the caller to print.
#[derive(Debug, Clone, Default)]
pub struct ScanPage {
    /// Where it was written.
    pub path: PathBuf,
    /// Its size in bytes.
    pub bytes: usize,
    /// The mesh's error against the truth, for simulated scans: RMS of its vertices' distances above
    /// the bottom 3 mm, in % of the truth's diagonal.
    pub truth_rms_percent: Option<Real>,
}

/// Builds `processed/report.html` for `scan` from what `processed` holds (its `report.json` and
/// outputs), and writes it atomically.
pub fn write(scan: &Path, processed: &Path) -> Result<ScanPage, PageError> {
    write_prepared(scan, processed, None)
}

/// [`write()`] with the 3D scene made beforehand by [`prepare_scene`] (`None`: made here).
pub fn write_prepared(scan: &Path, processed: &Path, prepared: Option<PreparedScene>) -> Result<ScanPage, PageError> {
    let html = build_prepared(scan, processed, prepared)?;
    let path = processed.join(REPORT_HTML);
    rig::write_atomic(&path, html.0.as_bytes())?;
    Ok(ScanPage { path, bytes: html.0.len(), truth_rms_percent: html.1 })
}

/// The page's heaviest part, made from the processed folder's cloud and mesh (and the scan's truth)
/// alone: the 3D scene, the object's extent and the accuracy section. `process` makes it while the
/// remesher runs — the cloud and the mesh are final once the mesh is written — and the page is then
/// put together from it and `report.json` once the run ends.
pub struct PreparedScene {
    scene: Scene,
    extent: Option<Extent>,
    accuracy: Option<(String, Real)>,
    unseen: Option<Unseen>,
}

/// The mesh's surface no measured point supports: what the reconstruction made up.
#[derive(Debug, Clone, Copy)]
struct Unseen {
    /// Share of the mesh's area whose corners all lie farther than `limit_mm` from every point.
    share: Real,
    /// The distance (0.5 % of the cloud's diagonal).
    limit_mm: Real,
}

/// A pass's colour in the viewer (pass 1 first): distinct hues that read on a light background.
const PASS_COLOURS: [[u8; 3]; 6] =
    [[230, 120, 30], [40, 110, 220], [40, 170, 80], [150, 70, 200], [210, 50, 60], [30, 170, 170]];

/// Makes the [`PreparedScene`] of `processed` (see there).
pub fn prepare_scene(scan: &Path, processed: &Path) -> Result<PreparedScene, PageError> {
    let truth_path = scan.join("truth/object.ply");
    // Each view's pass, where the scan has several.
    let passes: Option<Vec<u32>> =
        rig::Manifest::read(scan).ok().filter(|m| m.passes() > 1).map(|m| m.views.iter().map(|v| v.pass).collect());
    let truth = truth_path.is_file().then_some(truth_path.as_path());
    let (mut scene, extent, accuracy, unseen) = scene(&Layout::new(processed), truth)?;
    if let Some(passes) = passes {
        passes_layer(&mut scene, &Layout::new(processed), &passes)?;
    }
    Ok(PreparedScene { scene, extent, accuracy, unseen })
}

/// The page's HTML and the truth RMS (% of the diagonal) where there is a truth.
pub fn build(scan: &Path, processed: &Path) -> Result<(String, Option<Real>), PageError> {
    build_prepared(scan, processed, None)
}

fn build_prepared(
    scan: &Path,
    processed: &Path,
    prepared: Option<PreparedScene>,
) -> Result<(String, Option<Real>), PageError> {
    let report_path = processed.join(layout::REPORT);
    if !report_path.is_file() {
        return Err(PageError::Missing(format!(
            "{}: no report.json — run `scanrig process {}` first",
            processed.display(),
            scan.display()
        )));
    }
    let text = std::fs::read_to_string(&report_path).map_err(|e| rig::Error::io(&report_path, e))?;
    let report: ProcessReport = serde_json::from_str(&text)
        .map_err(|e| PageError::Missing(format!("{}: not a scanrig process report ({e})", report_path.display())))?;
    let rig = Rig::read(&scan.join("rig.toml")).ok();
    let lay = Layout::new(processed);
    let mut page = Page::new(
        &format!("Scan report: {}", scan.file_name().map_or("scan".into(), |n| n.to_string_lossy().into_owned())),
        &format!(
            "{} — made by scanrig {} from <code>{}</code>",
            match report.method {
                Some(Method::Laser) => "line-laser scan",
                Some(Method::StructuredLight) => "structured-light scan",
                _ => "scan",
            },
            esc(&report.scanrig_version),
            esc(&report.scan)
        ),
    );
    let manifest = rig::Manifest::read(scan).ok();
    let mut files: Vec<String> = report.outputs.iter().filter(|f| lay.path(f).exists()).cloned().collect();
    files.push(layout::REPORT.into());
    files.sort();
    files.dedup();
    // The results a person came for first (the mesh to print or view), then every other file.
    files.sort_by_key(|f| HEADLINE.iter().position(|h| h == f).unwrap_or(HEADLINE.len()));
    let headline: Vec<&String> = files.iter().filter(|f| HEADLINE.contains(&f.as_str())).collect();
    let mut summary_html = String::new();
    if !headline.is_empty() {
        let links: Vec<String> =
            headline.iter().map(|f| format!("<a href=\"{}\">{}</a>", esc(&crate::escape::href(f)), esc(f))).collect();
        summary_html.push_str(&format!("<p class=\"downloads\">Results: {}</p>", links.join(" · ")));
    }
    let PreparedScene { scene, extent, accuracy, unseen } = match prepared {
        Some(p) => p,
        None => prepare_scene(scan, processed)?,
    };
    summary_html.push_str(&summary(&report, rig.as_ref(), manifest.as_ref()));
    summary_html.push_str(&passes_and_unseen(&report, unseen));
    page.section("summary", "Summary", summary_html);
    page.section("views", "Views", views(&report, rig.as_ref(), extent, &lay)?);
    if scene.layer_count() > 0 {
        page.viewer_section("view3d", "3D view", scene);
    }
    let mut truth_rms = None;
    if let Some((html, rms)) = accuracy {
        page.section("accuracy", "Accuracy against the truth", html);
        truth_rms = Some(rms);
    }
    page.section("files", "Files", file_links(&files));
    Ok((page.render(), truth_rms))
}

/// The outputs a person downloads, in the order shown at the top of the page.
const HEADLINE: [&str; 6] =
    [layout::MESH_STL, layout::MESH_GLB, layout::MESH, layout::QUADS, layout::QUADS_PLY, layout::FUSED];

/// What each view captured, from the first view's frames: "white, black, 20 Gray-code columns, …".
fn capture_program(m: &rig::Manifest) -> String {
    use rig::Pattern as P;
    let Some(v) = m.views.first() else { return "no views".into() };
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for f in &v.frames {
        let k = match f.pattern {
            P::White => "white".to_string(),
            P::Black => "black".to_string(),
            P::Gray { axis, bits, .. } => format!("Gray code {axis:?} ({bits} bits, with inverses)").to_lowercase(),
            P::Phase { axis, steps, period_px, .. } => {
                format!("phase shift {axis:?} ({steps} steps, period {} px)", num(period_px)).to_lowercase()
            }
            P::LaserOff => "laser off".to_string(),
            P::Laser { index } => format!("laser {index}"),
            P::Texture => "texture (colour)".to_string(),
        };
        match kinds.iter_mut().find(|(n, _)| *n == k) {
            Some((_, c)) => *c += 1,
            None => kinds.push((k, 1)),
        }
    }
    let parts: Vec<String> = kinds.iter().map(|(k, c)| if *c > 1 { format!("{c} × {k}") } else { k.clone() }).collect();
    format!(
        "{} frames a view: {}; from {}{}",
        v.frames.len(),
        esc(&parts.join(", ")),
        esc(&m.source),
        m.seed.map_or(String::new(), |s| format!(" (seed {s})"))
    )
}

fn summary(r: &ProcessReport, rig: Option<&Rig>, manifest: Option<&rig::Manifest>) -> String {
    let mut rows: Vec<(&str, String)> = vec![("scan folder", format!("<code>{}</code>", esc(&r.scan)))];
    if let Some(m) = manifest {
        rows.push(("capture program", capture_program(m)));
    }
    if let Some(rig) = rig {
        let mut parts = vec![format!("camera {}×{}", rig.camera.width, rig.camera.height)];
        if let Some(p) = &rig.projector {
            parts.push(format!("projector {}×{}", p.lens.width, p.lens.height));
        }
        if !rig.lasers.is_empty() {
            parts.push(format!("{} laser(s)", rig.lasers.len()));
        }
        parts.push(if rig.turntable.is_some() { "turntable calibrated".into() } else { "no turntable axis".into() });
        rows.push(("rig", format!("{} — {}", esc(&rig.name), parts.join(", "))));
    }
    let angles: Vec<Real> = r.views.iter().map(|v| v.angle_deg).collect();
    let span = match angles.is_empty() {
        true => String::new(),
        false => format!(
            ", turntable from {}° to {}°",
            num(angles.iter().copied().fold(Real::INFINITY, Real::min)),
            num(angles.iter().copied().fold(Real::NEG_INFINITY, Real::max))
        ),
    };
    let incomplete = match r.incomplete_views.is_empty() {
        true => String::new(),
        false => format!(" ({} incomplete left out: {:?})", r.incomplete_views.len(), r.incomplete_views),
    };
    rows.push(("views", format!("{} complete{incomplete}{span}", r.views.len())));
    rows.push(("total time", format!("{:.1} s", r.total_seconds)));
    let mut h = facts(&rows);
    // Points and seconds per stage, in pipeline order.
    let view_points: usize = r.views.iter().map(|v| v.points).sum();
    // Wall time: views run side by side, so their own seconds add up to more than was waited.
    let view_seconds = r.views_wall_seconds();
    let mut stages: Vec<(&str, String, Real, &str)> = vec![("views", count(view_points), view_seconds, "points")];
    let status = |reused: bool| if reused { "reused" } else { "ran" };
    if let Some(s) = &r.merge {
        stages.push(("merge", count(s.report.points), s.seconds, status(s.reused)));
    }
    if let Some(s) = &r.register {
        stages.push(("register", count(s.report.points), s.seconds, status(s.reused)));
    }
    if let Some(s) = &r.fuse {
        stages.push(("fuse", count(s.report.mean_shift.points_out), s.seconds, status(s.reused)));
    }
    if let Some(s) = &r.close {
        stages.push(("close", "caps".into(), s.seconds, status(s.reused)));
    }
    if let Some(s) = &r.reconstruct {
        stages.push((
            "reconstruct",
            format!("{} triangles", count(s.report.reconstruct.triangles())),
            s.seconds,
            status(s.reused),
        ));
    }
    if let Some(s) = &r.remesh {
        stages.push(("remesh", format!("{} faces", count(s.report.quality.faces)), s.seconds, status(s.reused)));
    }
    h.push_str("<h3>Stages</h3><table><tr><th>stage</th><th class=\"num\">out</th><th class=\"num\">seconds</th><th></th></tr>");
    for (name, out, secs, st) in &stages {
        let _ = write!(
            h,
            "<tr><td>{name}</td><td class=\"num\">{out}</td><td class=\"num\">{secs:.2}</td><td class=\"note\">{st}</td></tr>"
        );
    }
    h.push_str("</table><h3>Warnings</h3>");
    h.push_str(&warnings(&r.warnings));
    if !r.skipped.is_empty() {
        h.push_str("<h3>Skipped</h3>");
        h.push_str(&crate::page::list("skipped", &r.skipped));
    }
    h
}

/// Where the object lies in the object frame: the fused (else registered or merged) cloud's
/// largest distance from the turntable axis and its height range, which is what the pipeline kept
/// after cropping, whatever crop options it ran with.
#[derive(Debug, Clone, Copy)]
pub struct Extent {
    radius: Real,
    z: (Real, Real),
}

impl Extent {
    fn of(points: &[rig::math::Point3]) -> Option<Extent> {
        let mut e = Extent { radius: 0.0, z: (Real::INFINITY, Real::NEG_INFINITY) };
        for p in points.iter().filter(|p| p.coords.iter().all(|c| c.is_finite())) {
            e.radius = e.radius.max(p.x.hypot(p.y));
            e.z = (e.z.0.min(p.z), e.z.1.max(p.z));
        }
        (e.z.0 <= e.z.1).then_some(e)
    }
}

/// The object's cells in a view: inside the object's extent once placed by the turntable (with a
/// margin of 2 % of its size), or without an extent above the platter and inside its radius; every
/// valid cell where the rig has no turntable.
fn on_object(grid: &rig::RangeGrid, rig: Option<&Rig>, extent: Option<Extent>, angle_deg: Real) -> Vec<bool> {
    let Some(axis) = rig.and_then(|r| r.turntable.as_ref()) else {
        return grid.valid.clone();
    };
    let platter = rig.and_then(|r| r.platter_radius_mm);
    in_extent(grid, axis, platter, extent, angle_deg)
}

fn in_extent(
    grid: &rig::RangeGrid,
    axis: &rig::TurntableAxis,
    platter_radius_mm: Option<Real>,
    extent: Option<Extent>,
    angle_deg: Real,
) -> Vec<bool> {
    let pose = turntable_pose(Some(axis), angle_deg);
    let (radius, lo, hi) = match extent {
        Some(e) => {
            let m = 0.02 * e.radius.max(e.z.1 - e.z.0);
            (e.radius + m, e.z.0 - m, e.z.1 + m)
        }
        None => (platter_radius_mm.unwrap_or(Real::INFINITY), 1.0, Real::INFINITY),
    };
    grid.points
        .iter()
        .zip(&grid.valid)
        .map(|(p, &ok)| {
            let q = pose * p;
            ok && q.z >= lo && q.z <= hi && q.x * q.x + q.y * q.y <= radius * radius
        })
        .collect()
}

/// A view's depth at thumbnail size (every f-th cell, f the shrink factor): z where the cell is on
/// the object, and what each cell is, so the full grids need not stay in memory while the shared
/// colour range is found.
struct DepthThumb {
    view: usize,
    name: String,
    width: usize,
    height: usize,
    /// Per cell: 0 no data, 1 background, 2 object.
    class: Vec<u8>,
    z: Vec<Real>,
    /// The object's depth range in this view (2nd–98th percentile), if any cell is on it.
    range: Option<(Real, Real)>,
}

fn depth_thumb(view: usize, name: String, grid: &rig::RangeGrid, mask: &[bool]) -> DepthThumb {
    let range = object_range(grid, mask);
    let f = (grid.width as u32).div_ceil(THUMB).max(1) as usize;
    let (width, height) = (grid.width / f, grid.height / f);
    let mut class = Vec::with_capacity(width * height);
    let mut z = Vec::with_capacity(width * height);
    for r in 0..height {
        for c in 0..width {
            let i = r * f * grid.width + c * f;
            class.push(if !grid.valid[i] {
                0
            } else if mask[i] {
                2
            } else {
                1
            });
            z.push(grid.points[i].z);
        }
    }
    DepthThumb { view, name, width, height, class, z, range }
}

impl DepthThumb {
    /// The thumbnail coloured over `lo..hi` (object), grey by depth (background), black (no data).
    fn image(&self, lo: Real, hi: Real) -> rig::image::Image8 {
        let (zmin, zmax) = self
            .z
            .iter()
            .zip(&self.class)
            .filter(|(_, c)| **c > 0)
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(a, b), (z, _)| (a.min(*z), b.max(*z)));
        let data = self
            .z
            .iter()
            .zip(&self.class)
            .flat_map(|(&z, &c)| match c {
                0 => [0, 0, 0],
                2 if hi > lo => turbo((z - lo) / (hi - lo)),
                _ => {
                    let t = if zmax > zmin { (zmax - z) / (zmax - zmin) } else { 0.5 };
                    [(70.0 + 110.0 * t) as u8; 3]
                }
            })
            .collect();
        rig::image::Image8 { width: self.width as u32, height: self.height as u32, channels: 3, data }
    }
}

fn views(r: &ProcessReport, rig: Option<&Rig>, extent: Option<Extent>, lay: &Layout) -> Result<String, PageError> {
    let labels: Vec<String> = r.views.iter().map(|v| v.view.to_string()).collect();
    let mut h = String::from("<div class=\"plots\">");
    let points: Vec<Real> = r.views.iter().map(|v| v.points as Real).collect();
    let coverage: Vec<Real> = r
        .views
        .iter()
        .map(|v| match (&v.decode, v.lasers.is_empty()) {
            (Some(d), _) => 100.0 * d.report.decoded as Real / d.report.lit.max(1) as Real,
            (None, false) => {
                let (found, searched) = v.lasers.iter().fold((0, 0), |(f, s), l| {
                    let lr = &l.report.line;
                    (f + lr.found, s + lr.found + lr.faint + lr.saturated + lr.doubled + lr.too_wide + lr.outside)
                });
                100.0 * found as Real / searched.max(1) as Real
            }
            _ => Real::NAN,
        })
        .collect();
    let what = if r.method == Some(Method::Laser) {
        "Line coverage: rows of the working volume where each laser's line was found, % (all lasers)"
    } else {
        "Decode coverage: lit pixels decoded, %"
    };
    h.push_str(&series(what, &labels, &[("coverage", coverage)], "%", "view"));
    h.push_str(&bars(
        "Points each view hands on (after denoising where it ran)",
        &labels,
        &points,
        &[],
        "points",
        "view",
    ));
    let displacement: Vec<Real> = r
        .views
        .iter()
        .map(|v| {
            v.denoise
                .as_ref()
                .map_or(Real::NAN, |d| d.report.rms_displacement.iter().map(|x| x * x).sum::<Real>().sqrt())
        })
        .collect();
    if displacement.iter().any(|d| d.is_finite()) {
        h.push_str(&series(
            "Denoising: RMS displacement of each view's points, all passes (mm; thesis eqs. 4.3/4.6)",
            &labels,
            &[("displacement", displacement)],
            "mm",
            "view",
        ));
    }
    let poses_path = lay.path(layout::POSES);
    if let Some(reg) = r.register.as_ref()
        && let Ok(text) = std::fs::read_to_string(&poses_path)
        && let Ok(serde_json::Value::Array(poses)) = serde_json::from_str::<serde_json::Value>(&text)
    {
        let f = |p: &serde_json::Value, k: &str| p[k].as_f64().unwrap_or(Real::NAN);
        let names: Vec<String> = poses
            .iter()
            .map(|p| match p["laser"].as_u64() {
                Some(l) => format!("{}·{l}", p["view"]),
                None => p["view"].to_string(),
            })
            .collect();
        let rot: Vec<Real> = poses.iter().map(|p| f(p, "rotation_change_deg")).collect();
        let shift: Vec<Real> = poses.iter().map(|p| f(p, "shift_mm")).collect();
        let refused: Vec<String> = reg.report.refused.iter().map(|x| x.to_string()).collect();
        let caption = match refused.is_empty() {
            true => "Registration: how far ICP moved each view from its turntable pose (thesis ch. 2.2)".to_string(),
            false => format!(
                "Registration: how far ICP moved each view from its turntable pose (thesis ch. 2.2). Refused, \
                 beyond the tolerance (those views kept their turntable pose; the figures are the refused \
                 corrections): {}",
                refused.join("; ")
            ),
        };
        h.push_str(&series(
            &caption,
            &names,
            &[("rotation (°)", rot), ("centroid shift (mm)", shift)],
            "° / mm",
            "view",
        ));
    }
    h.push_str("</div>");
    // Depth images, one colour scale over the object's depth in every view. Each grid is read,
    // reduced to its thumbnail and dropped: 36 full grids at 1280 × 1024 would hold gigabytes.
    // (Two at a time on two cores: each grid is parsed by one thread.)
    let thumbs: Vec<DepthThumb> = r
        .views
        .par_iter()
        .map(|v| {
            // The grids this run handed on: denoised where denoising ran, else the raw ones.
            let name = if v.denoise.is_some() { Layout::denoised(v.view) } else { Layout::grid(v.view) };
            if !lay.path(&name).is_file() {
                return Ok(None);
            }
            let grid = rig::ply::read_range_grid(&lay.path(&name))?;
            let mask = on_object(&grid, rig, extent, v.angle_deg);
            Ok(Some(depth_thumb(v.view, name, &grid, &mask)))
        })
        .collect::<Vec<Result<Option<DepthThumb>, PageError>>>()
        .into_iter()
        // The first unreadable grid in view order is the one named, whichever thread met it first.
        .collect::<Result<Vec<Option<DepthThumb>>, PageError>>()?
        .into_iter()
        .flatten()
        .collect();
    let ranges: Vec<(Real, Real)> = thumbs.iter().filter_map(|t| t.range).collect();
    let lo = ranges.iter().map(|r| r.0).fold(Real::INFINITY, Real::min);
    let hi = ranges.iter().map(|r| r.1).fold(Real::NEG_INFINITY, Real::max);
    h.push_str("<h3>Depth</h3>");
    if thumbs.is_empty() {
        h.push_str(if r.method == Some(Method::Laser) {
            "<p class=\"note\">A laser scan's views are single lines, not depth images: see the line coverage above.</p>"
        } else {
            "<p class=\"note\">No range grids yet: the run stopped before triangulation.</p>"
        });
    } else if lo > hi {
        h.push_str(
            "<p class=\"note\">No cell of any view lies on the object (an empty platter, or the turntable axis is \
             off): depth in grey.</p>",
        );
    } else {
        let _ = write!(
            h,
            "<p class=\"note\">Distance from the camera, coloured over the object's depth in all views \
             ({}–{} mm; near blue, far red); the platter and anything outside the object's extent in grey, no data \
             black.</p>{}",
            num(lo),
            num(hi),
            colour_bar(lo, hi, "depth from the camera (mm), near → far")
        );
    }
    h.push_str("<div class=\"thumbs\">");
    for t in &thumbs {
        let _ = write!(
            h,
            "<div class=\"thumb\"><a href=\"{}\"><img alt=\"view {v} depth\" src=\"{}\"></a>view {v}</div>",
            esc(&crate::escape::href(&t.name)),
            png_url(&t.image(lo, hi)),
            v = t.view
        );
    }
    h.push_str("</div>");
    Ok(h)
}

/// The viewer's scene: the fused cloud (else the registered or merged one), the mesh, and its
/// error against the truth where there is one; with the accuracy section's HTML and RMS.
#[allow(clippy::type_complexity)]
fn scene(
    lay: &Layout,
    truth: Option<&Path>,
) -> Result<(Scene, Option<Extent>, Option<(String, Real)>, Option<Unseen>), PageError> {
    let mut scene = Scene::new();
    let mut extent = None;
    let mut points = Vec::new();
    if let Some(name) = [layout::FUSED, layout::REGISTERED, layout::MERGED].into_iter().find(|n| lay.path(n).is_file())
    {
        let cloud = rig::ply::read_cloud(&lay.path(name))?;
        extent = Extent::of(&cloud.positions);
        let label = format!("{} cloud", name.trim_end_matches(".ply"));
        // The cloud, the mesh and its error colouring show one at a time: each hides the others.
        scene.add_points(&label, &cloud.positions, cloud.colors.as_deref(), true, Some("surface"));
        points = cloud.positions;
    }
    let mut accuracy = None;
    let mut unseen = None;
    if lay.path(layout::MESH).is_file() {
        let poly = rig::ply::read_mesh(&lay.path(layout::MESH))?;
        let mesh = poly.triangulate();
        let first = scene.layer_count() == 0;
        let (geometry, members) = scene.add_mesh("mesh", &mesh, poly.colors.as_deref(), first, Some("surface"));
        unseen = unseen_layer(&mut scene, &mesh, &points, geometry, &members);
        if let Some(truth) = truth {
            let t = rig::ply::read_mesh(truth)?.triangulate();
            let diag = t.bounding_box().map_or(1.0, |b| b.diagonal());
            let index = MeshDistance::new(&t, 2.0);
            // Unbounded: a vertex far off (a bad registration) must count with its whole distance.
            let err: Vec<Real> = mesh.vertices.par_iter().map(|v| index.distance(v)).collect();
            let mut above: Vec<Real> =
                mesh.vertices.iter().zip(&err).filter(|(v, _)| v.z > 3.0).map(|(_, e)| *e).collect();
            above.sort_by(Real::total_cmp);
            let pct = |q: Real| {
                above.get(((above.len().max(1) - 1) as Real * q).round() as usize).copied().unwrap_or(Real::NAN)
            };
            let rms = (above.iter().map(|e| e * e).sum::<Real>() / above.len().max(1) as Real).sqrt();
            let top = pct(0.99).max(1e-6);
            let colours: Vec<[u8; 3]> = members
                .iter()
                .map(|m| turbo(m.iter().map(|&i| err[i as usize]).sum::<Real>() / m.len().max(1) as Real / top))
                .collect();
            let legend = colour_bar(0.0, top, "distance to the true surface (mm)");
            scene.add_mesh_colouring("error against the truth", geometry, &colours, legend, false, Some("surface"));
            let mut h = facts(&[
                ("truth", "<code>truth/object.ply</code> in the scan folder (the simulator's object)".into()),
                ("diagonal", format!("{} mm", num(diag))),
                (
                    "above the bottom 3 mm",
                    format!(
                        "median {} mm, p95 {} mm, RMS {} mm = <b>{:.4} %</b> of the diagonal ({} vertices)",
                        num(pct(0.5)),
                        num(pct(0.95)),
                        num(rms),
                        100.0 * rms / diag,
                        count(above.len())
                    ),
                ),
                ("p95", format!("{:.4} % of the diagonal", 100.0 * pct(0.95) / diag)),
            ]);
            h.push_str(&histogram(
                "Mesh vertices' distance to the true surface (above the bottom 3 mm), coloured as in the 3D view's error layer",
                &above,
                0.0,
                top,
                40,
                "mm",
            ));
            accuracy = Some((h, 100.0 * rms / diag));
        }
    }
    Ok((scene, extent, accuracy, unseen))
}

/// The mesh coloured by whether a measured point lies near it (grey) or none does (red): the surface
/// the scan never saw, which the reconstruction closed by itself. Returns its share of the area.
fn unseen_layer(
    scene: &mut Scene,
    mesh: &rig::TriMesh,
    points: &[rig::math::Point3],
    geometry: crate::scene::MeshGeometry,
    members: &[Vec<u32>],
) -> Option<Unseen> {
    let diag = rig::Aabb::of(points)?.diagonal();
    let limit = 0.005 * diag;
    let tree = process::kd_tree::PointTree::new(points);
    let far: Vec<bool> = mesh.vertices.par_iter().map(|v| tree.nearest(v).1 > limit * limit).collect();
    let (mut total, mut off) = (0.0, 0.0);
    for f in &mesh.faces {
        let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
        let area = (b - a).cross(&(c - a)).norm() / 2.0;
        total += area;
        if f.iter().all(|&i| far[i as usize]) {
            off += area;
        }
    }
    let colours: Vec<[u8; 3]> = members
        .iter()
        .map(|m| if m.iter().all(|&i| far[i as usize]) { [215, 45, 45] } else { [185, 185, 185] })
        .collect();
    let legend = format!(
        "<span style=\"color:rgb(215,45,45)\">■</span> no measured point within {} mm (made up by the reconstruction) \
         · <span style=\"color:rgb(185,185,185)\">■</span> measured",
        num(limit)
    );
    scene.add_mesh_colouring("surface not seen", geometry, &colours, legend, false, Some("surface"));
    Some(Unseen { share: off / total.max(1e-300), limit_mm: limit })
}

/// The registered cloud coloured by pass (a scan of several passes).
fn passes_layer(scene: &mut Scene, lay: &Layout, passes: &[u32]) -> Result<(), PageError> {
    let path = lay.path(layout::REGISTERED);
    if !path.is_file() {
        return Ok(());
    }
    let cloud = rig::ply::read_cloud(&path)?;
    let Some(ids) = cloud.view_id.as_ref() else { return Ok(()) };
    let colour = |v: u32| {
        let p = passes.get(v as usize).copied().unwrap_or(1).clamp(1, PASS_COLOURS.len() as u32);
        PASS_COLOURS[p as usize - 1]
    };
    let colours: Vec<[u8; 3]> = ids.iter().map(|&v| colour(v)).collect();
    scene.add_points("passes (each its colour)", &cloud.positions, Some(&colours), false, Some("surface"));
    Ok(())
}

/// The summary's passes table (how each pass was placed, how sure) and the surface no pass saw.
fn passes_and_unseen(r: &ProcessReport, unseen: Option<Unseen>) -> String {
    let mut h = String::new();
    if let Some(passes) = r.register.as_ref().and_then(|s| s.report.passes.as_ref()) {
        h.push_str(
            "<h3>Passes</h3><table><tr><th>pass</th><th class=\"num\">views</th><th class=\"num\">points</th>\
             <th>placed</th><th class=\"num\">overlap</th><th class=\"num\">matches agreeing</th>\
             <th class=\"num\">rival</th><th class=\"num\">ICP refinement</th></tr>",
        );
        for (k, a) in passes.iter().enumerate() {
            let [r, g, b] = PASS_COLOURS[(a.pass.clamp(1, 6) - 1) as usize];
            // The first pass processed is the frame the others are placed in.
            let placed = match (k, a.aligned) {
                (0, _) => "reference".to_string(),
                (_, true) => "aligned by its shape".to_string(),
                (_, false) => format!("<b>not trusted</b>: {}", esc(&a.why)),
            };
            let _ = write!(
                h,
                "<tr><td><span style=\"color:rgb({r},{g},{b})\">■</span> {}</td><td class=\"num\">{}</td>\
                 <td class=\"num\">{}</td><td>{placed}</td><td class=\"num\">{:.0} %</td>\
                 <td class=\"num\">{} of {}</td><td class=\"num\">{:.2}</td><td class=\"num\">{:.3}° / {:.3} mm</td></tr>",
                a.pass,
                a.views,
                count(a.points),
                100.0 * a.overlap,
                a.inliers,
                a.matches,
                a.rival_share,
                a.refine_deg,
                a.refine_mm
            );
        }
        h.push_str("</table>");
    }
    if let Some(u) = unseen {
        let _ = write!(
            h,
            "<p>Surface not seen: <b>{:.1} %</b> of the mesh's area lies farther than {} mm (0.5 % of the cloud's \
             diagonal) from every measured point — closed by the reconstruction, not measured (the 3D view's \
             “surface not seen” layer shows where; another pass with the object turned over measures it).</p>",
            100.0 * u.share,
            num(u.limit_mm)
        );
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::page::markup;

    #[test]
    fn a_run_stopped_before_triangulation_gets_a_page_without_a_viewer_or_broken_numbers() {
        let d = tempfile::tempdir().unwrap();
        let processed = d.path().join("processed");
        std::fs::create_dir_all(&processed).unwrap();
        let report = ProcessReport { method: Some(Method::StructuredLight), ..Default::default() };
        std::fs::write(processed.join(layout::REPORT), serde_json::to_vec(&report).unwrap()).unwrap();
        let (html, truth) = build(d.path(), &processed).unwrap();
        assert!(truth.is_none());
        assert!(!html.contains("id=\"viewer-canvas\""), "nothing to draw, no viewer");
        assert!(html.contains("No range grids yet"));
        let text = markup(&html);
        for bad in ["NaN", "inf"] {
            assert!(!text.contains(bad), "{bad} in the page:\n{text}");
        }
        // A folder that was never processed is named, with what to run.
        let e = build(d.path(), d.path()).unwrap_err().to_string();
        assert!(e.contains("report.json") && e.contains("scanrig process"), "{e}");
    }

    #[test]
    fn the_object_mask_follows_the_cloud_s_extent_not_the_platter() {
        // A camera 300 mm in front of an axis along its −y (the turntable's up), points on the axis
        // at the object's height and a wall point 200 mm behind.
        let axis = rig::TurntableAxis {
            point: rig::math::Point3::new(0.0, 0.0, 300.0),
            direction: rig::math::UnitVector3::new_normalize(rig::math::Vector3::new(0.0, -1.0, 0.0)),
        };
        let mut grid = rig::RangeGrid::empty(3, 1, rig::Sensor::Center(rig::math::Point3::origin()));
        grid.points = vec![
            rig::math::Point3::new(0.0, -20.0, 300.0), // on the axis, 20 mm up: object
            rig::math::Point3::new(0.0, -20.0, 500.0), // the wall
            rig::math::Point3::new(0.0, 5.0, 300.0),   // below the platter
        ];
        grid.valid = vec![true; 3];
        let extent = Extent::of(&[rig::math::Point3::new(30.0, 0.0, 2.0), rig::math::Point3::new(0.0, 0.0, 40.0)]);
        assert_eq!(in_extent(&grid, &axis, Some(100.0), extent, 0.0), vec![true, false, false]);
        // Without a cloud yet, the platter's cylinder: the wall is 200 mm off the axis.
        assert_eq!(in_extent(&grid, &axis, Some(100.0), None, 0.0), vec![true, false, false]);
    }
}
