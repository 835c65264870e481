//! Processing a project from the station: `scanrig process SCAN` with its defaults (the options
//! parsed by the command line's own parser, so the station's mesh is the command's), each stage's
//! progress on the event stream, then the report page and the downloads.

use super::Station;
use crate::cli::{Args, Command};
use anyhow::{Context, Result, bail};
use clap::Parser;
use serde_json::json;
use std::sync::Arc;

/// The files a processed project offers for download, where they were made: name, what it is.
pub const DOWNLOADS: [(&str, &str); 5] = [
    ("mesh.ply", "mesh, PLY"),
    ("mesh.stl", "mesh, STL"),
    ("mesh.glb", "mesh, glTF binary"),
    ("fused.e57", "point cloud, E57"),
    ("fused.ply", "point cloud, PLY"),
];

/// Processes `project` into its `processed/` folder.
pub fn run(st: &Arc<Station>, project: &str) -> Result<()> {
    let scan = st.data.join(project);
    if !scan.join("scan.json").is_file() {
        bail!("{project} holds no scan (no scan.json): scan it first");
    }
    let out = scan.join("processed");
    // `scanrig process SCAN`, word for word.
    let args = Args::try_parse_from(["scanrig".as_ref(), "process".as_ref(), scan.as_os_str()])
        .context("the command line's defaults")?;
    let Command::Process(args) = args.command else { bail!("not a process command") };
    let params = crate::process_cmd::params(&args)?;
    params.validate()?;
    crate::process_cmd::guard_folders(&scan, &out)?;
    let bus = &st.bus;
    let mut last = (None, 0usize);
    let (report, page) = crate::process_cmd::run_pipeline_watched(&scan, &out, &params, |stage, done, total| {
        // One event per stage step: the page redraws a bar, no more often than the work moves.
        if last != (Some(stage), done) {
            last = (Some(stage), done);
            bus.send("stage", json!({"project": project, "stage": stage.name(), "done": done, "total": total}));
        }
    })?;
    // E57 for the tools that read scans (CloudCompare, the survey suites): the fused cloud.
    let fused = out.join(process::pipeline::layout::FUSED);
    if fused.is_file() {
        let cloud = rig::ply::read_cloud(&fused)?;
        rig::e57::write_cloud(&out.join("fused.e57"), &cloud)?;
    }
    let downloads: Vec<_> = DOWNLOADS
        .iter()
        .filter(|(name, _)| out.join(name).is_file())
        .map(|(name, what)| json!({"name": name, "what": what, "href": format!("/files/{project}/processed/{name}")}))
        .collect();
    st.bus.send(
        "processed",
        json!({
            "project": project,
            "report": page.map(|_| format!("/files/{project}/processed/report.html")),
            "warnings": report.warnings,
            "downloads": downloads,
            "seconds": report.total_seconds,
        }),
    );
    Ok(())
}
