//! `scanrig serve`: the operator's station in the browser. One page (offline: every script inlined)
//! talks to a small JSON API and listens on one event stream; every job it starts — a device check,
//! a calibration, a scan, processing — runs the same library calls as the command line, on a thread
//! of its own, and says how it goes on the stream. The server holds no algorithm.
//!
//! Who may do what: the station listens on 127.0.0.1 unless told otherwise, and answers only
//! requests that name it by a loopback host name (a web page elsewhere cannot rebind its name to
//! it); bound anywhere else, every request carries the token printed at start. One page at a time
//! controls the rig (it took control and holds its token); every other page watches, read-only.

mod calibration;
mod check;
mod devices;
mod events;
mod guard;
mod live;
mod process_job;
mod projector;
mod projects;
mod scan_job;

use crate::cli::{BoardArg, ServeArgs, SimWorld};
use anyhow::{Context, Result, bail};
use events::Bus;
use guard::{Access, Refusal};
use serde_json::{Value, json};
use sim::SimConfig;
use std::io::Read;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tiny_http::{Header, Method, Request, Response, ResponseBox};

/// A page that controls the rig gives up control this long after its event stream closed
/// (a reload reconnects well within it).
const CONTROL_GRACE: Duration = Duration::from_secs(10);

/// The longest `--seconds`: a year (more is a typo; leave it out to serve until interrupted).
const MAX_SECONDS: u64 = 365 * 24 * 3600;

/// `--control-timeout`'s range, seconds: under 3 a page's answers to the pings (a third of it
/// apart) would race the network; over an hour a sleeping laptop keeps the rig locked all morning.
const CONTROL_TIMEOUT: std::ops::RangeInclusive<u64> = 3..=3600;

/// The page controlling the rig.
struct Controller {
    token: String,
    /// Its open event streams.
    streams: usize,
    /// When its last stream closed (or when it took control, before it opened one).
    gone_since: Option<Instant>,
    /// When it was last heard from: its answers to the stream's pings, any other request that
    /// needs control (every POST, a live frame), and its event stream opening.
    /// A stream stays open while its laptop sleeps, until TCP gives up (about 15 minutes), so an
    /// open stream alone does not prove the page is there.
    heard: Instant,
}

/// What runs now: one job at a time, so two never drive the rig at once.
#[derive(Clone, serde::Serialize)]
pub struct Job {
    /// check, calibrate, scan or process.
    pub kind: String,
    /// The project (scan folder) it works on, where it has one.
    pub project: Option<String>,
}

/// The station's state, shared by the request threads and the jobs.
pub struct Station {
    access: Access,
    /// The projects' folder (absolute).
    pub data: PathBuf,
    /// The rig file calibration writes and scans use.
    pub rig_path: PathBuf,
    /// The virtual rig's world.
    pub world: SimWorld,
    /// Its simulator config.
    pub cfg: SimConfig,
    /// The calibration board.
    pub board: BoardArg,
    /// Its square, mm.
    pub square: f64,
    /// The event stream.
    pub bus: Bus,
    controller: Mutex<Option<Controller>>,
    /// How long the controller may go unheard before another page may take control.
    control_timeout: Duration,
    job: Mutex<Option<Job>>,
    /// The devices chosen and the turntable's link.
    pub devices: devices::Devices,
    /// The calibration in progress.
    pub calibration: Mutex<calibration::Wizard>,
    /// The virtual camera's exposure (the simulator's `[sensor] exposure`), set from the live view.
    pub exposure: Mutex<f64>,
    /// What the operator set the projector to show by hand (`None`: off); the raw live frame shows it.
    pub projector: Mutex<Option<rig::Pattern>>,
    /// The real projector's window (`--projector-monitor`), where there is one.
    pub window: Option<projector::Window>,
}

