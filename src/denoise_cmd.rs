//! `scanrig denoise`: range grids through the non-local (or bilateral) filter.

use crate::cli::DenoiseArgs;
use anyhow::{Context, Result, bail};
use process::pipeline::stages;
use std::io::Write;

/// Four significant digits, so lengths read the same in metres and in millimetres.
fn significant(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
}

pub fn run(args: &DenoiseArgs) -> Result<()> {
    let params = args.filter.params()?;
    let grids = args.inputs.iter().map(|p| rig::ply::read_range_grid(p)).collect::<Result<Vec<_>, _>>()?;
    let single = grids.len() == 1;
    if args.temporal > grids.len() {
        bail!("--temporal {} reaches past the {} frames given", args.temporal, grids.len());
    }
    let outputs: Vec<std::path::PathBuf> = if single {
        vec![args.out.clone()]
    } else {
        args.inputs.iter().map(|i| args.out.join(i.file_name().unwrap_or_default())).collect()
    };
    for (k, a) in outputs.iter().enumerate() {
        if let Some(j) = outputs[..k].iter().position(|b| b == a) {
            bail!(
                "{} and {} would both be written to {}: give inputs distinct file names",
                args.inputs[j].display(),
                args.inputs[k].display(),
                a.display()
            );
        }
    }
    let inputs: Vec<(&str, &std::path::Path)> = args.inputs.iter().map(|p| ("INPUT", p.as_path())).collect();
    let outs: Vec<(&str, Option<&std::path::Path>)> = outputs.iter().map(|p| ("--out", Some(p.as_path()))).collect();
    // Several grids go into the folder --out, made here if it is new (before the plan, which wants
    // every output's folder to exist).
    if !single && !args.out.is_dir() {
        std::fs::create_dir_all(&args.out).with_context(|| format!("--out {}: creating it", args.out.display()))?;
    }
    crate::outputs::plan(&inputs, &outs)?;
    let mut reports = Vec::new();
    for (k, input) in args.inputs.iter().enumerate() {
        let (clean, report) = stages::denoise(&grids, k, args.temporal, &params)
            .with_context(|| format!("denoising {}", input.display()))?;
        let out = &outputs[k];
        let mut opts = rig::ply::WriteOptions::default();
        let units = rig::ply::read_header(input)?.units();
        if let Some(u) = &units {
            opts = opts.with_units(u);
        }
        rig::ply::write_range_grid(out, &clean, &opts)?;
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
        reports.push(crate::json_outputs::DenoisedGrid { input, output: out, report });
    }
    if args.json {
        let mut o = std::io::stdout().lock();
        serde_json::to_writer_pretty(
            &mut o,
            &crate::outputs::versioned(&crate::json_outputs::Denoised { grids: reports }),
        )?;
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
