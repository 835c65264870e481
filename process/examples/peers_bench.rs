//! The Rust half of the peers bench (`bench/peers.py`, issue 42): the same oriented bunny points for
//! every tool, and one measure of what each made.
//!
//! `cargo run --release -p process --example peers_bench -- export OUT.ply` writes the ten real bunny
//! range scans aligned by bun.conf, in millimetres, with PCA normals turned toward each scan's sensor:
//! the input of the reconstruction test (`reconstruct::bunny_scans_reconstruct_close_to_the_zipper_mesh`).
//!
//! `... -- score MESH.ply [MESH.ply ...]` prints one JSON line per mesh, measured against bun_zipper.ply
//! as that test measures: accuracy (the mesh → bun_zipper, mean over 100,000 surface samples that lie
//! within 2 mm of an input point, so surface a method invented where no scan looked does not count),
//! completeness (bun_zipper → the mesh, mean over 100,000 samples), their mean (`chamfer`), and the
//! mesh's topology (closed oriented 2-manifold, genus, components) and self-intersecting triangle pairs.
//! A mesh that cannot be read is a JSON line with `error`, so one peer's odd file does not stop the rest.

use process::kd_tree::PointTree;
use process::mesh_distance::MeshDistance;
use process::normals::pca_normals;
use process::reconstruct::self_intersect::intersecting_pairs;
use rig::math::{Real, Vector3};
use rig::topology::topology;
use rig::{PointCloud, TriMesh};
use std::path::Path;

type Error = Box<dyn std::error::Error>;

/// The bench's input: what the reconstruction test reconstructs.
fn bunny() -> Result<PointCloud, Error> {
    fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z()))
        .ok_or_else(|| "the Stanford bunny scans are not under ../shared/data (stanford-bunny/)".into())
}

fn mean(v: &[Real]) -> Real {
    v.iter().sum::<Real>() / v.len().max(1) as Real
}

fn score(path: &Path, input: &PointTree, zipper: &TriMesh, to_zipper: &MeshDistance) -> Result<String, Error> {
    let start = std::time::Instant::now();
    let mesh = rig::read_mesh(path)?.triangulate();
    if mesh.faces.is_empty() {
        return Err(format!("{} has no faces", path.display()).into());
    }
    // `nearest` gives the squared distance: 4 mm² is within 2 mm of a scanned point.
    // Seeded area-weighted samples, so every mesh is measured alike.
    let accuracy: Vec<Real> = fixtures::surface_points(&mesh, 100_000, 5)
        .iter()
        .filter(|p| input.nearest(p).1 <= 4.0)
        .map(|p| to_zipper.distance(p))
        .collect();
    let to_mesh = MeshDistance::new(&mesh, 1.0);
    let completeness: Vec<Real> =
        fixtures::surface_points(zipper, 100_000, 6).iter().map(|p| to_mesh.distance(p)).collect();
    let t = topology(&mesh);
    let (acc, comp) = (mean(&accuracy), mean(&completeness));
    let line = serde_json::json!({
        "mesh": path.display().to_string(),
        "vertices": t.vertices,
        "triangles": mesh.faces.len(),
        "accuracy_mm": acc,
        "completeness_mm": comp,
        "chamfer_mm": (acc + comp) / 2.0,
        "closed_manifold": t.is_closed_oriented_manifold(),
        "genus": t.genus(),
        "euler": t.euler(),
        "components": t.components,
        "boundary_edges": t.boundary_edges,
        "non_manifold_edges": t.non_manifold_edges,
        "self_intersections": intersecting_pairs(&mesh).len(),
        "seconds_to_score": start.elapsed().as_secs_f64(),
    });
    Ok(line.to_string())
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("export") => {
            let out = Path::new(args.get(1).ok_or("export takes the .ply to write")?);
            if out.exists() {
                return Err(format!("{} exists: give a new path", out.display()).into());
            }
            let cloud = bunny()?;
            let opts = rig::ply::WriteOptions::default().with_units("mm");
            rig::ply::write_cloud(out, &cloud, &opts)?;
            eprintln!("wrote {} oriented points to {}", cloud.len(), out.display());
        }
        Some("score") if args.len() > 1 => {
            let cloud = bunny()?;
            let input = PointTree::new(&cloud.positions);
            let zipper_path = fixtures::data_file("stanford-bunny/reconstruction/bun_zipper.ply")
                .ok_or("bun_zipper.ply is not under ../shared/data/stanford-bunny/reconstruction")?;
            // bun_zipper.ply is in metres, the scans in millimetres.
            let mut zipper = rig::read_mesh(&zipper_path)?.triangulate();
            zipper.vertices.iter_mut().for_each(|v| *v *= 1000.0);
            let to_zipper = MeshDistance::new(&zipper, 1.0);
            for mesh in &args[1..] {
                match score(Path::new(mesh), &input, &zipper, &to_zipper) {
                    Ok(line) => println!("{line}"),
                    Err(e) => println!("{}", serde_json::json!({ "mesh": mesh, "error": e.to_string() })),
                }
            }
        }
        _ => return Err("usage: peers_bench export OUT.ply | peers_bench score MESH.ply [MESH.ply ...]".into()),
    }
    Ok(())
}
