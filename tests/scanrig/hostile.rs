//! Issue 37: the hostile user. Every subcommand is run with generated option values (0, negative,
//! NaN, ±inf, 1e300, u64::MAX, u32::MAX + 1) and with inputs that are missing, empty, folders, FIFOs,
//! links to /dev/zero, garbage, or the output itself — each run under a time limit, asserting:
//! - never a panic, an abort, a signal or a hang;
//! - exit ≠ 0 ⇒ the message names the option or the file;
//! - exit 0 ⇒ every output named exists and is not empty;
//! - either way, every file that was there before is byte for byte as it was, and nothing appeared
//!   outside the run's output paths.
//!
//! It prints how many cases it tried. Each defect of issue 37 that is about options or inputs is one of
//! its cases; a deliberately removed check (for example `FuseParams::validate`'s upper bound) fails it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Values for every numeric option: each is either refused naming the option, or run to a result.
const VALUES: [&str; 9] = ["0", "-1", "NaN", "inf", "-inf", "1e300", "18446744073709551615", "4294967296", "1e-300"];

/// No command may take longer than this on a fixture this small (the limit is 60 s).
const LIMIT: Duration = Duration::from_secs(60);

/// One run: arguments (relative to the case's folder), the option or file its refusal must name, and
/// the paths it may write (files or folders, relative).
struct Case {
    args: Vec<String>,
    names: Vec<String>,
    outputs: Vec<String>,
}

fn case(args: &str, names: &[&str], outputs: &[&str]) -> Case {
    Case {
        args: args.split_whitespace().map(str::to_string).collect(),
        names: names.iter().map(|s| s.to_string()).collect(),
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
    }
}

/// A file's inode, length and last change: a fixture file hard-linked into a case and never written
/// keeps all of them.
type Stamp = (u64, u64, i64, i64);

/// What a snapshot holds of each file: its stamp and its bytes' hash (FIFOs and links: their name).
type Seen = BTreeMap<PathBuf, (Stamp, u64)>;

/// Every file under `root` and its bytes' hash. A file whose stamp is the one `known` has for its path
/// is not read again: the cases' fixtures are hard links of one tree, so only what a run wrote (a new
/// inode or a new time of change) is hashed anew.
fn snapshot(root: &Path, known: &Seen) -> Seen {
    use std::hash::{Hash, Hasher};
    use std::os::unix::fs::MetadataExt;
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            let Ok(t) = e.file_type() else { continue };
            let rel = p.strip_prefix(root).unwrap().to_path_buf();
            if t.is_dir() {
                stack.push(p);
            } else if t.is_file() {
                let Ok(m) = e.metadata() else { continue };
                let stamp = (m.ino(), m.len(), m.mtime(), m.mtime_nsec());
                let hash = match known.get(&rel) {
                    Some((s, h)) if *s == stamp => *h,
                    _ => {
                        let mut h = std::collections::hash_map::DefaultHasher::new();
                        std::fs::read(&p).unwrap_or_default().hash(&mut h);
                        h.finish()
                    }
                };
                out.insert(rel, (stamp, hash));
            } else {
                // A FIFO or a link: its name only (reading a FIFO would block).
                out.insert(rel, ((0, 0, 0, 0), 0));
            }
        }
    }
    out
}

/// The fixtures for one case: hard links of every file (cheap, and a write in place shows in the
/// stamps), real copies under the case's outputs, where a run may write into what is there.
fn link_tree(from: &Path, to: &Path, rel: &Path, outputs: &[String]) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let (src, dst, rel) = (e.path(), to.join(e.file_name()), rel.join(e.file_name()));
        let t = e.file_type().unwrap();
        if t.is_dir() {
            link_tree(&src, &dst, &rel, outputs);
        } else if t.is_file() && outputs.iter().any(|o| rel.starts_with(o)) {
            std::fs::copy(&src, &dst).unwrap();
        } else {
            // Files, FIFOs and symbolic links alike (a FIFO cannot be copied; a link to a link is one).
            std::fs::hard_link(&src, &dst).unwrap();
        }
    }
}

/// Runs `scanrig ARGS` in `dir` under [`LIMIT`]; `None` when it had to be killed.
fn run_limited(dir: &Path, args: &[String]) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_scanrig"))
        .args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read stderr on a thread: a chatty child must not block on a full pipe.
    let mut pipe = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut pipe, &mut s);
        s
    });
    let start = Instant::now();
    // Most runs refuse within milliseconds: look again soon at first, then every 20 ms.
    let mut pause = Duration::from_millis(1);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return Some((status.code(), reader.join().unwrap()));
        }
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(pause);
        pause = (pause * 2).min(Duration::from_millis(20));
    }
}