/// Locks, going on with the data when another thread panicked holding it (every state here stays
/// consistent between statements).
pub fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Station {
    /// The rig scans use: the rig file when there is one, else the virtual rig's own.
    pub fn rig(&self) -> Result<rig::Rig> {
        rig_at(&self.rig_path, &self.cfg)
    }

    /// The projector for a job showing `program` on `rig` (refused where its frames would be unlit:
    /// [`projector::for_job`]), the simulator camera seeing `shown`.
    pub fn projector_for(
        &self,
        rig: &rig::Rig,
        shown: &Arc<Mutex<Option<rig::Pattern>>>,
        program: &[rig::Pattern],
    ) -> Result<projector::Shown<'_>> {
        projector::for_job(self.window.as_ref(), rig, &self.devices.camera(), shown, program, &self.projector)
    }

    /// Whether the station drives `rig`'s projector for the camera chosen ([`projector::drives`]).
    pub fn drives_projector(&self, rig: &rig::Rig) -> Result<(), String> {
        projector::drives(self.window.as_ref(), rig, &self.devices.camera())
    }

    /// The simulator's config with the exposure set now: the virtual camera's settings.
    pub fn camera_config(&self) -> SimConfig {
        let mut cfg = self.cfg.clone();
        cfg.sensor.exposure = *lock(&self.exposure);
        cfg
    }

    /// Starts `kind` on a thread of its own unless a job runs; the thread's error is said on the
    /// stream as a `fault` event and the job ends either way.
    fn start_job(
        self: &Arc<Self>,
        kind: &str,
        project: Option<String>,
        work: impl FnOnce(&Arc<Station>) -> Result<()> + Send + 'static,
    ) -> Result<(), (u16, String)> {
        self.claim(kind, project.clone())?;
        self.bus.send("state", self.state_json());
        let st = self.clone();
        let kind = kind.to_string();
        std::thread::spawn(move || {
            // Each job is one run of the command line's kind: what it reads, it never overwrites
            // (rig::run_files), counted from the job's start.
            let _run = rig::run_files::Run::open();
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&st)));
            let error = match result {
                Ok(Ok(())) => None,
                Ok(Err(e)) => Some(format!("{e:#}")),
                Err(_) => Some("internal error (a bug in scanrig; the log above says where)".into()),
            };
            if let Some(e) = error {
                st.bus.send("fault", json!({"job": kind, "project": project, "message": e}));
            }
            // The run's record ends before the slot frees: the next job opens its own.
            drop(_run);
            *lock(&st.job) = None;
            st.bus.send("state", st.state_json());
        });
        Ok(())
    }

    /// Takes the one job slot for `kind`, or says what holds it.
    fn claim(&self, kind: &str, project: Option<String>) -> Result<(), (u16, String)> {
        let mut job = lock(&self.job);
        if let Some(j) = job.as_ref() {
            return Err((
                409,
                format!("busy: {} {} runs; wait for it or stop it", j.kind, j.project.clone().unwrap_or_default()),
            ));
        }
        *job = Some(Job { kind: kind.into(), project });
        Ok(())
    }

    /// Runs `work` now, on the request's thread, holding the job slot (a live frame, a manual move,
    /// a change of devices: none may touch the rig while a job drives it, nor a job start meanwhile).
    pub fn exclusive<T>(&self, kind: &str, work: impl FnOnce() -> Result<T, String>) -> Result<T, (u16, String)> {
        self.claim(kind, None)?;
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        *lock(&self.job) = None;
        match r {
            Ok(r) => r.map_err(|e| (400, e)),
            Err(_) => Err((500, "internal error (a bug in scanrig; the log above says where)".into())),
        }
    }

    /// Everything a page shows outside a job's own events.
    pub fn state_json(&self) -> Value {
        let controlled = lock(&self.controller).is_some();
        json!({
            "job": *lock(&self.job),
            "controlled": controlled,
            "devices": self.devices.describe(),
            "rig": {
                "path": self.rig_path.display().to_string(),
                "calibrated": self.rig_path.is_file(),
            },
            "board": format!("{}x{}", self.board.cols, self.board.rows),
            "exposure": *lock(&self.exposure),
            "projector": lock(&self.projector).map(|p| p.name()),
            "projector_window": self.window.as_ref().map(|w| w.describe()),
            "views": self.cfg.scan.views,
            "data": self.data.display().to_string(),
        })
    }

    /// Gives control to the page asking, unless another page holds it.
    fn take_control(&self, offered: Option<&str>) -> Result<String, (u16, String)> {
        let mut c = lock(&self.controller);
        if let Some(held) = c.as_ref() {
            let closed = held.streams == 0 && held.gone_since.is_some_and(|t| t.elapsed() > CONTROL_GRACE);
            let gone = closed || held.heard.elapsed() > self.control_timeout;
            if offered != Some(held.token.as_str()) && !gone {
                return Err((
                    409,
                    "another operator controls the rig: this page watches, read-only (control passes when that page \
                     releases it, closes, or goes unheard for --control-timeout)"
                        .into(),
                ));
            }
            if offered == Some(held.token.as_str()) {
                return Ok(held.token.clone());
            }
        }
        let token = guard::new_token().map_err(|e| (500, format!("no random token: {e}")))?;
        let now = Instant::now();
        *c = Some(Controller { token: token.clone(), streams: 0, gone_since: Some(now), heard: now });
        Ok(token)
    }

    /// True when `token` is the controller's, which is then heard from now.
    fn controls(&self, token: Option<&str>) -> bool {
        let mut c = lock(&self.controller);
        match c.as_mut().filter(|h| Some(h.token.as_str()) == token) {
            Some(held) => {
                held.heard = Instant::now();
                true
            }
            None => false,
        }
    }

    /// A controller's event stream opened (`true`) or closed.
    fn stream_of(&self, token: Option<&str>, open: bool) {
        let mut c = lock(&self.controller);
        if let Some(held) = c.as_mut().filter(|h| Some(h.token.as_str()) == token) {
            if open {
                held.streams += 1;
                held.gone_since = None;
                held.heard = Instant::now();
            } else {
                held.streams = held.streams.saturating_sub(1);
                if held.streams == 0 {
                    held.gone_since = Some(Instant::now());
                }
            }
        }
    }
}

