//! `scanrig serve`: an operator's whole run in Chromium (tests/browser/operator_run.py) against the
//! virtual turntable and the simulated camera and projector — check, calibrate, scan with the
//! turntable unplugged mid-scan and resumed, process, report — and then what the command line makes
//! of the same captures, file for file; and the station's refusals over plain HTTP.
//! `SCANRIG_UPDATE_SCREENSHOTS=1` copies the run's screenshots README.md shows into `docs/screenshots/`.

use crate::run::scanrig;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The virtual rig small enough to run the whole workflow in seconds.
const WORLD: [&str; 4] = ["--resolution", "320x240", "--views", "12"];

/// A running station; killed when dropped.
struct Station {
    child: Child,
    url: String,
}

impl Drop for Station {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(data: &Path, extra: &[&str]) -> Station {
    let mut child = Command::new(env!("CARGO_BIN_EXE_scanrig"))
        .args(["serve", "--port", "0", "--data"])
        .arg(data)
        .args(WORLD)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).expect("the station's address").to_string();
    Station { child, url }
}

/// (status, body) of a raw HTTP/1.0 request to the station at `url` with `Host: host`.
fn request(url: &str, method: &str, path: &str, host: Option<&str>, headers: &[(&str, &str)]) -> (u16, String) {
    send(url, method, path, host, headers, "")
}

/// [`request`] with a body.
fn send(
    url: &str,
    method: &str,
    path: &str,
    host: Option<&str>,
    headers: &[(&str, &str)],
    body: &str,
) -> (u16, String) {
    let addr = url.trim_start_matches("http://").split('/').next().unwrap().to_string();
    let connect = addr.replace("0.0.0.0", "127.0.0.1");
    let mut s = TcpStream::connect(&connect).unwrap();
    let mut req =
        format!("{method} {path} HTTP/1.0\r\nHost: {}\r\nContent-Length: {}\r\n", host.unwrap_or(&addr), body.len());
    // The station's own page sends JSON; a request saying otherwise is refused (checked below).
    if method == "POST" && !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("Content-Type")) {
        req.push_str("Content-Type: application/json\r\n");
    }
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    req.push_str("\r\n");
    s.write_all(req.as_bytes()).unwrap();
    s.write_all(body.as_bytes()).unwrap();
    let mut out = Vec::new();
    s.read_to_end(&mut out).unwrap();
    let text = String::from_utf8_lossy(&out).into_owned();
    let status = text.split_whitespace().nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
    (status, text.split_once("\r\n\r\n").map_or(String::new(), |(_, b)| b.to_string()))
}