/// What is wrong with one run, if anything.
fn judge(dir: &Path, c: &Case, before: &Seen) -> Option<String> {
    let Some((code, err)) = run_limited(dir, &c.args) else {
        return Some(format!("did not finish within {} s", LIMIT.as_secs()));
    };
    for sign in ["panicked", "stack backtrace", "internal error", "memory allocation of"] {
        if err.contains(sign) {
            return Some(format!("printed `{sign}`: {err}"));
        }
    }
    let inside_output = |p: &Path| c.outputs.iter().any(|o| p.starts_with(o));
    let after = snapshot(dir, before);
    for (p, (_, h)) in before {
        match after.get(p) {
            Some((_, a)) if a == h => {}
            Some(_) if inside_output(p) => {}
            None if inside_output(p) => {}
            _ => return Some(format!("{} changed or vanished (exit {code:?}): {err}", p.display())),
        }
    }
    if let Some(p) = after.keys().find(|p| !before.contains_key(*p) && !inside_output(p)) {
        return Some(format!("wrote {} outside its outputs (exit {code:?})", p.display()));
    }
    match code {
        Some(0) => {
            for o in &c.outputs {
                let p = dir.join(o);
                let empty = if p.is_dir() {
                    !after.keys().any(|k| k.starts_with(o))
                } else {
                    std::fs::metadata(&p).map_or(true, |m| m.len() == 0)
                };
                if empty {
                    return Some(format!("exit 0 but output {o} is missing or empty"));
                }
                if let Some(why) = implausible(&c.args[0], &p) {
                    return Some(format!("exit 0 but output {o} {why}"));
                }
            }
            None
        }
        Some(1) | Some(2) => (!c.names.iter().any(|n| err.contains(n.as_str())))
            .then(|| format!("refused without naming {:?}: {err}", c.names)),
        other => Some(format!("exit {other:?} (a signal or an abort): {err}")),
    }
}

/// Why a result file of `command` cannot be right, if it cannot: a mesh without faces, a cloud
/// without points, a scan folder without a complete view.
fn implausible(command: &str, path: &Path) -> Option<String> {
    let is = |ext: &str| path.extension().is_some_and(|e| e == ext);
    match command {
        "reconstruct" | "remesh" if is("ply") || is("obj") => match rig::read_mesh(path) {
            Ok(m) if m.face_count() > 0 => None,
            Ok(_) => Some("has no faces".into()),
            Err(e) => Some(format!("cannot be read back: {e}")),
        },
        "fuse" | "denoise" | "align" if is("ply") => match rig::read_cloud(path) {
            Ok(c) if !c.positions.is_empty() => None,
            Ok(_) => Some("has no points".into()),
            Err(e) => Some(format!("cannot be read back: {e}")),
        },
        "calibrate" if is("toml") => match rig::Rig::read(path) {
            Ok(_) => None,
            Err(e) => Some(format!("cannot be read back: {e}")),
        },
        "sim" | "scan" | "import" if path.is_dir() => match rig::Manifest::read(path) {
            Ok(m) if m.views.iter().all(|v| v.complete) => None,
            Ok(_) => Some("holds incomplete views".into()),
            Err(e) => Some(format!("is not a scan folder: {e}")),
        },
        _ => None,
    }
}

/// A sphere of `n` points with outward normals, radius 20 (mm).
fn sphere_cloud(n: usize) -> rig::PointCloud {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut cloud = rig::PointCloud::default();
    let mut normals = Vec::new();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let a = golden * i as f64;
        let d = rig::Vector3::new(r * a.cos(), r * a.sin(), z);
        cloud.positions.push(rig::Point3::from(d * 20.0));
        normals.push(d);
    }
    cloud.normals = Some(normals);
    cloud
}

