//! `NAME.report.html` beside a calibration's `NAME.report.json`: every image with the corners found,
//! the per-view reprojection error, the residual vectors over the image, the laser planes' and the
//! turntable axis' fits, and the board poses around the camera in 3D.

use crate::PageError;
use crate::escape::esc;
use crate::page::{Page, facts, file_links, relative_link, warnings};
use crate::picture::{jpeg_url, mark, thumbnail, to_rgb};
use crate::plot::{bars, num, vectors};
use crate::scene::Scene;
use calib::CalibReport;
use calib::workflow::report::{BoardPose, BoardView, CameraReport};
use rig::image::Image8;
use rig::math::{Isometry3, Point3, Real, Translation3, UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::Path;

/// Thumbnails drawn at most (a page of hundreds of images would be slow and say nothing more).
const MAX_THUMBS: usize = 60;
const THUMB: u32 = 240;

fn pose(rotation_vector: [Real; 3], translation_mm: [Real; 3]) -> Option<Isometry3> {
    let (r, t) = (Vector3::from(rotation_vector), Vector3::from(translation_mm));
    (r.iter().chain(t.iter()).all(|x| x.is_finite()))
        .then(|| Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_scaled_axis(r)))
}

fn board_pose(p: &BoardPose) -> Option<Isometry3> {
    pose(p.rotation_vector, p.translation_mm)
}

/// The page for a calibration `report` (the JSON `calibrate` writes), written to `path` atomically.
/// `read_image` reads a board image as the calibration saw it (turned the same way); images it
/// cannot read are listed without a thumbnail.
pub fn write(
    path: &Path,
    report: &CalibReport,
    read_image: &dyn Fn(&Path) -> Option<Image8>,
) -> Result<usize, PageError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let html = build(
        report,
        path.file_name().map_or("calibration".into(), |n| n.to_string_lossy().into_owned()),
        dir,
        read_image,
    );
    rig::write_atomic(path, html.as_bytes())?;
    Ok(html.len())
}