/// The rig file at `path` when there is one, else the virtual rig's own.
fn rig_at(path: &std::path::Path, cfg: &SimConfig) -> Result<rig::Rig> {
    if path.is_file() {
        return rig::Rig::read(path).with_context(|| format!("reading {}", path.display()));
    }
    Ok(crate::virtual_rig::default_rig(cfg))
}

pub fn run(args: &ServeArgs) -> Result<()> {
    if args.board.charuco.is_some() {
        bail!("--board: the station's wizard calibrates with a chessboard (ChArUco boards: `scanrig calibrate`)");
    }
    // The board as `calibrate` checks it, before anything is bound.
    calib::RigCalibParams {
        target: calib::workflow::Target::All,
        board: calib::BoardSpec {
            cols: args.board.cols as usize,
            rows: args.board.rows as usize,
            square_mm: args.square,
            markers: None,
        },
        orientation: calib::workflow::Orientation::default(),
        lens: calib::CameraOptions::default(),
        lens_model: calib::LensModel::default(),
        corner_height_mm: None,
        projector_size: None,
    }
    .validate()?;
    if args.seconds.is_some_and(|s| s > MAX_SECONDS) {
        bail!("--seconds must be at most {MAX_SECONDS} (a year); leave it out to serve until interrupted");
    }
    if !CONTROL_TIMEOUT.contains(&args.control_timeout) {
        bail!(
            "--control-timeout must be {} to {} seconds, got {}",
            CONTROL_TIMEOUT.start(),
            CONTROL_TIMEOUT.end(),
            args.control_timeout
        );
    }
    let cfg = crate::sim_cmd::world_config(&args.world)?;
    let loopback = args.bind.is_loopback();
    let token = match (&args.token, loopback) {
        (Some(t), _) if t.len() < 16 || !t.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_') => {
            bail!("--token must be at least 16 letters, digits, - or _")
        }
        (Some(t), _) => Some(t.clone()),
        (None, true) => None,
        (None, false) => Some(guard::new_token().context("making a token")?),
    };
    if loopback && token.is_some() {
        eprintln!("note: --token is needed only for a non-loopback --bind; it is asked for anyway");
    }
    std::fs::create_dir_all(&args.data).with_context(|| format!("creating the data folder {}", args.data.display()))?;
    let data = args.data.canonicalize().with_context(|| format!("opening {}", args.data.display()))?;
    if !data.is_dir() {
        bail!("--data {}: not a folder", args.data.display());
    }
    let rig_path = args.rig.clone().unwrap_or_else(|| data.join("rig.toml"));
    if let Some(r) = &args.rig {
        rig::Rig::read(r).with_context(|| format!("--rig {}", r.display()))?;
    }
    // The real projector's window, at the size of the rig's projector now.
    let window = match args.projector_monitor {
        Some(m) => Some(projector::Window::open(m, &rig_at(&rig_path, &cfg)?)?),
        None => None,
    };
    let server = tiny_http::Server::http((args.bind, args.port))
        .map_err(|e| anyhow::anyhow!("listening on {}:{}: {e}", args.bind, args.port))?;
    let port = server.server_addr().to_ip().map_or(args.port, |a| a.port());
    let station = Arc::new(Station {
        access: Access { loopback, port, token: token.clone() },
        data,
        rig_path,
        world: args.world.clone(),
        exposure: Mutex::new(cfg.sensor.exposure),
        projector: Mutex::new(Some(rig::Pattern::White)),
        cfg,
        board: args.board,
        square: args.square,
        bus: Bus::default(),
        controller: Mutex::new(None),
        control_timeout: Duration::from_secs(args.control_timeout),
        job: Mutex::new(None),
        devices: devices::Devices::default(),
        calibration: Mutex::new(calibration::Wizard::default()),
        window,
    });
    let host = if loopback { "127.0.0.1".to_string() } else { args.bind.to_string() };
    let query = token.as_ref().map(|t| format!("?token={t}")).unwrap_or_default();
    println!("scanrig station on http://{host}:{port}/{query}");
    use std::io::Write as _;
    std::io::stdout().flush()?;
    eprintln!(
        "projects in {}; rig {}; Ctrl-C stops the station (a scan keeps its complete views; Start resumes it)",
        station.data.display(),
        station.rig_path.display()
    );
    let page = Arc::new(web::station_page::build());
    let until = args.seconds.map(|s| Instant::now() + Duration::from_secs(s));
    loop {
        let left = until.map(|u| u.saturating_duration_since(Instant::now()));
        if left == Some(Duration::ZERO) {
            return Ok(());
        }
        let wait = left.unwrap_or(Duration::from_secs(3600)).min(Duration::from_secs(3600));
        if let Some(request) = server.recv_timeout(wait).context("accepting a request")? {
            let (st, page) = (station.clone(), page.clone());
            std::thread::spawn(move || handle(&st, &page, request));
        }
    }
}

