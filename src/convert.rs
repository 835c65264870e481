//! `scanrig convert`: a mesh or a cloud from one file format to another.

use crate::cli::ConvertArgs;
use anyhow::{Context, Result};
use rig::ply::{Encoding, Precision, WriteOptions};
use rig::{MeshFormat, PolyMesh};

pub fn run(args: &ConvertArgs) -> Result<()> {
    let mut opts = WriteOptions {
        encoding: if args.ascii { Encoding::Ascii } else { Encoding::BinaryLittleEndian },
        precision: if args.double { Precision::F64 } else { Precision::F32 },
        comments: Vec::new(),
    };
    // A file with faces converts as a mesh; a bare vertex list as a cloud, keeping all its attributes.
    let mesh: Option<PolyMesh> = match MeshFormat::of(&args.input) {
        Some(MeshFormat::Ply) => {
            let ply = rig::ply::read(&args.input)?;
            if let Some(u) = ply.header.units() {
                opts = opts.with_units(&u);
            }
            let has_faces = ply.element("face").is_some() || ply.element("tristrips").is_some();
            if has_faces { Some(rig::ply::mesh_from_ply(&ply).map_err(|e| e.with_path(&args.input))?) } else { None }
        }
        _ => Some(rig::read_mesh(&args.input)?).filter(|m| m.face_count() > 0),
    };
    match mesh {
        Some(m) => {
            rig::write_mesh(&args.output, &m, &opts)?;
            if args.json {
                let json = serde_json::json!({"output": args.output, "kind": "mesh", "vertices": m.vertices.len(), "faces": m.face_count()});
                println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
            } else {
                println!("{}: {} vertices, {} faces", args.output.display(), m.vertices.len(), m.face_count());
            }
        }
        None => {
            let cloud = rig::read_cloud(&args.input)?;
            rig::write_cloud(&args.output, &cloud, &opts).with_context(|| "writing the point cloud")?;
            if args.json {
                let json = serde_json::json!({"output": args.output, "kind": "cloud", "points": cloud.len()});
                println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
            } else {
                println!("{}: {} points", args.output.display(), cloud.len());
            }
        }
    }
    Ok(())
}
