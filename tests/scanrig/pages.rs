//! Issue 23: the pages scanrig writes — a processed scan's `report.html`, a calibration's
//! `NAME.report.html`, and `scanrig view`'s page — work offline in a real browser: no console
//! errors, the 3D canvas draws (pixels that are not the background, counted from a screenshot, with
//! each layer shown in turn), every image decodes and every link resolves.
//!
//! The browser half needs Debian's chromium and Playwright for Python (`tests/browser/check_pages.py`
//! says how to install them); `.ci/run` installs them and sets `SCANRIG_REQUIRE_BROWSER=1`, so there
//! a missing browser fails the test; elsewhere the test says it skipped that half. The offline checks
//! in Rust (images decode, links resolve, nothing fetched from the network) always run.
//! `SCANRIG_UPDATE_SCREENSHOTS=1` copies the screenshots README.md shows into `docs/screenshots/`.

use crate::run::scanrig;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Every `attr="…"` value in the page.
fn attributes<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!(" {attr}=\"");
    html.match_indices(&key).filter_map(|(i, _)| html[i + key.len()..].split('"').next()).collect()
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Some(v) = std::str::from_utf8(&b[i + 1..i + 3]).ok().and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The checks that need no browser: the page fetches nothing (no script or image from elsewhere),
/// every embedded image decodes, every link resolves. Returns (images, links).
fn offline_checks(page: &Path) -> (usize, usize) {
    let html = std::fs::read_to_string(page).unwrap();
    let dir = page.parent().unwrap();
    assert!(!html.contains("<script src") && !html.contains("<link "), "{}: loads a file", page.display());
    let images = attributes(&html, "src");
    for src in &images {
        let (kind, b64) =
            src.split_once(";base64,").unwrap_or_else(|| panic!("{}: image not embedded: {src}", page.display()));
        let bytes = base64::Engine::decode(&base64::engine::general_purpose::STANDARD, b64).unwrap();
        let img = match kind {
            "data:image/png" => rig::image::decode_png(&bytes).unwrap(),
            "data:image/jpeg" => rig::image::decode_jpeg(&bytes).unwrap(),
            other => panic!("{}: unexpected image {other}", page.display()),
        };
        assert!(img.width > 0 && img.height > 0);
    }
    let links = attributes(&html, "href");
    for href in &links {
        if let Some(id) = href.strip_prefix('#') {
            assert!(html.contains(&format!("id=\"{id}\"")), "{}: no anchor {href}", page.display());
        } else {
            assert!(!href.contains("://"), "{}: links off the machine: {href}", page.display());
            let target = dir.join(percent_decode(href));
            assert!(target.exists(), "{}: link {href} → {} does not exist", page.display(), target.display());
        }
    }
    (images.len(), links.len())
}

/// The browser's verdict on `pages` (screenshots into `shots`), or None (said) when no browser is at
/// hand and none is required.
fn browser_checks(pages: &[PathBuf], shots: &Path) -> Option<serde_json::Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser/check_pages.py");
    let o = Command::new("python3").arg(script).arg("--out").arg(shots).args(pages).output();
    let required = std::env::var_os("SCANRIG_REQUIRE_BROWSER").is_some();
    let o = match o {
        Ok(o) => o,
        Err(e) => {
            assert!(!required, "SCANRIG_REQUIRE_BROWSER is set but python3 cannot run: {e}");
            eprintln!("SKIPPED the browser checks of the pages: no python3 ({e}); `.ci/run` installs what they need");
            return None;
        }
    };
    let err = String::from_utf8_lossy(&o.stderr);
    eprintln!("{err}");
    if o.status.code() == Some(2) {
        assert!(!required, "SCANRIG_REQUIRE_BROWSER is set but the browser is missing: {err}");
        eprintln!("SKIPPED the browser checks of the pages: {}", err.trim());
        return None;
    }
    assert!(o.status.success(), "the pages failed in the browser:\n{err}");
    Some(serde_json::from_slice(&o.stdout).unwrap())
}