/// A JSON answer.
fn json_response(status: u16, body: &Value) -> ResponseBox {
    Response::from_data(body.to_string().into_bytes())
        .with_status_code(status)
        .with_header(header("Content-Type", "application/json"))
        .with_header(header("Cache-Control", "no-store"))
        .boxed()
}

fn header(k: &str, v: &str) -> Header {
    Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("an ASCII header")
}

fn error(status: u16, message: &str) -> ResponseBox {
    json_response(status, &json!({ "error": message }))
}

fn header_value<'a>(req: &'a Request, name: &'static str) -> Option<&'a str> {
    req.headers().iter().find(|h| h.field.equiv(name)).map(|h| h.value.as_str())
}

/// A request's JSON body (at most 64 KiB); `{}` when empty.
fn body(req: &mut Request) -> Result<Value, String> {
    let mut text = String::new();
    req.as_reader().take(64 * 1024).read_to_string(&mut text).map_err(|e| format!("reading the request: {e}"))?;
    if text.trim().is_empty() {
        return Ok(json!({}));
    }
    serde_json::from_str(&text).map_err(|e| format!("the request is not JSON: {e}"))
}

fn handle(st: &Arc<Station>, page: &str, mut req: Request) {
    let url = req.url().to_string();
    let token = header_value(&req, "X-Scanrig-Token")
        .map(str::to_string)
        .or_else(|| guard::query_value(&url, "token"))
        .or_else(|| header_value(&req, "Cookie").and_then(guard::cookie_token));
    if let Err(r) = st.access.admit(header_value(&req, "Host"), token.as_deref()) {
        let _ = req.respond(error(r.status(), r.message()));
        return;
    }
    let path = match guard::clean_path(&url) {
        Ok(p) => p,
        Err(r) => {
            let _ = req.respond(error(r.status(), r.message()));
            return;
        }
    };
    let control = header_value(&req, "X-Scanrig-Control").map(str::to_string);
    let method = req.method().clone();
    // The event stream keeps its connection: it answers on this thread until the page goes away.
    if method == Method::Get && path == "/api/events" {
        let ctl = guard::query_value(&url, "control");
        let events = st.bus.subscribe();
        st.stream_of(ctl.as_deref(), true);
        // Pings a third of the timeout apart (at most 5 s), so a page that is there answers at least
        // twice before the timeout runs out (six times at the default 30 s).
        let ping = (st.control_timeout / 3).min(Duration::from_secs(5));
        events::stream(req.into_writer(), events, ping);
        st.stream_of(ctl.as_deref(), false);
        return;
    }
    let response = match (method, path.as_str()) {
        (Method::Get, "/" | "/index.html") => {
            let mut r = Response::from_data(page.as_bytes().to_vec())
                .with_header(header("Content-Type", "text/html; charset=utf-8"))
                .with_header(header("Cache-Control", "no-store"))
                // Not framed by another site (clickjacking).
                .with_header(header("X-Frame-Options", "DENY"))
                .with_header(header("Content-Security-Policy", "frame-ancestors 'none'"));
            // Beyond loopback, the token given in the address becomes a cookie, so the report pages'
            // own relative links (which do not carry it) open too.
            if let Some(t) = token.as_deref().filter(|_| st.access.token.is_some()) {
                r = r.with_header(header(
                    "Set-Cookie",
                    &format!("scanrig_token={t}; HttpOnly; SameSite=Strict; Path=/"),
                ));
            }
            r.boxed()
        }
        // The report pages name no icon; the browser asks anyway.
        (Method::Get, "/favicon.ico") => Response::empty(204).boxed(),
        (Method::Get, "/api/state") => json_response(200, &st.state_json()),
        (Method::Get, "/api/calibration") => json_response(200, &calibration::describe(st)),
        (Method::Get, "/api/projects") => json_response(200, &projects::list(st)),
        (Method::Get, p) if p.starts_with("/files/") => match files(st, &p["/files".len()..]) {
            Ok(r) => r,
            Err(r) => error(r.status(), r.message()),
        },
        (Method::Get, "/api/live") => {
            if !st.controls(control.as_deref()) {
                error(409, "only the page that controls the rig takes live frames (they switch lasers and patterns)")
            } else {
                live::frame(st, &guard::query_value(&url, "show").unwrap_or_else(|| "raw".into()))
            }
        }
        (Method::Get, p) if p.starts_with("/api/calibrate/capture/") => calibration::picture(st, p),
        (Method::Post, _) if !same_origin(&req) => error(
            403,
            "refused: a control request must come from the station's own page (same origin, Content-Type application/json)",
        ),
        (Method::Post, "/api/control") => {
            let offered = body(&mut req).ok().and_then(|b| b["token"].as_str().map(str::to_string));
            match st.take_control(offered.as_deref()) {
                Ok(t) => {
                    st.bus.send("state", st.state_json());
                    json_response(200, &json!({ "token": t }))
                }
                Err((s, m)) => error(s, &m),
            }
        }
        (Method::Post, p) => {
            if !st.controls(control.as_deref()) {
                let why = if lock(&st.controller).is_some() {
                    "another operator controls the rig: this page is read-only"
                } else {
                    "take control first (the button at the top)"
                };
                error(409, why)
            } else {
                match body(&mut req) {
                    Err(e) => error(400, &e),
                    Ok(b) => post(st, p, &b),
                }
            }
        }
        _ => error(404, "not found"),
    };
    // A browser that went away mid-answer is not an error of ours.
    let _ = req.respond(response);
}