#[test]
fn the_station_refuses_paths_out_of_its_folder_foreign_hosts_and_a_second_controller() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("data");
    std::fs::create_dir_all(data.join("scan1/processed")).unwrap();
    std::fs::write(data.join("scan1/processed/report.html"), "<p>report</p>").unwrap();
    // Beside the data folder, not in it: no path may reach it.
    std::fs::write(d.path().join("secret.txt"), "SECRET outside the data folder").unwrap();
    std::os::unix::fs::symlink(d.path().join("secret.txt"), data.join("scan1/link.txt")).unwrap();
    let st = serve(&data.join("scan1/.."), &[]);
    assert!(st.url.starts_with("http://127.0.0.1:"), "bound to loopback by default: {}", st.url);
    let (ok, body) = request(&st.url, "GET", "/files/scan1/processed/report.html", None, &[]);
    assert_eq!((ok, body.as_str()), (200, "<p>report</p>"));
    for bad in [
        "/files/../../../etc/passwd",
        "/files/scan1/../../../etc/passwd",
        "/files/%2e%2e/%2e%2e/etc/passwd",
        "/files/%2E%2E%2F%2E%2E%2Fetc%2Fpasswd",
        "/files/scan1/%252e%252e/secret.txt",
        "/files/%2e%2e/secret.txt",
        "/files/../secret.txt",
        "/files/scan1/link.txt",
        "/files/..%5c..%5cetc%5cpasswd",
        "/files//etc/passwd",
        "/%2e%2e/etc/passwd",
    ] {
        let (status, body) = request(&st.url, "GET", bad, None, &[]);
        assert!(status == 400 || status == 404, "{bad}: answered {status} {body}");
        assert!(!body.contains("root:") && !body.contains("SECRET"), "{bad} leaked a file");
    }
    // A page elsewhere that rebinds its name to 127.0.0.1 sends its own Host: refused.
    let port = st.url.rsplit(':').next().unwrap().trim_end_matches('/');
    let (status, _) = request(&st.url, "GET", "/api/state", Some(&format!("evil.example:{port}")), &[]);
    assert_eq!(status, 403);
    // One controller: the second is refused, and a page without control cannot drive the rig.
    let (status, body) = request(&st.url, "POST", "/api/control", None, &[]);
    assert_eq!(status, 200, "{body}");
    let (status, body) = request(&st.url, "POST", "/api/control", None, &[]);
    assert!(status == 409 && body.contains("another operator"), "{status} {body}");
    let (status, _) = request(&st.url, "POST", "/api/check", None, &[("X-Scanrig-Control", "guessed")]);
    assert_eq!(status, 409);
    // Another site's page cannot post to the station: not as a form or plain text, not from its origin.
    let port_host = format!("127.0.0.1:{port}");
    for headers in [
        vec![("Content-Type", "text/plain")],
        vec![("Content-Type", "application/x-www-form-urlencoded")],
        vec![("Content-Type", "application/json"), ("Origin", "http://evil.example")],
        vec![("Content-Type", "application/json"), ("Sec-Fetch-Site", "cross-site")],
    ] {
        let (status, body) = request(&st.url, "POST", "/api/control", Some(&port_host), &headers);
        assert_eq!(status, 403, "{headers:?}: {body}");
    }
    let origin = format!("http://{port_host}");
    let (status, _) = request(&st.url, "POST", "/api/release", Some(&port_host), &[("Origin", origin.as_str())]);
    assert_eq!(status, 409, "same origin, but without the control token");

    // Beyond loopback, the token printed at start is needed for everything, the page included.
    let wide = serve(d.path(), &["--bind", "0.0.0.0"]);
    let token = wide.url.split("?token=").nth(1).expect("a token printed with a non-loopback address");
    assert!(token.len() >= 32, "{token}");
    for path in ["/", "/api/state", "/files/scan1/processed/report.html"] {
        assert_eq!(request(&wide.url, "GET", path, Some("scanner.lan"), &[]).0, 403, "{path} without the token");
        let wrong = format!("{}{}", if token.starts_with('0') { '1' } else { '0' }, &token[1..]);
        assert_eq!(request(&wide.url, "GET", &format!("{path}?token={wrong}"), None, &[]).0, 403);
    }
    let (status, body) = request(&wide.url, "GET", "/api/state", Some("scanner.lan"), &[("X-Scanrig-Token", token)]);
    assert_eq!(status, 200, "{body}");
    // A bad token on the command line is refused before anything is bound.
    let o = scanrig(&[&"serve", &"--bind", &"0.0.0.0", &"--token", &"short", &"--data", &d.path()]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--token"));
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() { stack.push(p) } else { out.push(p.strip_prefix(dir).unwrap().to_path_buf()) }
        }
    }
    out.sort();
    out
}

