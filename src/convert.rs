//! `scanrig convert`: a mesh or a cloud from one file format to another.

use crate::cli::ConvertArgs;
use crate::json_outputs::{Converted, ConvertedKind};
use anyhow::{Context, Result};
use rig::ply::{Encoding, Precision, WriteOptions};
use rig::{MeshFormat, PolyMesh};

pub fn run(args: &ConvertArgs) -> Result<()> {
    crate::outputs::plan(&[("INPUT", &args.input)], &[("OUTPUT", Some(&args.output))])?;
    let mut opts = WriteOptions {
        encoding: if args.ascii { Encoding::Ascii } else { Encoding::BinaryLittleEndian },
        precision: if args.double { Precision::F64 } else { Precision::F32 },
        comments: Vec::new(),
    };
    // A file with faces converts as a mesh; a bare vertex list as a cloud, keeping all its attributes.
    let mut grid_note = None;
    // What the reader could not keep, each naming the file: printed, never dropped in silence.
    let mut warnings: Vec<String> = Vec::new();
    // The data's unit as the input gives it, kept by every format written (OBJ had said none, so a
    // cloud in metres went through it to E57 1000 times too small).
    if let Some(u) = rig::data_units(&args.input)? {
        opts = opts.with_units(&u);
    }
    let mesh: Option<PolyMesh> = match MeshFormat::of(&args.input) {
        Some(MeshFormat::Ply) => {
            let ply = rig::ply::read(&args.input)?;
            // A range grid stays one in PLY; in any other format only its points can go, and that is said.
            if rig::ply::is_range_grid(&ply) {
                let grid = rig::ply::range_grid_from_ply(&ply).map_err(|e| e.with_path(&args.input))?;
                if MeshFormat::of(&args.output) == Some(MeshFormat::Ply) {
                    rig::ply::write_range_grid(&args.output, &grid, &opts)?;
                    let valid = grid.valid_count();
                    if args.json {
                        let json = Converted {
                            output: &args.output,
                            what: ConvertedKind::RangeGrid { width: grid.width, height: grid.height, points: valid },
                        };
                        println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
                    } else {
                        println!(
                            "{}: range grid {}x{}, {valid} points",
                            args.output.display(),
                            grid.width,
                            grid.height
                        );
                    }
                    return Ok(());
                }
                grid_note = Some(format!(
                    "note: {} is a {}x{} range grid; {} keeps its points, not its grid cells (PLY keeps both)",
                    args.input.display(),
                    grid.width,
                    grid.height,
                    args.output.display()
                ));
            }
            let has_faces = ply.element("face").is_some() || ply.element("tristrips").is_some();
            if has_faces { Some(rig::ply::mesh_from_ply(&ply).map_err(|e| e.with_path(&args.input))?) } else { None }
        }
        // An E57 file holds clouds only.
        Some(MeshFormat::E57) => None,
        _ => {
            let read = rig::read_mesh_reported(&args.input)?;
            warnings = read.warnings;
            Some(read.value).filter(|m| m.face_count() > 0)
        }
    };
    let warn = |warnings: &[String]| {
        for w in warnings {
            eprintln!("warning: {w}");
        }
    };
    // What the output's format cannot hold is said (after the write succeeds), not dropped in silence.
    let format = MeshFormat::of(&args.output);
    match mesh {
        Some(m) => {
            warn(&warnings);
            let triangles = matches!(format, Some(MeshFormat::Stl | MeshFormat::Glb)) && m.faces().any(|f| f.len() > 3);
            let lost = rig::mesh_losses(&args.output, &m);
            rig::write_mesh(&args.output, &m, &opts)?;
            warn(&lost);
            warnings.extend(lost);
            if args.json {
                let what =
                    ConvertedKind::Mesh { vertices: m.vertices.len(), faces: m.face_count(), warnings: &warnings };
                let json = Converted { output: &args.output, what };
                println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
            } else {
                let written = match triangles {
                    true => format!(" ({} triangles written)", m.faces().map(|f| f.len() - 2).sum::<usize>()),
                    false => String::new(),
                };
                println!("{}: {} vertices, {} faces{written}", args.output.display(), m.vertices.len(), m.face_count());
            }
        }
        None => {
            if let Some(note) = &grid_note {
                eprintln!("{note}");
            }
            let read = rig::read_cloud_reported(&args.input)?;
            warnings = read.warnings;
            let cloud = read.value;
            warn(&warnings);
            let lost = rig::cloud_losses(&args.output, &cloud);
            rig::write_cloud(&args.output, &cloud, &opts).with_context(|| "writing the point cloud")?;
            warn(&lost);
            warnings.extend(lost);
            if args.json {
                let json = Converted {
                    output: &args.output,
                    what: ConvertedKind::Cloud { points: cloud.len(), warnings: &warnings },
                };
                println!("{}", serde_json::to_string_pretty(&crate::outputs::versioned(&json))?);
            } else {
                println!("{}: {} points", args.output.display(), cloud.len());
            }
        }
    }
    Ok(())
}