/// Builds the fixtures once: a cloud, a mesh, a range grid and a small simulated scan.
fn fixtures_dir() -> PathBuf {
    let d = fixtures::temp_dir("hostile-fixtures");
    let root = d.path().to_path_buf();
    std::mem::forget(d);
    rig::write_cloud(&root.join("cloud.ply"), &sphere_cloud(3000), &Default::default()).unwrap();
    let scan = root.join("scan");
    let sim = run_limited(
        &root,
        &["sim", "--views", "2", "--resolution", "160x128", "--no-truth", "--out", "scan"].map(String::from),
    );
    assert_eq!(sim.as_ref().map(|s| s.0), Some(Some(0)), "{sim:?}");
    let tri = run_limited(&root, &["process", "scan", "--until", "triangulate", "--out", "p"].map(String::from));
    assert_eq!(tri.as_ref().map(|s| s.0), Some(Some(0)), "{tri:?}");
    std::fs::copy(root.join("p/views/view_000.ply"), root.join("grid.ply")).unwrap();
    std::fs::remove_dir_all(root.join("p")).unwrap();
    // The first view's frames re-filed as OpenCV's GrayCodePattern writes them (Gray codes, then
    // white and black), for `decode`.
    let m = rig::Manifest::read(&scan).unwrap();
    let frames = &m.views[0].frames;
    let order = frames
        .iter()
        .filter(|f| matches!(f.pattern, rig::Pattern::Gray { .. }))
        .chain(frames.iter().filter(|f| f.pattern == rig::Pattern::White))
        .chain(frames.iter().filter(|f| f.pattern == rig::Pattern::Black));
    std::fs::create_dir(root.join("graycode")).unwrap();
    for (k, f) in order.enumerate() {
        std::fs::copy(scan.join(&f.file), root.join(format!("graycode/graycode_{k:02}.png"))).unwrap();
    }
    // Calibration captures (three held board poses) and a laser scan in FabScanPi's layout, for
    // `calibrate` and `import`.
    let board = run_limited(
        &root,
        &["sim", "--config", "laser", "--board", "7x5", "--square", "11", "--poses", "3", "--resolution", "320x240"]
            .into_iter()
            .chain(["--no-truth", "--out", "calib"])
            .map(String::from)
            .collect::<Vec<_>>(),
    );
    assert_eq!(board.as_ref().map(|s| s.0), Some(Some(0)), "{board:?}");
    let laser = run_limited(
        &root,
        &["sim", "--config", "laser", "--views", "4", "--resolution", "160x120", "--no-truth", "--layout", "fabscan"]
            .into_iter()
            .chain(["--out", "lscan"])
            .map(String::from)
            .collect::<Vec<_>>(),
    );
    assert_eq!(laser.as_ref().map(|s| s.0), Some(Some(0)), "{laser:?}");
    let rec = run_limited(&root, &["reconstruct", "cloud.ply", "-o", "mesh.ply", "--depth", "6"].map(String::from));
    assert_eq!(rec.as_ref().map(|s| s.0), Some(Some(0)), "{rec:?}");
    assert!(scan.join("scan.json").is_file());
    root
}