/// Points on a sphere of radius 80 mm, coloured by height: a cloud past the viewer's display limit.
fn big_cloud(path: &Path, n: usize) {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut cloud = rig::PointCloud::default();
    let mut colours = Vec::with_capacity(n);
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let a = golden * i as f64;
        cloud.positions.push(rig::Point3::new(80.0 * r * a.cos(), 80.0 * r * a.sin(), 80.0 * z + 80.0));
        colours.push([(127.0 * (1.0 + z)) as u8, 90, (127.0 * (1.0 - z)) as u8]);
    }
    cloud.colors = Some(colours);
    rig::ply::write_cloud(path, &cloud, &Default::default()).unwrap();
}

#[test]
fn report_calibration_and_view_pages_work_offline_in_a_browser() {
    let d = tempfile::tempdir().unwrap();
    let demo = crate::shared_demo::copy_demo(d.path());
    let (scan, processed) = (demo.join("scan"), demo.join("processed"));
    // `demo` (like `process`) wrote the page; `report` rebuilds it and measures the mesh on the truth.
    let report = processed.join("report.html");
    assert!(report.is_file(), "demo wrote no report.html");
    std::fs::remove_file(&report).unwrap();
    let o = scanrig(&[&"report", &scan, &"-o", &processed]);
    ok(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("report.html") && report.is_file(), "{out}");
    let rms: f64 = out.split("RMS ").nth(1).and_then(|s| s.split(' ').next()).and_then(|s| s.parse().ok()).unwrap();
    // The figure the page shows, against one measured here by brute force (every triangle of the
    // truth for every 151st vertex above 3 mm, no spatial index): two views leave the back of the vase
    // invented, so the figure is large, and it must be that one.
    let truth = rig::read_mesh(&scan.join("truth/object.ply")).unwrap().triangulate();
    let mesh = rig::read_mesh(&processed.join("mesh.ply")).unwrap().triangulate();
    let diag = truth.bounding_box().unwrap().diagonal();
    let sample: Vec<f64> = mesh
        .vertices
        .iter()
        .filter(|v| v.z > 3.0)
        .step_by(151)
        .map(|v| {
            truth
                .faces
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|i| truth.vertices[i as usize]);
                    (process::mesh_distance::closest_on_triangle(v, &a, &b, &c) - v).norm()
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let want = 100.0 * (sample.iter().map(|e| e * e).sum::<f64>() / sample.len() as f64).sqrt() / diag;
    assert!(rms.is_finite() && (rms / want - 1.0).abs() < 0.15, "the page says RMS {rms} %, brute force {want} %");
    let html = std::fs::read_to_string(&report).unwrap();
    for part in [
        "id=\"summary\"",
        "id=\"views\"",
        "id=\"view3d\"",
        "id=\"accuracy\"",
        "id=\"files\"",
        "error against the truth",
    ] {
        assert!(html.contains(part), "report.html lacks {part}");
    }

    // A calibration: the laser rig on a short sweep (camera, axis and both planes).
    let caps = d.path().join("caps");
    ok(&scanrig(&[
        &"sim",
        &"--board",
        &"9x6",
        &"--square",
        &"11",
        &"--config",
        &"laser",
        &"--resolution",
        &"640x480",
        &"--poses",
        &"6",
        &"--sweep=-40:40:20",
        &"--out",
        &caps,
    ]));
    let rig_toml = d.path().join("rig.toml");
    ok(&scanrig(&[&"calibrate", &"all", &caps, &"-o", &rig_toml, &"--board", &"9x6", &"--square", &"11"]));
    let calib = d.path().join("rig.report.html");
    let chtml = std::fs::read_to_string(&calib).unwrap();
    for part in ["Reprojection RMS per view", "Residuals over the image", "Laser planes", "turntable axis", "boards"] {
        assert!(chtml.contains(part), "rig.report.html lacks {part}");
    }

    // `view`: a mesh and a cloud together, and a 3 M-point cloud past the display limit.
    let view = d.path().join("view.html");
    ok(&scanrig(&[&"view", &processed.join("mesh.ply"), &processed.join("fused.ply"), &"-o", &view]));
    let big = d.path().join("big.ply");
    big_cloud(&big, 3_000_000);
    let o = scanrig(&[&"view", &big]);
    ok(&o);
    let big_page = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
    assert_eq!(big_page, d.path().join("big.view.html"));
    let big_html = std::fs::read_to_string(&big_page).unwrap();
    assert!(big_html.contains("600\u{2009}000 of its 3\u{2009}000\u{2009}000 points"), "decimation not said");
    let mb = big_html.len() as f64 / 1e6;
    assert!(mb < 25.0, "a 3 M-point cloud's page is {mb:.1} MB");

    let pages = [report.clone(), calib.clone(), view.clone(), big_page.clone()];
    for p in &pages {
        let (images, links) = offline_checks(p);
        eprintln!("{}: {images} embedded images decode, {links} links resolve", p.display());
    }
    let shots = d.path().join("shots");
    let Some(seen) = browser_checks(&pages, &shots) else { return };
    let pick = seen[0]["pick"].as_str().unwrap_or("");
    assert!(pick.starts_with("x "), "a click on the report's cloud read no point: {pick:?}");
    for (page, s) in pages.iter().zip(seen.as_array().unwrap()) {
        assert_eq!(s["errors"], serde_json::json!([]), "{}: {s}", page.display());
        let canvases = s["canvases"].as_array().unwrap();
        assert!(!canvases.is_empty(), "{}: no viewer canvas checked", page.display());
        eprintln!(
            "{}: {:.1} MB, opened (viewer drawn) in {:.2} s; canvas drawn {:.1} % after load",
            page.display(),
            s["bytes"].as_f64().unwrap() / 1e6,
            s["open_seconds"].as_f64().unwrap(),
            100.0 * canvases[0]["fraction"].as_f64().unwrap()
        );
    }
    if std::env::var_os("SCANRIG_UPDATE_SCREENSHOTS").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshots");
        std::fs::create_dir_all(&docs).unwrap();
        for (from, to) in [
            ("report.png", "report.png"),
            ("report.viewer.2.png", "report-error.png"),
            ("rig.report.png", "calibration-report.png"),
            ("view.viewer.png", "view.png"),
        ] {
            std::fs::copy(shots.join(from), docs.join(to)).unwrap();
        }
    }
}

