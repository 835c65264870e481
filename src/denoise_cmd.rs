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

/// Four significant digits, so lengths read the same in metres and in millimetres.
fn significant(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
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
        let units = rig::ply::read_header(input)?.units();
        if let Some(u) = &units {
            opts = opts.with_units(u);
        }
        rig::ply::write_range_grid(&out, &clean, &opts)?;
        let unit = units.unwrap_or_else(|| "file units".into());
        eprintln!(
            "{} → {}: {} points, lone cells dropped: {}, d {} s {} {unit}, RMS move {} {unit}, {:.2} s",
            input.display(),
            out.display(),
            report.points,
            report.isolated_dropped,
            significant(report.d[0]),
            significant(report.s[0]),
            significant(report.rms_displacement.last().copied().unwrap_or(0.0)),
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

#[cfg(test)]
mod tests {
    #[test]
    fn lengths_keep_four_significant_digits() {
        assert_eq!(super::significant(0.001_234_56), "0.001235");
        assert_eq!(super::significant(5.6e-5), "0.00005600");
        assert_eq!(super::significant(1.5), "1.500");
        assert_eq!(super::significant(1234.5), "1234");
        assert_eq!(super::significant(0.0), "0");
    }
}