fn option_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let each = |cases: &mut Vec<Case>, template: &str, option: &str, outputs: &[&str]| {
        for v in VALUES {
            let args = template.replace("{v}", v);
            cases.push(case(&args, &[option], outputs));
        }
    };
    each(&mut cases, "fuse cloud.ply -o out.ply --k {v}", "--k", &["out.ply"]);
    // A sphere onto itself is refused as ambiguous (naming the files) unless forced; every spacing
    // is refused by name or runs.
    each(&mut cases, "align cloud.ply hardlink.ply -o out.ply --force --voxel {v}", "--voxel", &["out.ply"]);
    each(&mut cases, "sim --out passes --views 2 --resolution 64x48 --passes {v}", "--passes", &["passes"]);
    for o in ["--depth", "--smoothing-cells", "--memory-budget", "--trim"] {
        each(&mut cases, &format!("reconstruct cloud.ply -o out.ply {o} {{v}}"), o, &["out.ply"]);
    }
    for o in ["--depth", "--error", "--samples-per-cell"] {
        each(&mut cases, &format!("reconstruct cloud.ply -o out.ply --method adfft {o} {{v}}"), o, &["out.ply"]);
    }
    // Depths that hung or ran out of memory (issue 37): refused or finished within the limit.
    for depth in ["10", "11", "12"] {
        cases.push(case(
            &format!("reconstruct cloud.ply -o out.ply --method adfft --depth {depth}"),
            &["--depth"],
            &["out.ply"],
        ));
    }
    cases.push(case(
        "reconstruct cloud.ply -o out.ply --depth 10 --memory-budget 1",
        &["--depth", "--memory-budget"],
        &["out.ply"],
    ));
    cases.push(case("remesh mesh.ply -o out.obj --spacing 0.01", &["--spacing"], &["out.obj"]));
    // The demo: its views, and a stage to stop at that leaves nothing to measure the accuracy on
    // (refused before it simulates).
    each(&mut cases, "demo --views {v} --until triangulate --out d", "--views", &["d"]);
    for stage in ["decode", "nothing"] {
        cases.push(case(&format!("demo --views 1 --until {stage} --out d"), &["--until"], &["d"]));
    }
    // Values of issue 37 that left nothing, or were refused only after minutes of earlier stages.
    cases.push(case("reconstruct cloud.ply -o out.ply --trim 1e-9", &["--trim"], &["out.ply"]));
    cases.push(case("remesh mesh.ply -o out.obj --spacing 1e6", &["--spacing"], &["out.obj"]));
    cases.push(case("fuse cloud.ply -o out.ply --k 2999", &["--k"], &["out.ply"]));
    for (o, v) in [("--crop-radius", "0.001"), ("--crop-min-height", "1e9"), ("--depth", "30"), ("--k", "100000")] {
        cases.push(case(
            &format!("process scan --until merge --out scan/processed {o} {v}"),
            &[o],
            &["scan/processed"],
        ));
    }
    for o in ["--spacing", "--features", "--weight"] {
        each(&mut cases, &format!("remesh mesh.ply -o out.obj {o} {{v}}"), o, &["out.obj"]);
    }
    for o in ["--window", "--patch", "--iterations", "--temporal"] {
        each(&mut cases, &format!("denoise grid.ply -o out.ply {o} {{v}}"), o, &["out.ply"]);
    }
    each(&mut cases, "sim --views 2 --resolution 64x48 --no-truth --out s --size {v}", "--size", &["s"]);
    each(&mut cases, "sim --views 2 --resolution 64x48 --no-truth --out s --offset {v},0,0", "--offset", &["s"]);
    each(&mut cases, "sim --views {v} --resolution 64x48 --no-truth --out s", "--views", &["s"]);
    for o in ["--gray-fit-radius", "--shadow-threshold", "--bit-threshold"] {
        let args = format!("decode graycode --projector 1024x768 -o out.npy {o} {{v}}");
        each(&mut cases, &args, o, &["out.npy", "out.preview.png"]);
    }
    each(&mut cases, "decode graycode --projector {v}x768 -o out.npy", "--projector", &["out.npy", "out.preview.png"]);
    for o in [
        "--crop-radius",
        "--crop-min-height",
        "--depth",
        "--k",
        "--max-correction-deg",
        "--max-correction-mm",
        "--spacing",
        "--shadow-threshold",
        "--gray-fit-radius",
    ] {
        each(&mut cases, &format!("process scan --until merge --out scan/processed {o} {{v}}"), o, &["scan/processed"]);
    }
    // Calibration: each value refused before an image is read, or a calibration that reads back.
    // Three poses support no k3: the lens model chosen from the views holds it (issue 39).
    let calibrate = "calibrate camera calib -o rig.toml --board 7x5";
    each(
        &mut cases,
        &format!("{calibrate} --square {{v}}"),
        "--square",
        &["rig.toml", "rig.report.json", "rig.report.html"],
    );
    each(
        &mut cases,
        &format!("{calibrate} --corner-height {{v}}"),
        "--corner-height",
        &["rig.toml", "rig.report.json", "rig.report.html"],
    );
    each(&mut cases, "calibrate camera calib -o rig.toml --fix-k3 --board {v}x5", "--board", &["rig.toml"]);
    each(&mut cases, &format!("{calibrate} --lens-model {{v}}"), "--lens-model", &["rig.toml"]);
    // A ChArUco board's description: every length and the dictionary through the same parser.
    for field in ["square={v}:marker=7", "square=10:marker={v}"] {
        let board = format!("charuco:11x9:{field}:dict=4x4_50");
        each(&mut cases, &format!("calibrate camera calib -o rig.toml --board {board}"), "--board", &["rig.toml"]);
    }
    each(
        &mut cases,
        &format!("{calibrate} --projector {{v}}x768"),
        "--projector",
        &["rig.toml", "rig.report.json", "rig.report.html"],
    );
    // Importing a FabScanPi scan: the step between positions.
    let fabscan = "import fabscan lscan/fabscan/sim --config lscan/fabscan/config.json -o imported";
    each(&mut cases, &format!("{fabscan} --step-deg {{v}}"), "--step-deg", &["imported"]);
    // … as a further pass of a scan (issue 40): the pass, and a scan folder that is not there.
    each(&mut cases, &format!("{fabscan} --step-deg 90 --pass {{v}}"), "--pass", &["imported"]);
    each(&mut cases, "scan --out s --views 2 --resolution 64x48 --pass {v}", "--pass", &["s"]);
    // A scan on the simulated rig: its program's options.
    each(&mut cases, "scan --out s --views {v} --resolution 64x48", "--views", &["s"]);
    each(&mut cases, "scan --out s --views 2 --resolution 64x48 --settle-ms {v}", "--settle-ms", &["s"]);
    each(&mut cases, "scan --out s --views 2 --resolution 64x48 --size {v}", "--size", &["s"]);
    // The station (issue 41): checked, bound and stopped at once (--seconds 0); it writes no file
    // (its data folder is made, empty).
    // --projector-monitor: refused by name where no display or monitor is (CI), or opened and closed.
    for o in ["--square", "--token", "--board", "--resolution", "--control-timeout", "--projector-monitor"] {
        each(&mut cases, &format!("serve --seconds 0 --port 0 --data d {o} {{v}}"), o, &[]);
    }
    each(&mut cases, "serve --seconds 0 --data d --port {v}", "--port", &[]);
    each(&mut cases, "serve --seconds {v} --port 0 --data d", "--seconds", &[]);
    each(&mut cases, "serve --seconds 0 --port 0 --data d --bind {v}", "--bind", &[]);
    cases
}

