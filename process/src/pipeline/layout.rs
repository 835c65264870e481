//! The processed folder's layout: every path `process` writes, in one place, so the pipeline, the
//! single-stage subcommands and the records agree on names.
//!
//! ```text
//! stages.json                  how each output was made (see `records`): reuse is decided there
//! decode/view_NNN.npy          structured light: (H, W, 3) projector u, v, confidence (NaN undecoded)
//! views/view_NNN.ply           the view's range grid (camera frame, mm; a cloud with grid_col/grid_row)
//! views/view_NNN_laserK.ply    laser scans: one sparse view (points and their pixels) per laser
//! denoised/view_NNN.ply        the range grid after non-local denoising (structured light)
//! preview/view_NNN_depth.png   colour depth map; preview/view_NNN_projector.png the decoded map
//! merged.ply                   all views in the object frame, cropped to the platter cylinder, with
//!                              normals, confidence and view_id per point
//! registered.ply               the views again, placed by multi-view ICP from their turntable poses
//! registered.poses.json        each view's refined pose and how far it moved
//! fused.ply                    mean-shift fusion of the registered (else merged) cloud
//! closed.ply                   the fused cloud with flat caps over its open base and top
//! mesh.ply                     watertight surface of the closed cloud (FFT or AdFFT, ch. 5)
//! mesh.stl, mesh.glb           the same mesh for printing (binary STL) and web viewers (glTF binary)
//! quads.obj, quads.ply         quad remesh of mesh.ply along a harmonic field's streamlines (ch. 6)
//! report.json                  what every stage did (`ProcessReport`), merged stage by stage
//! report.html                  the same to look at, with a 3D viewer (written by the `web` crate's
//!                              `scan_report`, which reads this folder)
//! ```

use std::path::{Path, PathBuf};

/// Paths inside one processed folder. Names are relative (they key the records); [`Layout::path`]
/// makes them absolute.
#[derive(Debug, Clone)]
pub struct Layout {
    /// The processed folder.
    pub root: PathBuf,
}

/// The merged cloud.
pub const MERGED: &str = "merged.ply";
/// The registered cloud.
pub const REGISTERED: &str = "registered.ply";
/// The registered poses.
pub const POSES: &str = "registered.poses.json";
/// The fused cloud.
pub const FUSED: &str = "fused.ply";
/// The watertight mesh.
pub const MESH: &str = "mesh.ply";
/// The fused cloud with caps over its open base and top: what reconstruction meshes.
pub const CLOSED: &str = "closed.ply";
/// The quad mesh.
pub const QUADS: &str = "quads.obj";
/// The quad mesh as PLY polygons.
pub const QUADS_PLY: &str = "quads.ply";
/// The mesh as binary STL.
pub const MESH_STL: &str = "mesh.stl";
/// The mesh as glTF binary.
pub const MESH_GLB: &str = "mesh.glb";
/// The report.
pub const REPORT: &str = "report.json";

impl Layout {
    /// The folders of the layout, created before a run.
    pub const FOLDERS: [&str; 4] = ["decode", "views", "denoised", "preview"];

    /// The layout under `root`.
    pub fn new(root: &Path) -> Self {
        Layout { root: root.to_path_buf() }
    }
    /// The absolute path of a relative name.
    pub fn path(&self, name: &str) -> PathBuf {
        self.root.join(name)
    }
    /// The folders the layout uses, created before a run.
    pub fn create(&self) -> Result<(), rig::Error> {
        for d in Self::FOLDERS {
            let p = self.root.join(d);
            std::fs::create_dir_all(&p).map_err(|e| rig::Error::io(&p, e))?;
        }
        Ok(())
    }
    /// A view's projector map.
    pub fn decode(v: usize) -> String {
        format!("decode/view_{v:03}.npy")
    }
    /// A structured-light view's range grid.
    pub fn grid(v: usize) -> String {
        format!("views/view_{v:03}.ply")
    }
    /// A laser view's sparse view (its line's points) for laser `k`.
    pub fn laser_grid(v: usize, k: usize) -> String {
        format!("views/view_{v:03}_laser{k}.ply")
    }
    /// A view's denoised range grid.
    pub fn denoised(v: usize) -> String {
        format!("denoised/view_{v:03}.ply")
    }
    /// A view's decoded-map preview.
    pub fn projector_preview(v: usize) -> String {
        format!("preview/view_{v:03}_projector.png")
    }
    /// A view's depth preview.
    pub fn depth_preview(v: usize) -> String {
        format!("preview/view_{v:03}_depth.png")
    }
}
