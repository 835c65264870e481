//! Reading the single-stage subcommands' input files: what a reader could not keep is printed as a
//! warning naming the file (`rig::Reported`), never dropped in silence.

use std::path::Path;

fn warn(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// A point cloud by its extension, its reader's warnings printed.
pub fn read_cloud(path: &Path) -> Result<rig::PointCloud, rig::Error> {
    let read = rig::read_cloud_reported(path)?;
    warn(&read.warnings);
    Ok(read.value)
}

/// A polygon mesh by its extension, its reader's warnings printed.
pub fn read_mesh(path: &Path) -> Result<rig::PolyMesh, rig::Error> {
    let read = rig::read_mesh_reported(path)?;
    warn(&read.warnings);
    Ok(read.value)
}