fn input_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for (name, kind) in [
        ("missing.ply", "missing"),
        ("empty.ply", "empty"),
        ("folder.ply", "folder"),
        ("fifo.ply", "fifo"),
        ("zero.ply", "/dev/zero"),
        ("garbage.ply", "garbage"),
    ] {
        let _ = kind;
        cases.push(case(&format!("fuse {name} -o out.ply"), &[name], &["out.ply"]));
        cases.push(case(&format!("reconstruct {name} -o out.ply"), &[name], &["out.ply"]));
        cases.push(case(&format!("remesh {name} -o out.obj"), &[name], &["out.obj"]));
        cases.push(case(&format!("convert {name} out.obj"), &[name], &["out.obj"]));
        cases.push(case(&format!("info {name}"), &[name], &[]));
        cases.push(case(&format!("align {name} cloud.ply -o out.ply"), &[name], &["out.ply"]));
        cases.push(case(&format!("align cloud.ply {name} -o out.ply"), &[name], &["out.ply"]));
        cases.push(case(&format!("calibrate camera {name} -o rig.toml --board 7x5"), &[name], &["rig.toml"]));
        cases.push(case(&format!("import horus {name} -o rig.toml"), &[name], &["rig.toml"]));
        cases.push(case(&format!("import fabscan {name} -o rig.toml"), &[name], &["rig.toml"]));
        // The scanner's own file an export is laid over: read, never written.
        for scanner in ["fabscan", "horus"] {
            cases.push(case(
                &format!("export {scanner} lscan/rig.toml --into {name} -o out.json"),
                &[name],
                &["out.json"],
            ));
        }
    }
    cases.push(case("export fabscan lscan/rig.toml --into cloud.ply -o out.json", &["cloud.ply"], &["out.json"]));
    let into = "lscan/fabscan/config.json";
    cases.push(case(&format!("export fabscan lscan/rig.toml --into {into} -o {into}"), &["config.json"], &[]));
    cases.push(case("export fabscan lscan/rig.toml -o lscan/rig.toml", &["rig.toml"], &[]));
    // An output that is the input, another name for it, or inside the scan it reads.
    cases.push(case("fuse cloud.ply -o cloud.ply", &["cloud.ply"], &[]));
    cases.push(case("fuse cloud.ply -o hardlink.ply", &["hardlink.ply"], &[]));
    cases.push(case("fuse cloud.ply -o out.ply --outliers cloud.ply", &["cloud.ply"], &["out.ply"]));
    cases.push(case("remesh mesh.ply -o mesh.ply", &["mesh.ply"], &[]));
    cases.push(case("align cloud.ply mesh.ply -o mesh.ply", &["mesh.ply"], &[]));
    cases.push(case("align cloud.ply mesh.ply -o out.ply --pose cloud.ply", &["cloud.ply"], &["out.ply"]));
    cases.push(case("align cloud.ply hardlink.ply -o out.ply", &["cloud.ply"], &["out.ply"]));
    cases.push(case("convert cloud.ply cloud.ply", &["cloud.ply"], &[]));
    cases.push(case("reconstruct cloud.ply -o cloud.ply", &["cloud.ply"], &[]));
    cases.push(case("denoise grid.ply -o grid.ply", &["grid.ply"], &[]));
    cases.push(case("decode graycode --projector 1024x768 -o graycode/graycode_00.npy", &["graycode"], &[]));
    cases.push(case("decode graycode --projector 1024x768 -o map.png", &["--out"], &[]));
    cases.push(case("decode fifo.ply --projector 1024x768 -o out.npy", &["fifo.ply"], &[]));
    cases.push(case("process scan --until merge --out scan", &["--out"], &[]));
    cases.push(case("process scan --until merge --out scan/frames/view_000", &["--out"], &[]));
    cases.push(case("process scan --until merge --out .", &["--out"], &[]));
    cases.push(case("calibrate camera calib -o calib/rig.toml --board 7x5", &["calib"], &[]));
    cases.push(case("calibrate camera calib -o cloud.ply --board 7x5 --yaml cloud.ply", &["cloud.ply"], &[]));
    cases.push(case("import fabscan lscan/fabscan/sim --step-deg 90 -o lscan", &["lscan"], &[]));
    cases.push(case("sim --out scan --views 2 --resolution 64x48", &["scan"], &[]));
    // The scan's own files replaced by what a user's mistake or a hostile folder holds.
    cases.push(case("process fifo-scan --until merge", &["scan.json"], &["fifo-scan/processed"]));
    cases
}

