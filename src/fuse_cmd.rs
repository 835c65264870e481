//! `scanrig fuse`: mean-shift fusion of a registered cloud.

use crate::cli::FuseArgs;
use anyhow::{Result, bail};
use process::mean_shift::{MeanShiftParams, mean_shift};
use rig::PointCloud;
use rig::ply::WriteOptions;
use std::io::Write;

pub fn run(args: &FuseArgs) -> Result<()> {
    if args.k < 6 {
        bail!("--k must be at least 6 (a kernel fits a plane to its neighbours), got {}", args.k);
    }
    let cloud = rig::read_cloud(&args.input)?;
    let mut opts = WriteOptions::default();
    if rig::MeshFormat::of(&args.input) == Some(rig::MeshFormat::Ply)
        && let Some(u) = rig::ply::read_header(&args.input)?.units()
    {
        opts = opts.with_units(&u);
    }
    let mut result = mean_shift(&cloud, &MeanShiftParams { k: args.k, ..Default::default() });
    // Without input normals the kernels' normals have no side: orient them consistently over the
    // cleaned cloud, the top facing up.
    let mut parts = None;
    if cloud.normals.is_none()
        && let Some(normals) = result.cloud.normals.as_mut()
    {
        parts = Some(process::orient::orient_by_spanning_tree(&result.cloud.positions, normals, 12));
    }
    rig::write_cloud(&args.out, &result.cloud, &opts)?;
    if let Some(path) = &args.outliers {
        let removed = (0..cloud.len()).filter(|&i| !result.kept[i]).map(|i| cloud.positions[i]).collect();
        rig::write_cloud(path, &PointCloud::from_positions(removed), &opts)?;
    }
    let r = &result.report;
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, r)?;
        writeln!(o)?;
    } else {
        writeln!(
            o,
            "{}: {} → {} points ({} outliers removed), {:.1} s",
            args.out.display(),
            r.points_in,
            r.points_out,
            r.strays + r.outliers_removed,
            r.seconds_kernels + r.seconds_shift + r.seconds_cluster
        )?;
        if let Some(parts) = parts {
            writeln!(o, "  the input had no normals: oriented by a spanning tree ({parts} connected parts)")?;
        }
    }
    Ok(())
}
