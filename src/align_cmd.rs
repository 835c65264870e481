//! `scanrig align A B`: cloud A moved onto cloud B with no pose to start from — another pass of the
//! object, another tool's scan — by the library's global registration
//! ([`process::register::global`]). An ambiguous or unsupported match is refused (exit ≠ 0) unless
//! `--force`: a wrong alignment that exits 0 is the worst outcome of this command.

use crate::cli::AlignArgs;
use crate::json_outputs::Aligned;
use anyhow::{Context, Result, bail};
use process::register::global::{GlobalParams, align_global};
use std::io::Write;
use std::path::Path;

pub fn run(args: &AlignArgs) -> Result<()> {
    crate::outputs::plan(
        &[("A", &args.moving), ("B", &args.fixed)],
        &[("--out", args.out.as_deref()), ("--pose", args.pose.as_deref())],
    )?;
    // Options checked before a file is read.
    GlobalParams::check_voxel(args.voxel)?;
    one_unit(&args.moving, &args.fixed)?;
    let moving = crate::inputs::read_cloud(&args.moving)?;
    let fixed = crate::inputs::read_cloud(&args.fixed)?;
    let params = GlobalParams::for_clouds(&moving.positions, &fixed.positions, args.voxel, args.seed)
        .with_context(|| format!("aligning {} onto {}", args.moving.display(), args.fixed.display()))?;
    crate::progress::note(format!(
        "aligning {} ({} points) onto {} ({} points) at a {:.3} spacing …",
        args.moving.display(),
        moving.len(),
        args.fixed.display(),
        fixed.len(),
        params.voxel
    ));
    // Clouds in two units (files that do not say theirs) fail as too few points or matches: the
    // sizes' ratio is named with the failure.
    let a = align_global(&moving.positions, &fixed.positions, &params).map_err(|e| {
        anyhow::anyhow!(
            "aligning {} onto {}: {e}{}",
            args.moving.display(),
            args.fixed.display(),
            size_hint(&moving.positions, &fixed.positions)
        )
    })?;
    if !a.aligned {
        if !args.force {
            bail!(
                "{} could not be aligned onto {}: {} (overlap {:.0} %, {} of {} matches agree){}; nothing written — \
                 --force writes this best guess anyway",
                args.moving.display(),
                args.fixed.display(),
                a.why,
                100.0 * a.overlap,
                a.inliers,
                a.matches,
                size_hint(&moving.positions, &fixed.positions)
            );
        }
        eprintln!(
            "warning: not aligned ({}{}), written anyway as --force asks",
            a.why,
            size_hint(&moving.positions, &fixed.positions)
        );
    }
    if let Some(out) = &args.out {
        let mut moved = moving;
        moved.positions.iter_mut().for_each(|p| *p = a.pose * *p);
        if let Some(n) = moved.normals.as_mut() {
            n.iter_mut().for_each(|n| *n = a.pose.rotation * *n);
        }
        crate::outputs::write_cloud(out, &moved, &crate::outputs::write_options_like(&args.fixed)?)?;
    }
    let pose = rig::math::rows_of(&a.pose);
    let json = Aligned { moving: &args.moving, fixed: &args.fixed, pose, voxel: params.voxel, alignment: &a };
    if let Some(path) = &args.pose {
        rig::write_atomic(path, &serde_json::to_vec_pretty(&crate::outputs::versioned(&json))?)?;
    }
    let mut o = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut o, &crate::outputs::versioned(&json))?;
        writeln!(o)?;
    } else {
        let (axis, angle) = a.pose.rotation.axis_angle().map_or((rig::Vector3::z(), 0.0), |(ax, an)| (*ax, an));
        writeln!(
            o,
            "{} → {}: {}; turned {:.2}° about ({:.3}, {:.3}, {:.3}), moved ({:.2}, {:.2}, {:.2}); overlap {:.0} %, RMS \
             {:.3}, {} of {} matches agree, rival {:.2}",
            args.moving.display(),
            args.fixed.display(),
            if a.aligned { "aligned" } else { "NOT aligned (forced)" },
            angle.to_degrees(),
            axis.x,
            axis.y,
            axis.z,
            a.pose.translation.x,
            a.pose.translation.y,
            a.pose.translation.z,
            100.0 * a.overlap,
            a.rms,
            a.inliers,
            a.matches,
            a.rival_share
        )?;
        if let Some(out) = &args.out {
            writeln!(o, "  A moved into B's frame: {}", out.display())?;
        }
    }
    Ok(())
}

/// Refuses two files whose headers state different units: the alignment matches shapes by their
/// distances, so a cloud in metres never matches one in millimetres, and the failure would otherwise
/// read as "too few matches".
fn one_unit(a: &Path, b: &Path) -> Result<()> {
    let (Some(ua), Some(ub)) = (rig::data_units(a)?, rig::data_units(b)?) else { return Ok(()) };
    let differ = match (rig::precision::millimetres_per(&ua), rig::precision::millimetres_per(&ub)) {
        (Some(x), Some(y)) => (x - y).abs() > 1e-9 * x.max(y),
        _ => !ua.eq_ignore_ascii_case(&ub),
    };
    if differ {
        bail!(
            "{} is in {ua} and {} in {ub} (as their files say): align matches the clouds' shapes by their distances, \
             so both must be in one unit; nothing was aligned",
            a.display(),
            b.display()
        );
    }
    Ok(())
}

/// `; ` and [`process::register::global::sizes_apart`], or nothing.
fn size_hint(a: &[rig::Point3], b: &[rig::Point3]) -> String {
    process::register::global::sizes_apart(a, b).map_or(String::new(), |h| format!("; {h}"))
}