/// The hostile inputs, made in a case's folder.
fn plant_inputs(dir: &Path) {
    std::fs::write(dir.join("empty.ply"), b"").unwrap();
    std::fs::create_dir(dir.join("folder.ply")).unwrap();
    let fifo = Command::new("mkfifo").arg(dir.join("fifo.ply")).status();
    assert!(fifo.is_ok_and(|s| s.success()), "mkfifo");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.ply")).unwrap();
    std::fs::write(dir.join("garbage.ply"), b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\n")
        .unwrap();
    std::fs::hard_link(dir.join("cloud.ply"), dir.join("hardlink.ply")).unwrap();
    let fifo_scan = dir.join("fifo-scan");
    std::fs::create_dir(&fifo_scan).unwrap();
    std::fs::copy(dir.join("scan/rig.toml"), fifo_scan.join("rig.toml")).unwrap();
    let fifo = Command::new("mkfifo").arg(fifo_scan.join("scan.json")).status();
    assert!(fifo.is_ok_and(|s| s.success()), "mkfifo");
}

#[test]
fn every_subcommand_refuses_hostile_options_and_inputs_by_name_and_keeps_every_file() {
    if Command::new("mkfifo").arg("--version").output().is_err() {
        eprintln!("SKIPPED hostile-user harness: no mkfifo on this machine");
        return;
    }
    let fixtures = fixtures_dir();
    // Planted once: every case gets hard links of them with the rest.
    plant_inputs(&fixtures);
    let reference = snapshot(&fixtures, &BTreeMap::new());
    let cases: Vec<Case> = option_cases().into_iter().chain(input_cases()).collect();
    let mut failures = Vec::new();
    let (mut refused, mut ran) = (0, 0);
    let start = Instant::now();
    for (i, c) in cases.iter().enumerate() {
        let dir = fixtures.with_file_name(format!("{}-case{i}", fixtures.file_name().unwrap().to_string_lossy()));
        link_tree(&fixtures, &dir, Path::new(""), &c.outputs);
        let before = snapshot(&dir, &reference);
        match judge(&dir, c, &before) {
            Some(why) => failures.push(format!("`scanrig {}`: {why}", c.args.join(" "))),
            None if c.outputs.iter().any(|o| dir.join(o).exists()) => ran += 1,
            None => refused += 1,
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    let _ = std::fs::remove_dir_all(&fixtures);
    let summary = format!(
        "hostile-user harness: {} cases ({ran} ran to a result, {refused} refused by name, {} failed) in {:.0} s",
        cases.len(),
        failures.len(),
        start.elapsed().as_secs_f64()
    );
    println!("{summary}");
    // cargo test hides a passing test's output: .ci/run prints this file after the tests.
    let _ = std::fs::write(Path::new(env!("CARGO_TARGET_TMPDIR")).join("hostile-summary.txt"), format!("{summary}\n"));
    assert!(
        failures.is_empty(),
        "{} of {} hostile cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
