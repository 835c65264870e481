//! `scanrig denoise`: range grids through the non-local (or bilateral) filter.

use crate::cli::{DenoiseArgs, DirectionArg, FilterArg};
use anyhow::{Context, Result, bail};
use process::denoise::{DenoiseParams, Direction, Similarity, denoise_sequence};
use std::io::Write;

fn half(size: usize, what: &str) -> Result<usize> {
    if size < 3 || size.is_multiple_of(2) {
        bail!("--{what} must be an odd size of at least 3, got {size}");
    }
    Ok(size / 2)
}

pub fn run(args: &DenoiseArgs) -> Result<()> {
    let params = DenoiseParams {
        window: half(args.window, "window")?,
        similarity: match args.filter {
            FilterArg::NonLocal => Similarity::NonLocal { half: half(args.patch, "patch")? },
            FilterArg::Bilateral => Similarity::Bilateral,
        },
        direction: if args.direction == DirectionArg::Sight { Direction::LineOfSight } else { Direction::Normal },
        iterations: args.iterations.max(1),
        adaptive: !args.no_adaptive,
        bandwidth: args.bandwidth,
        drop_isolated: !args.keep_isolated,
        ..Default::default()
    };
    let grids = args.inputs.iter().map(|p| rig::ply::read_range_grid(p)).collect::<Result<Vec<_>, _>>()?;
    let single = grids.len() == 1;
    if !single {
        std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    }
    let mut reports = Vec::new();
    for (k, input) in args.inputs.iter().enumerate() {
        let (mut clean, report) = denoise_sequence(&grids, k, args.temporal, &params)
            .with_context(|| format!("denoising {}", input.display()))?;
        if clean.normals.is_some() {
            process::grid_normals::estimate_normals(&mut clean, 2.0);
        }
        let out = if single { args.out.clone() } else { args.out.join(input.file_name().unwrap_or_default()) };
        let mut opts = rig::ply::WriteOptions::default();
        if let Some(u) = rig::ply::read_header(input)?.units() {
            opts = opts.with_units(&u);
        }
        rig::ply::write_range_grid(&out, &clean, &opts)?;
        eprintln!(
            "{} → {}: {} points, lone cells dropped: {}, d {:.4} s {:.4}, RMS move {:.4} (file units), {:.2} s",
            input.display(),
            out.display(),
            report.points,
            report.isolated_dropped,
            report.d_mm[0],
            report.s_mm[0],
            report.rms_displacement_mm.last().copied().unwrap_or(0.0),
            report.seconds
        );
        reports.push(serde_json::json!({ "input": input, "output": out, "report": report }));
    }
    if args.json {
        let mut o = std::io::stdout().lock();
        serde_json::to_writer_pretty(&mut o, &reports)?;
        writeln!(o)?;
    }
    Ok(())
}