#[test]
fn view_serves_its_page_on_loopback_and_refuses_what_it_cannot_show() {
    use std::io::{BufRead, Read, Write};
    let d = tempfile::tempdir().unwrap();
    let obj = d.path().join("m.obj");
    std::fs::write(&obj, b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_scanrig"))
        .args(["view", "--serve"])
        .arg(&obj)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let addr =
        line.trim().strip_prefix("http://").and_then(|a| a.strip_suffix('/')).unwrap_or_else(|| panic!("{line}"));
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    write!(s, "GET / HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut page = String::new();
    s.read_to_string(&mut page).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(
        page.contains(" 200 ") && page.contains("viewer-canvas") && page.contains("m.obj"),
        "{}",
        &page[..200.min(page.len())]
    );
    assert!(!page.contains("Open the files"), "a served page has no file links to follow");
    assert!(!d.path().join("m.view.html").exists(), "--serve writes nothing");

    // What cannot be shown is named.
    let missing = d.path().join("missing.ply");
    let o = scanrig(&[&"view", &missing]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("missing.ply"));
    let o = scanrig(&[&"report", &d.path()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("report.json") && err.contains("scanrig process"), "{err}");
    let empty = d.path().join("empty.ply");
    std::fs::write(
        &empty,
        b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    )
    .unwrap();
    let o = scanrig(&[&"view", &empty]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("empty.ply") && err.contains("nothing"), "{err}");
}