#[test]
fn an_operator_checks_calibrates_scans_and_processes_in_the_browser() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("data");
    // A short --control-timeout: the page in control must answer the station's pings to keep it.
    let st = serve(&data, &["--control-timeout", "5"]);
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("station-screens");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser/operator_run.py");
    let required = std::env::var_os("SCANRIG_REQUIRE_BROWSER").is_some();
    let o = match Command::new("python3").arg(&script).args(["--url", &st.url, "--out"]).arg(&shots).output() {
        Ok(o) => o,
        Err(e) => {
            assert!(!required, "SCANRIG_REQUIRE_BROWSER is set but python3 cannot run: {e}");
            eprintln!("SKIPPED the station's browser run: no python3 ({e}); `.ci/run` installs what it needs");
            return;
        }
    };
    let err = String::from_utf8_lossy(&o.stderr);
    eprintln!("{err}");
    if o.status.code() == Some(2) {
        assert!(!required, "SCANRIG_REQUIRE_BROWSER is set but the browser is missing: {err}");
        eprintln!("SKIPPED the station's browser run: {}", err.trim());
        return;
    }
    assert!(o.status.success(), "the operator's run failed in the browser:\n{err}");
    let run: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    eprintln!("operator run: {run:#}");
    assert_eq!(run["errors"], serde_json::json!([]), "console errors, exceptions or failed requests");
    // The check: every verdict passed on the virtual rig, the turn measured from the board.
    let check = run["check"].as_array().unwrap();
    assert!(check.len() >= 5 && check.iter().all(|c| c["verdict"] == "yes"), "{check:?}");
    let turn = check.iter().find(|c| c["name"] == "turn").expect("the turn checked").to_string();
    assert!(turn.contains("+29.9") || turn.contains("+30.0"), "{turn}");
    assert!(run["calibrated"].as_str().unwrap().starts_with("Calibrated"), "{}", run["calibrated"]);
    assert!(run["overexposed"].as_str().unwrap().contains("saturated"), "{}", run["overexposed"]);
    assert!(
        run["second_controller"].as_str().unwrap().contains("another operator")
            && run["second_buttons_disabled"] == true
    );
    assert_eq!(run["second_refusal_logged"].as_array().unwrap().len(), 2, "the two refusals, and only them");
    // Idle past --control-timeout, the operator's page kept control by answering the pings.
    assert!(run["second_controller_after_idle"].as_str().unwrap().contains("another operator"), "{run}");
    assert!(run["operator_after_idle"].as_str().unwrap().contains("This page controls"), "{run}");
    // Live: every view drawn within a second of its capture; clicks answered within 200 ms while
    // the mesh was being made.
    let lags = run["lags_ms"].as_object().unwrap();
    assert_eq!(lags.len(), 12, "{lags:?}");
    assert!(lags.values().all(|l| (0..1000).contains(&l.as_i64().unwrap())), "{lags:?}");
    let clicks = run["clicks_ms"].as_array().unwrap();
    assert!(!clicks.is_empty() && clicks.iter().all(|c| c.as_i64().unwrap() < 200), "{clicks:?}");
    // The fault: said on the page, the views kept, and the scan resumed to the end.
    let fault = &run["fault"];
    assert!(fault["status"].as_str().unwrap().contains("views are kept"), "{fault}");
    assert!(fault["message"].as_str().unwrap().contains("unplugged"), "{fault}");
    let kept = run["views_before_fault"].as_u64().unwrap();
    assert!((4..12).contains(&kept), "{kept}");
    for f in ["mesh.ply", "mesh.stl", "mesh.glb", "fused.e57"] {
        assert!(run["downloads"].as_array().unwrap().iter().any(|d| d == f), "no {f} to download");
    }
    assert!(run["screens"].as_array().unwrap().len() >= 9);
    if std::env::var_os("SCANRIG_UPDATE_SCREENSHOTS").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshots");
        for screen in ["devices", "live", "calibrate", "scan", "fault", "processed", "projects", "read-only"] {
            std::fs::copy(shots.join(format!("{screen}.png")), docs.join(format!("station-{screen}.png"))).unwrap();
        }
    }

    // What the command line makes of the same captures: the same rig, frames and mesh.
    let cli = d.path().join("cli");
    std::fs::create_dir_all(&cli).unwrap();
    let o = scanrig(&[
        &"calibrate",
        &"all",
        &data.join("calibration/board"),
        &"-o",
        &cli.join("rig.toml"),
        &"--board",
        &"9x6",
        &"--square",
        &"11",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(cli.join("rig.toml")).unwrap(), std::fs::read(data.join("rig.toml")).unwrap(), "the rig");
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"scan", &"--settle-ms", &"0"];
    let (scan_dir, rig) = (cli.join("scan"), data.join("rig.toml"));
    args.extend([&"--out" as &dyn AsRef<std::ffi::OsStr>, &scan_dir, &"--rig", &rig]);
    for w in &WORLD {
        args.push(w);
    }
    let o = scanrig(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ours, theirs) = (data.join("scan1/frames"), scan_dir.join("frames"));
    let names = files(&ours);
    assert_eq!(names, files(&theirs));
    assert_eq!(names.len(), 12 * rig::Manifest::read(&scan_dir).unwrap().views[0].frames.len());
    for n in &names {
        assert!(
            std::fs::read(ours.join(n)).unwrap() == std::fs::read(theirs.join(n)).unwrap(),
            "frame {} differs from an uninterrupted scan's",
            n.display()
        );
    }
    assert_eq!(
        std::fs::read(data.join("scan1/scan.json")).unwrap(),
        std::fs::read(scan_dir.join("scan.json")).unwrap()
    );
    // The mesh is written by the reconstruct stage; the quads after it are its remesh (7 of the
    // 13 s here), which the station ran with everything else.
    let o = scanrig(&[&"process", &data.join("scan1"), &"--out", &cli.join("processed"), &"--until", &"reconstruct"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read(cli.join("processed/mesh.ply")).unwrap(),
        std::fs::read(data.join("scan1/processed/mesh.ply")).unwrap(),
        "the station's mesh is the command line's"
    );
}

