//! `scanrig reconstruct`: a watertight mesh from an oriented cloud.

use crate::cli::{MethodArg, ReconstructArgs};
use anyhow::{Context, Result};
use process::reconstruct::adfft::{AdFftParams, reconstruct_adfft};
use process::reconstruct::global_fft::{FftParams, reconstruct_fft};
use rig::ply::WriteOptions;
use rig::topology::topology;
use std::io::Write;

pub fn run(args: &ReconstructArgs) -> Result<()> {
    let cloud = rig::read_cloud(&args.input)?;
    let mut opts = WriteOptions::default();
    if rig::MeshFormat::of(&args.input) == Some(rig::MeshFormat::Ply)
        && let Some(u) = rig::ply::read_header(&args.input)?.units()
    {
        opts = opts.with_units(&u);
    }
    let start = std::time::Instant::now();
    let context = || format!("reconstructing {}", args.input.display());
    anyhow::ensure!(
        args.error.is_none() || args.method == MethodArg::Adfft,
        "--error steers AdFFT's octree; the global method (--method fft) has none"
    );
    let (mesh, report, patches) = match args.method {
        MethodArg::Fft => {
            let params =
                FftParams { depth: args.depth, memory_budget: (args.memory_budget * 1e9) as u64, ..Default::default() };
            let (mesh, r) = reconstruct_fft(&cloud, &params).with_context(context)?;
            (mesh, serde_json::to_value(&r)?, None)
        }
        MethodArg::Adfft => {
            if let Some(e) = args.error {
                anyhow::ensure!(e > 0.0 && e.is_finite(), "--error must be a positive distance, got {e}");
            }
            let params = AdFftParams { depth: args.depth, error: args.error, ..Default::default() };
            let (mesh, r) = reconstruct_adfft(&cloud, &params).with_context(context)?;
            let patches = r.leaves();
            (mesh, serde_json::to_value(&r)?, Some(patches))
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    rig::write_mesh(&args.out, &mesh.to_poly(), &opts)?;
    let t = topology(&mesh);
    let peak = rig::memory::peak_resident_bytes();
    let mut o = std::io::stdout().lock();
    if args.json {
        let json = serde_json::json!({
            "report": report,
            "topology": t,
            "genus": t.genus(),
            "seconds": seconds,
            "peak_resident_bytes": peak,
        });
        serde_json::to_writer_pretty(&mut o, &json)?;
        writeln!(o)?;
    } else {
        writeln!(
            o,
            "{}: {} vertices, {} triangles from {} points; {}³ grid (cell {:.4}){}, {:.2} s, peak memory {}",
            args.out.display(),
            mesh.vertices.len(),
            mesh.faces.len(),
            cloud.len(),
            report["n"],
            report["cell"].as_f64().unwrap_or(f64::NAN),
            patches.map_or(String::new(), |p| format!(", {p} patches")),
            seconds,
            peak.map_or("unknown".into(), |b| format!("{:.0} MB", b as f64 / 1e6))
        )?;
        match t.genus() {
            Some(g) => writeln!(o, "  closed, oriented 2-manifold: {} component(s), genus {g}", t.components)?,
            None => writeln!(o, "  not a closed manifold: {t:?}")?,
        }
    }
    Ok(())
}