/// The page's HTML; `dir` is the folder it will be written to (links are relative to it).
pub fn build(report: &CalibReport, name: String, dir: &Path, read_image: &dyn Fn(&Path) -> Option<Image8>) -> String {
    let mut page = Page::new(
        &format!("Calibration report: {}", name.trim_end_matches(".report.html")),
        "written by scanrig calibrate",
    );
    let (board, found) = (&report.board, &report.board_found);
    let mut rows: Vec<(&str, String)> = vec![(
        "board",
        format!(
            "{}×{} inner corners, {} mm squares; found in {} of {} images{}",
            board.cols,
            board.rows,
            num(board.square_mm),
            found.found,
            found.of,
            if found.partial > 0 { format!(" ({} of them in part)", found.partial) } else { String::new() }
        ),
    )];
    if let Some(cam) = &report.camera {
        rows.push((
            "camera",
            format!(
                "{}×{} px, fx {} fy {} cx {} cy {} px; distortion (k1 k2 p1 p2 k3) {}; <b>RMS {:.3} px</b>",
                cam.lens.width,
                cam.lens.height,
                num(cam.lens.fx),
                num(cam.lens.fy),
                num(cam.lens.cx),
                num(cam.lens.cy),
                cam.lens.distortion.iter().map(|d| format!("{d:.4}")).collect::<Vec<_>>().join(" "),
                cam.rms_px
            ),
        ));
        let mut model = format!("estimated {}", cam.model.estimated.join(" "));
        for held in &cam.model.held {
            model.push_str(&format!("; {}", esc(held)));
        }
        rows.push(("lens model", model));
        if !cam.coverage.advice.is_empty() {
            rows.push((
                "next captures",
                format!("corners in {:.0} % of the image; {}", 100.0 * cam.coverage.covered, esc(&cam.coverage.advice)),
            ));
        }
    }
    if let Some(proj) = &report.projector {
        rows.push((
            "projector",
            format!(
                "{}×{} px, fx {} fy {}; RMS {:.3} px alone, stereo {:.3} px ({} views)",
                proj.lens.width,
                proj.lens.height,
                num(proj.lens.fx),
                num(proj.lens.fy),
                proj.projector_rms_px,
                proj.stereo_rms_px,
                proj.views
            ),
        ));
    }
    if let Some(axis) = &report.turntable {
        let fit = match axis.rms_px {
            Some(rms) => format!("RMS {rms:.3} px"),
            None => format!("circle RMS {:.3} mm", axis.circle_rms_mm.unwrap_or(Real::NAN)),
        };
        rows.push(("turntable axis", format!("{} from {} views; {fit}", esc(&axis.method), axis.views)));
    }
    let mut h = facts(&rows);
    h.push_str("<h3>Warnings</h3>");
    h.push_str(&warnings(&report.warnings));
    let missed: Vec<String> = report.not_found.iter().map(|m| format!("{}: {}", m.image.display(), m.why)).collect();
    if !missed.is_empty() {
        h.push_str("<h3>No board found</h3>");
        h.push_str(&warnings(&missed));
    }
    page.section("summary", "Summary", h);

    let views: &[BoardView] = report.camera.as_ref().map_or(&[], |c| &c.views);
    if let Some(cam) = report.camera.as_ref().filter(|c| !c.views.is_empty()) {
        page.section("camera", "Camera views", camera_views(cam, read_image));
    }
    if let Some(lasers) = report.lasers.as_ref().filter(|l| !l.is_empty()) {
        let labels: Vec<String> = lasers.iter().map(|l| format!("laser {}", l.laser)).collect();
        let mut h = String::from("<div class=\"plots\">");
        h.push_str(&bars(
            "Laser planes: RMS distance of the line's points from the fitted plane (mm)",
            &labels,
            &lasers.iter().map(|l| l.spread_rms_mm).collect::<Vec<_>>(),
            &[],
            "mm",
            "",
        ));
        h.push_str(&bars(
            "Laser planes: largest distance of an inlier from the plane (mm)",
            &labels,
            &lasers.iter().map(|l| l.spread_max_mm).collect::<Vec<_>>(),
            &[],
            "mm",
            "",
        ));
        h.push_str("</div><table><tr><th>laser</th><th class=\"num\">points</th><th class=\"num\">inliers</th><th class=\"num\">views</th><th class=\"num\">distance (mm)</th></tr>");
        for l in lasers {
            let _ = write!(
                h,
                "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                l.laser,
                l.points,
                l.inliers,
                l.views,
                num(l.distance_mm)
            );
        }
        h.push_str("</table>");
        page.section("lasers", "Laser planes", h);
    }
    let scene = scene(report, views);
    if scene.layer_count() > 0 {
        page.viewer_section("poses", "Board poses in 3D (camera frame, mm)", scene);
    }
    let mut files = Vec::new();
    if let Some(p) = &report.rig {
        files.push(relative_link(p, dir));
    }
    files.push(format!("{}.report.json", name.trim_end_matches(".report.html")));
    page.section("files", "Files", file_links(&files));
    page.render()
}