/// A control request's answer.
fn post(st: &Arc<Station>, path: &str, b: &Value) -> ResponseBox {
    let started = |r: Result<(), (u16, String)>| match r {
        Ok(()) => json_response(202, &json!({ "started": true })),
        Err((s, m)) => error(s, &m),
    };
    let done = |r: Result<Value, String>| match r {
        Ok(v) => json_response(200, &v),
        Err(m) => error(400, &m),
    };
    match path {
        // The controlling page's answer to a ping: it is there (`controls` noted the time).
        "/api/alive" => json_response(200, &json!({ "alive": true })),
        "/api/release" => {
            *lock(&st.controller) = None;
            st.bus.send("state", st.state_json());
            json_response(200, &json!({ "released": true }))
        }
        "/api/devices" => match st.exclusive("devices", || st.devices.choose(b)) {
            Ok(()) => json_response(200, &st.state_json()),
            Err((s, m)) => error(s, &m),
        },
        "/api/check" => started(st.start_job("check", None, check::run)),
        "/api/turntable" => match st.exclusive("manual", || devices::manual(st, b)) {
            Ok(v) => json_response(200, &v),
            Err((s, m)) => error(s, &m),
        },
        "/api/camera" => done(live::set_exposure(st, b)),
        "/api/projector" => match live::set_projector(st, b) {
            Ok(v) => json_response(200, &v),
            Err((s, m)) => error(s, &m),
        },
        "/api/fault/unplug" => done(st.devices.unplug().map(|_| json!({ "unplugged": true }))),
        "/api/scan" => match scan_job::request(st, b) {
            Ok((project, views)) => {
                let p = project.clone();
                started(st.start_job("scan", Some(project), move |st| scan_job::run(st, &p, views)))
            }
            Err(m) => error(400, &m),
        },
        "/api/scan/stop" => {
            if lock(&st.job).as_ref().is_some_and(|j| j.kind == "scan") {
                acquire::session::request_stop();
                json_response(202, &json!({ "stopping": true }))
            } else {
                error(409, "no scan runs")
            }
        }
        "/api/process" => match projects::name(b) {
            Ok(project) => {
                let p = project.clone();
                started(st.start_job("process", Some(project), move |st| process_job::run(st, &p)))
            }
            Err(m) => error(400, &m),
        },
        "/api/calibrate/capture" => match b["kind"].as_str() {
            Some(k @ ("held" | "sweep")) => {
                let kind = k.to_string();
                started(st.start_job("calibrate", None, move |st| calibration::capture(st, &kind)))
            }
            _ => error(400, &format!("kind: held or sweep, got {}", b["kind"])),
        },
        "/api/calibrate/review" => done(calibration::review(st, b)),
        "/api/calibrate/run" => started(st.start_job("calibrate", None, calibration::run)),
        "/api/calibrate/reset" => match st.exclusive("calibrate", || calibration::reset(st)) {
            Ok(v) => json_response(200, &v),
            Err((s, m)) => error(s, &m),
        },
        _ => error(404, "not found"),
    }
}