/// (status, body) of a POST with a JSON body from the controller.
fn post(url: &str, path: &str, control: &str, body: &str) -> (u16, String) {
    send(url, "POST", path, None, &[("X-Scanrig-Control", control)], body)
}

#[test]
fn hostile_requests_are_refused_by_name_and_leave_the_station_and_the_disk_as_they_were() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("data");
    let st = serve(&data, &["--seconds", "120"]);
    let (_, body) = request(&st.url, "POST", "/api/control", None, &[]);
    let token: serde_json::Value = serde_json::from_str(&body).unwrap();
    let token = token["token"].as_str().unwrap();
    let long = "a".repeat(100);
    let cases: Vec<(&str, String, &str)> = vec![
        ("/api/scan", r#"{"project": "../escape"}"#.into(), "project"),
        ("/api/scan", r#"{"project": "a/b"}"#.into(), "project"),
        ("/api/scan", r#"{"project": ""}"#.into(), "project"),
        ("/api/scan", format!(r#"{{"project": "{long}"}}"#), "project"),
        ("/api/scan", r#"{"project": "ok", "views": -1}"#.into(), "views"),
        ("/api/scan", r#"{"project": "ok", "views": 1e9}"#.into(), "views"),
        ("/api/scan", r#"{"project": "ok", "views": "12"}"#.into(), "views"),
        ("/api/scan", r#"{"project": "ok", "views": 0}"#.into(), "views"),
        ("/api/process", r#"{"project": "..\\x"}"#.into(), "project"),
        ("/api/process", r#"{"project": 7}"#.into(), "project"),
        ("/api/scan", "not json".into(), "JSON"),
        ("/api/turntable", r#"{"angle": 1e300}"#.into(), "angle"),
        ("/api/turntable", r#"{"laser": 99, "on": true}"#.into(), "laser"),
        ("/api/turntable", r#"{"nothing": 1}"#.into(), "angle"),
        ("/api/devices", r#"{"turntable": "/dev/nonexistent-port"}"#.into(), "turntable"),
        ("/api/devices", r#"{"camera": "/no/such/folder"}"#.into(), "camera"),
        ("/api/calibrate/capture", r#"{"kind": "sideways"}"#.into(), "kind"),
        ("/api/calibrate/capture", r#"{"kind": 3}"#.into(), "kind"),
        ("/api/camera", r#"{"exposure": 0}"#.into(), "exposure"),
        ("/api/camera", r#"{"exposure": "bright"}"#.into(), "exposure"),
        ("/api/projector", r#"{"pattern": "plaid"}"#.into(), "pattern"),
        ("/api/calibrate/review", r#"{"index": 99999, "accept": true}"#.into(), "index"),
        ("/api/calibrate/review", r#"{"index": -1, "accept": "yes"}"#.into(), "index"),
        ("/api/calibrate/review", r#"{"index": 0, "accept": "yes"}"#.into(), "accept"),
        ("/api/nowhere", "{}".into(), "not found"),
    ];
    for (path, body, names) in &cases {
        let (status, answer) = post(&st.url, path, token, body);
        // Refused at once, naming what is wrong.
        assert!((400..500).contains(&status), "{path} {body}: answered {status} {answer}");
        assert!(answer.contains(names), "{path} {body}: the refusal does not name {names:?}: {answer}");
        assert!(!answer.contains("panicked"), "{answer}");
    }
    // A body far past the limit is cut, not read whole, and refused.
    let (status, _) = post(&st.url, "/api/scan", token, &format!(r#"{{"project": "{}"}}"#, "x".repeat(200_000)));
    assert!((400..500).contains(&status));
    // The station still answers, and nothing was made outside its data folder's projects.
    let (status, _) = request(&st.url, "GET", "/api/state", None, &[]);
    assert_eq!(status, 200);
    assert!(!d.path().join("escape").exists() && !data.join("a").exists());
    let made: Vec<_> = std::fs::read_dir(&data).unwrap().flatten().map(|e| e.file_name()).collect();
    assert!(made.iter().all(|n| n == "calibration"), "{made:?}");
}

/// The events a station sends on one stream until one of `kind` carries `until` (or 60 s pass).
fn events_until(url: &str, kind: &str, until: &str, start: impl FnOnce()) -> Vec<(String, serde_json::Value)> {
    let addr = url.trim_start_matches("http://").split('/').next().unwrap().to_string();
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(60))).unwrap();
    s.write_all(format!("GET /api/events HTTP/1.0\r\nHost: {addr}\r\n\r\n").as_bytes()).unwrap();
    let (mut name, mut reader) = (String::new(), BufReader::new(s));
    // The stream is open (its head and first event read) before the work starts.
    let mut head = String::new();
    while !head.starts_with("retry:") {
        head.clear();
        reader.read_line(&mut head).unwrap();
    }
    start();
    let mut events = Vec::new();
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).unwrap_or(0) == 0 {
            return events;
        }
        if let Some(n) = line.strip_prefix("event: ") {
            name = n.trim().to_string();
        } else if let Some(d) = line.strip_prefix("data: ") {
            let v: serde_json::Value = serde_json::from_str(d.trim()).unwrap();
            let done = name == kind && v["name"] == until;
            events.push((name.clone(), v));
            if done {
                return events;
            }
        }
    }
}

#[test]
fn a_laser_rig_is_checked_and_its_line_shown_with_the_pipeline_s_own_extraction() {
    let d = tempfile::tempdir().unwrap();
    let st = serve(d.path(), &["--config", "laser"]);
    let (_, body) = request(&st.url, "POST", "/api/control", None, &[]);
    let token: serde_json::Value = serde_json::from_str(&body).unwrap();
    let token = token["token"].as_str().unwrap().to_string();
    let events = events_until(&st.url, "check", "end", || {
        assert_eq!(post(&st.url, "/api/check", &token, "{}").0, 202);
    });
    let verdicts: Vec<&serde_json::Value> =
        events.iter().filter(|(k, v)| k == "check" && v["ok"].is_boolean()).map(|(_, v)| v).collect();
    for name in ["turntable", "board", "exposure", "turn", "laser 0", "laser 1"] {
        let v =
            verdicts.iter().find(|v| v["name"] == name).unwrap_or_else(|| panic!("no {name} verdict: {verdicts:?}"));
        assert_eq!(v["ok"], true, "{v}");
    }
    // The live view's laser line: the pipeline's extraction, every reason named (once the check's
    // job has let go of the rig).
    while request(&st.url, "GET", "/api/state", None, &[]).1.contains("\"job\":{") {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let (status, body) = request(&st.url, "GET", "/api/live?show=laser", None, &[("X-Scanrig-Control", &token)]);
    assert_eq!(status, 200, "{body}");
    let live: serde_json::Value = serde_json::from_str(&body).unwrap();
    let note = live["note"].as_str().unwrap();
    let rows: usize = note.split("a line in ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(rows > 50 && note.contains("saturated") && note.contains("doubled"), "{note}");
    assert!(live["image"].as_str().unwrap().starts_with("data:image/png;base64,"));
    // Without control, no frame.
    assert_eq!(request(&st.url, "GET", "/api/live?show=raw", None, &[]).0, 409);
}

/// A page in control whose laptop goes to sleep keeps its event stream open (nothing closes the
/// socket until TCP gives up, about 15 minutes), so the stream alone cannot tell the station it is
/// gone: the station pings every stream and the page in control answers. Here that page answers
/// for 6 s, then stops reading with its stream still open; another page is refused while it
/// answers and takes control once it has been unheard for `--control-timeout` (4 s).
#[test]
fn a_controlling_page_that_stops_answering_loses_control_after_the_timeout() {
    use std::time::{Duration, Instant};
    let d = tempfile::tempdir().unwrap();
    let st = serve(d.path(), &["--control-timeout", "4"]);
    let take = || request(&st.url, "POST", "/api/control", None, &[]);
    let (status, body) = take();
    assert_eq!(status, 200, "{body}");
    let token: serde_json::Value = serde_json::from_str(&body).unwrap();
    let a = token["token"].as_str().unwrap().to_string();
    let addr = st.url.trim_start_matches("http://").split('/').next().unwrap().to_string();
    let mut stream = TcpStream::connect(&addr).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    stream.write_all(format!("GET /api/events?control={a} HTTP/1.0\r\nHost: {addr}\r\n\r\n").as_bytes()).unwrap();
    let awake_until = Instant::now() + Duration::from_secs(6);
    let (url, token_a) = (st.url.clone(), a.clone());
    // The page: answers each ping until it falls asleep, then holds its stream open unread.
    let page = std::thread::spawn(move || {
        let mut reader = BufReader::new(stream);
        let (mut answered, mut last) = (0, Instant::now());
        while Instant::now() < awake_until {
            let mut line = String::new();
            if reader.read_line(&mut line).unwrap_or(0) == 0 {
                break;
            }
            if line.trim() == "event: ping" {
                // Taken before the answer is sent: the station hears it later, never earlier.
                let sent = Instant::now();
                let (status, body) = post(&url, "/api/alive", &token_a, "{}");
                assert_eq!(status, 200, "{body}");
                (answered, last) = (answered + 1, sent);
            }
        }
        (answered, last, reader)
    });
    // Past the timeout since the stream opened: only the page's answers keep control now.
    std::thread::sleep(Duration::from_millis(5_500));
    let (status, body) = take();
    assert!(status == 409 && body.contains("another operator"), "while the page answers: {status} {body}");
    let (answered, last_answer, _asleep) = page.join().unwrap();
    assert!(answered >= 3, "pings answered in 6 s: {answered}");
    let (status, body) = take();
    assert_eq!(status, 409, "just after the page fell asleep: {body}");
    let taken = loop {
        let (status, body) = take();
        if status == 200 {
            break last_answer.elapsed();
        }
        assert!(last_answer.elapsed() < Duration::from_secs(12), "control never passed: {status} {body}");
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(taken >= Duration::from_secs(4), "control passed {taken:?} after the page's last answer");
    // The sleeping page wakes: its answer is refused, and it watches.
    let (status, body) = post(&st.url, "/api/alive", &a, "{}");
    assert!(status == 409 && body.contains("another operator"), "{status} {body}");
}