fn camera_views(cam: &CameraReport, read_image: &dyn Fn(&Path) -> Option<Image8>) -> String {
    let (w, ht, views) = (cam.lens.width.max(1), cam.lens.height.max(1), &cam.views);
    // The image's folder and name: capture layouts name every view's frame alike (view_004/00_white.png).
    let name = |v: &BoardView| {
        let parts: Vec<String> = v.image.iter().rev().take(2).map(|c| c.to_string_lossy().into_owned()).collect();
        parts.into_iter().rev().collect::<Vec<_>>().join("/")
    };
    let labels: Vec<String> = (0..views.len()).map(|i| i.to_string()).collect();
    let rms: Vec<Real> = views.iter().map(|v| v.rms_px).collect();
    let flagged: Vec<bool> = views.iter().map(|v| cam.outlier_views.contains(&v.image)).collect();
    let mut h = String::from("<div class=\"plots\">");
    h.push_str(&bars(
        "Reprojection RMS per view (px); outlier views (over 3× the median and 0.5 px) in orange",
        &labels,
        &rms,
        &flagged,
        "px",
        "view",
    ));
    let mut arrows = Vec::new();
    for v in views {
        for (c, r) in v.corners.iter().zip(&v.residuals_px) {
            arrows.push([c[0], c[1], r[0], r[1]]);
        }
    }
    let mut lengths: Vec<Real> = arrows.iter().map(|a| a[2].hypot(a[3])).filter(|l| l.is_finite()).collect();
    lengths.sort_by(Real::total_cmp);
    let p95 = lengths.get(lengths.len() * 95 / 100).copied().unwrap_or(1.0).max(1e-6);
    // The 95th-percentile residual drawn 4 % of the image wide: small errors become visible.
    let scale = 0.04 * w as Real / p95;
    h.push_str(&vectors(
        &format!(
            "Residuals over the image, every corner of every view (reprojected − found), drawn {}× \
             (95th percentile {:.3} px); a pattern here (rings, a swirl) means the lens model misses something",
            num(scale),
            p95
        ),
        w,
        ht,
        560.0,
        &arrows,
        scale,
    ));
    h.push_str("</div><h3>Images</h3><p class=\"note\">Corners found in green, the first corner in red.</p><div class=\"thumbs\">");
    for (i, v) in views.iter().enumerate().take(MAX_THUMBS) {
        let corners = &v.corners;
        let image = read_image(&v.image);
        let rms = v.rms_px;
        let rms = if rms.is_finite() { format!("{rms:.3} px") } else { "no RMS".into() };
        let caption = format!("{i}: {} — {rms}", esc(&name(v)));
        match image {
            Some(img) => {
                let mut rgb = to_rgb(&img);
                let r = (img.width / 300).max(2) as i64;
                mark(&mut rgb, corners, r, [40, 220, 90]);
                mark(&mut rgb, &corners[..corners.len().min(1)], r + 1, [240, 40, 60]);
                let _ = write!(
                    h,
                    "<div class=\"thumb\"><img alt=\"{caption}\" src=\"{}\">{caption}</div>",
                    jpeg_url(&thumbnail(&rgb, THUMB), 80)
                );
            }
            None => {
                let _ = write!(h, "<div class=\"thumb\">{caption} (image not readable now)</div>");
            }
        }
    }
    h.push_str("</div>");
    if views.len() > MAX_THUMBS {
        let _ = write!(h, "<p class=\"note\">The first {MAX_THUMBS} of {} images shown.</p>", views.len());
    }
    h
}

