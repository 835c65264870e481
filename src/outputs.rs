//! What the single-stage subcommands share about their outputs: refusing output paths that would
//! overwrite each other or the input, writing with the input's units, and the `--json` envelope.

use anyhow::{Result, bail};
use std::path::Path;

/// Fails when a named output path is a folder (or ends in `/`) where a file is wanted, or two of them
/// are the same file (a result would be lost) — checked before any work starts.
pub fn distinct(outputs: &[(&str, Option<&Path>)]) -> Result<()> {
    let given: Vec<(&str, &Path)> = outputs.iter().filter_map(|(n, p)| p.map(|p| (*n, p))).collect();
    for (name, p) in &given {
        if p.is_dir() || p.as_os_str().to_string_lossy().ends_with('/') {
            bail!(
                "{name} {} is a folder; give the file to write (for example {})",
                p.display(),
                p.join("out").display()
            );
        }
    }
    for (i, (a, pa)) in given.iter().enumerate() {
        for (b, pb) in &given[i + 1..] {
            if same_file(pa, pb) {
                bail!("{a} and {b} name the same file, {}: one result would overwrite the other", pa.display());
            }
        }
    }
    Ok(())
}

/// [`distinct`], every output's folder exists, and no output is one of the run's `inputs` (files,
/// or folders whose contents the run reads) nor inside an input folder — checked before any work
/// starts. The same rules hold again
/// at every write ([`rig::run_files`]); this says so before minutes of work are spent.
pub fn plan(inputs: &[(&str, &Path)], outputs: &[(&str, Option<&Path>)]) -> Result<()> {
    distinct(outputs)?;
    for (name, out) in outputs.iter().filter_map(|(n, p)| p.map(|p| (*n, p))) {
        // A missing folder had failed only at the write, after the work, naming a temporary file.
        if let Some(folder) = out.parent().filter(|d| !d.as_os_str().is_empty() && !d.is_dir()) {
            bail!(
                "{name} {}: the folder {} does not exist; create it first, or give a path in an existing folder",
                out.display(),
                folder.display()
            );
        }
        for (what, input) in inputs {
            if same_file(out, input) {
                bail!(
                    "{name} {} is the input {what}: writing it would replace the data it is made from; give another \
                     file",
                    out.display()
                );
            }
            let inside = input.is_dir()
                && input.canonicalize().ok().zip(canonical(out)).is_some_and(|(dir, o)| o.starts_with(dir));
            if inside {
                bail!(
                    "{name} {} is inside the input folder {what} ({}): the run reads that folder, so its results \
                     go elsewhere",
                    out.display(),
                    input.display()
                );
            }
        }
    }
    Ok(())
}

fn canonical(p: &Path) -> Option<std::path::PathBuf> {
    let parent = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    parent.canonicalize().ok().map(|d| d.join(p.file_name().unwrap_or_default()))
}

/// The same file: one spelling, one canonical path, or one inode (a hard link).
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let inode = |p: &Path| std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()));
    a == b
        || matches!((canonical(a), canonical(b)), (Some(x), Some(y)) if x == y)
        || matches!((inode(a), inode(b)), (Some(x), Some(y)) if x == y)
}

/// [`rig::write_cloud`] of a user's output, then a warning for each thing its format cannot hold
/// ([`rig::cloud_losses`]: confidence and views in OBJ, glTF, E57).
pub fn write_cloud(path: &Path, cloud: &rig::PointCloud, opts: &rig::ply::WriteOptions) -> Result<()> {
    rig::write_cloud(path, cloud, opts)?;
    for w in rig::cloud_losses(path, cloud) {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// [`rig::write_mesh`] of a user's output, then a warning for each thing its format cannot hold
/// ([`rig::mesh_losses`]: quads in STL and glTF, colours in STL).
pub fn write_mesh(path: &Path, mesh: &rig::PolyMesh, opts: &rig::ply::WriteOptions) -> Result<()> {
    rig::write_mesh(path, mesh, opts)?;
    for w in rig::mesh_losses(path, mesh) {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// Write options that keep the input's units (a PLY `comment units …`).
pub fn write_options_like(input: &Path) -> Result<rig::ply::WriteOptions> {
    let mut opts = rig::ply::WriteOptions::default();
    // The data's unit as the input gives it (a PLY's or an OBJ's comment; E57 and glTF are read in
    // millimetres), so every format written from them keeps it.
    if let Some(u) = rig::data_units(input)? {
        opts = opts.with_units(&u);
    }
    if rig::MeshFormat::of(input) == Some(rig::MeshFormat::Ply) {
        let header = rig::ply::read_header(input)?;
        // Still in a turntable's object frame: the output says so as the input did.
        if rig::ply::in_turntable_frame(&header) {
            opts.comments.push(rig::ply::TURNTABLE_FRAME.into());
        }
    }
    Ok(opts)
}

/// A `--json` report with the schema version every scanrig JSON output carries.
pub fn versioned(report: &impl serde::Serialize) -> serde_json::Value {
    let mut v = serde_json::to_value(report).expect("reports serialise");
    let version = serde_json::json!(process::pipeline::REPORT_SCHEMA_VERSION);
    match &mut v {
        serde_json::Value::Object(map) => {
            map.insert("schema_version".into(), version);
            v
        }
        _ => serde_json::json!({ "schema_version": version, "report": v }),
    }
}