/// A file under the data folder: a project's report page, its downloads, its previews.
fn files(st: &Station, rel: &str) -> Result<ResponseBox, Refusal> {
    let path = guard::file_under(&st.data, rel)?;
    if !path.is_file() {
        return Err(Refusal::NotFound(format!("not a file: {rel}")));
    }
    let file = std::fs::File::open(&path).map_err(|e| Refusal::NotFound(format!("{rel}: {e}")))?;
    let kind = match path.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "json" => "application/json",
        "png" => "image/png",
        "glb" => "model/gltf-binary",
        _ => "application/octet-stream",
    };
    let mut r = Response::from_file(file).with_header(header("Content-Type", kind));
    if kind == "application/octet-stream" || kind == "model/gltf-binary" {
        // The name as printable ASCII (a header carries no more; the file keeps its own name).
        let printable = |c: char| if c.is_ascii_graphic() && c != '"' && c != '\\' { c } else { '_' };
        let name: String =
            path.file_name().map(|n| n.to_string_lossy().chars().map(printable).collect()).unwrap_or_default();
        r = r.with_header(header("Content-Disposition", &format!("attachment; filename=\"{name}\"")));
    }
    Ok(r.boxed())
}

/// True for a POST the station's own page could have sent: a JSON body (a form or a no-cors fetch
/// from another site cannot say `application/json` without a preflight the station never answers),
/// and no Origin or Sec-Fetch-Site naming another site.
fn same_origin(req: &Request) -> bool {
    let json = header_value(req, "Content-Type")
        .is_some_and(|t| t.trim().to_ascii_lowercase().starts_with("application/json"));
    let site_ok = header_value(req, "Sec-Fetch-Site").is_none_or(|s| s == "same-origin" || s == "none");
    let origin_ok = match (header_value(req, "Origin"), header_value(req, "Host")) {
        (None, _) => true,
        (Some(o), Some(h)) => o.strip_prefix("http://").is_some_and(|rest| rest == h),
        (Some(_), None) => false,
    };
    json && site_ok && origin_ok
}