/// Board outlines at their poses, the camera's and projector's frusta, the turntable axis.
fn scene(report: &CalibReport, views: &[BoardView]) -> Scene {
    let mut scene = Scene::new();
    scene.set_camera_frame();
    let sq = report.board.square_mm;
    let (cols, rows) = (report.board.cols.max(2) as Real, report.board.rows.max(2) as Real);
    let mut segments = Vec::new();
    let mut far: Real = 0.0;
    for (i, v) in views.iter().enumerate() {
        let Some(p) = board_pose(&v.pose) else { continue };
        let colour = crate::plot::COLOURS[i % crate::plot::COLOURS.len()];
        let c = u32::from_str_radix(&colour[1..], 16).unwrap_or(0xffffff);
        let rgb = [(c >> 16) as u8, (c >> 8) as u8, c as u8];
        let (x1, y1) = ((cols - 1.0) * sq, (rows - 1.0) * sq);
        let q = [[0.0, 0.0], [x1, 0.0], [x1, y1], [0.0, y1]].map(|[x, y]| p * Point3::new(x, y, 0.0));
        for k in 0..4 {
            segments.push((q[k], q[(k + 1) % 4], rgb));
        }
        // The first row's edge doubled in white: the board's orientation.
        segments.push((q[0], p * Point3::new(sq, 0.0, 0.0), [255, 255, 255]));
        far = far.max(q.iter().map(|q| q.z).fold(0.0, Real::max));
    }
    if segments.is_empty() {
        return scene;
    }
    scene.add_lines("boards", &segments, true);
    let frustum = |size: (Real, Real), fx: Real, fy: Real, cx: Real, cy: Real, at: Isometry3, depth: Real, colour| {
        let corners = [[0.0, 0.0], [size.0, 0.0], [size.0, size.1], [0.0, size.1]]
            .map(|[u, v]| at * Point3::new((u - cx) / fx * depth, (v - cy) / fy * depth, depth));
        let o = at * Point3::origin();
        let mut s = Vec::new();
        for k in 0..4 {
            s.push((o, corners[k], colour));
            s.push((corners[k], corners[(k + 1) % 4], colour));
        }
        s
    };
    let depth = 0.25 * far.max(100.0);
    let mut rigs = Vec::new();
    if let Some(cam) = &report.camera {
        let size = (cam.lens.width as Real, cam.lens.height as Real);
        let at = Isometry3::identity();
        rigs.extend(frustum(size, cam.lens.fx, cam.lens.fy, cam.lens.cx, cam.lens.cy, at, depth, [230, 230, 230]));
    }
    if let Some(proj) = &report.projector
        && let Some(p) = pose(proj.rotation_vector, proj.translation_mm)
    {
        // from_camera maps camera points into the projector's frame; its inverse places the projector.
        let size = (proj.lens.width as Real, proj.lens.height as Real);
        rigs.extend(frustum(
            size,
            proj.lens.fx,
            proj.lens.fy,
            proj.lens.cx,
            proj.lens.cy,
            p.inverse(),
            depth,
            [240, 180, 60],
        ));
    }
    if !rigs.is_empty() && rigs.iter().all(|s| s.0.iter().chain(s.1.iter()).all(|v| v.is_finite())) {
        scene.add_lines("camera and projector", &rigs, true);
    }
    if let Some(axis) = &report.turntable {
        let (p, d) = (Point3::from(axis.point_mm), Vector3::from(axis.direction).normalize() * 0.3 * far.max(100.0));
        scene.add_lines("turntable axis", &[(p - 0.2 * d, p + d, [220, 60, 60])], true);
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::page::markup;
    use serde_json::json;

    #[test]
    fn a_camera_only_report_with_missing_figures_and_unreadable_images_still_makes_a_whole_page() {
        let view = |x: f64, rms: serde_json::Value| {
            json!({
                "image": format!("caps/view_00{x}/00_white.png"), "rms_px": rms,
                "corners": [[100.0 + x, 100.0], [120.0 + x, 100.0], [100.0 + x, 120.0], [120.0 + x, 120.0]],
                "residuals_px": [[0.1, 0.0], [null, null], [0.0, -0.2], [0.05, 0.05]],
                "pose": {"rotation_vector": [0.1, 0.0, 0.0], "translation_mm": [x, 0.0, 400.0]},
            })
        };
        let report = json!({
            "board": {"cols": 2, "rows": 2, "square_mm": 11.0},
            "board_found": {"found": 2, "of": 3},
            "camera": {"width": 640, "height": 480, "fx": 700.0, "fy": 700.0, "cx": 320.0, "cy": 240.0,
                       "distortion": [0.0, 0.0, 0.0, 0.0, 0.0], "rms_px": 0.12,
                       "views": [view(1.0, json!(0.1)), view(2.0, serde_json::Value::Null)], "outlier_views": []},
            "not_found": [{"image": "caps/view_003/00_white.png", "why": "no board <i>"}],
            "warnings": ["the principal point is 40 % off centre"],
        });
        // Read as `calibrate` writes it: a NaN figure is JSON null, read back as NaN.
        let report: CalibReport = serde_json::from_value(report).unwrap();
        assert!(report.camera.as_ref().unwrap().views[1].rms_px.is_nan());
        let html = build(&report, "rig.report.html".into(), Path::new(""), &|_| None);
        let text = markup(&html);
        for bad in ["NaN", "inf", "<i>"] {
            assert!(!text.contains(bad), "{bad} in the page");
        }
        assert!(text.contains("view_001/00_white.png") && text.contains("(image not readable now)"));
        assert!(text.contains("40 % off centre") && text.contains("no board &lt;i&gt;"));
        // Two board outlines and the camera: a viewer; the JSON report linked beside the page.
        assert!(html.contains("id=\"viewer-canvas\"") && text.contains("href=\"rig.report.json\""));
        assert!(!text.contains("Laser planes"), "no laser step, no laser section");
    }
}
