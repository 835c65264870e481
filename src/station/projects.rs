//! The projects under `--data`: each scan folder, how far it got, and its report.

use super::Station;
use super::process_job::DOWNLOADS;
use serde_json::{Value, json};

/// A project's name from a request's `project`: letters, digits, `-` and `_`, 1 to 64 of them, so
/// it is a folder directly under `--data` and nothing else.
pub fn name(b: &Value) -> Result<String, String> {
    let n = b["project"].as_str().unwrap_or("").trim();
    if n.is_empty() || n.len() > 64 || !n.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'-' || c == b'_') {
        return Err(format!(
            "project: {n:?} is not a project name (1 to 64 letters, digits, - or _; it becomes a folder under --data)"
        ));
    }
    Ok(n.to_string())
}

/// Every scan folder under `--data`, by name: views complete of planned, processed or not, links.
pub fn list(st: &Station) -> Value {
    let mut projects = Vec::new();
    let mut entries: Vec<_> = std::fs::read_dir(&st.data).map(|d| d.flatten().collect()).unwrap_or_default();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let dir = e.path();
        let Some(name) = dir.file_name().and_then(|n| n.to_str()).map(str::to_string) else { continue };
        if name == "calibration" || !dir.join("scan.json").is_file() || name.starts_with('.') {
            continue;
        }
        let (complete, total, state) = match rig::Manifest::read(&dir) {
            Ok(m) => {
                let c = m.views.iter().filter(|v| v.complete).count();
                let t = m.views.len();
                (c, t, if c < t { "incomplete: Start resumes it" } else { "captured" })
            }
            Err(_) => (0, 0, "unreadable scan.json"),
        };
        let processed = dir.join("processed/report.html").is_file();
        let downloads: Vec<Value> = DOWNLOADS
            .iter()
            .filter(|(f, _)| dir.join("processed").join(f).is_file())
            .map(|(f, what)| json!({"name": f, "what": what, "href": format!("/files/{name}/processed/{f}")}))
            .collect();
        projects.push(json!({
            "name": name,
            "complete": complete,
            "total": total,
            "state": if processed { "processed" } else { state },
            "report": processed.then(|| format!("/files/{name}/processed/report.html")),
            "downloads": downloads,
        }));
    }
    json!({ "projects": projects })
}
