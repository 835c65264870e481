//! `scanrig import` and `scanrig export`: other scanners' calibration files (Horus' settings.json,
//! FabScanPi's config.json) to and from rig files, through `rig::scanner_calibration`.

use crate::cli::{ExportCommand, ImportCommand};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

/// Reads a text file, naming it on failure.
fn read_text(path: &Path) -> Result<String> {
    Ok(rig::input::read_regular_to_string(path, None)?)
}

pub fn import(command: &ImportCommand) -> Result<()> {
    let (rig, source, out) = match command {
        ImportCommand::Horus { settings, out } => {
            let rig = rig::scanner_calibration::rig_from_horus(&read_text(settings)?)
                .with_context(|| format!("importing Horus settings {}", settings.display()))?;
            (rig, settings.clone(), out)
        }
        ImportCommand::Fabscan { input, config, step_deg, out } if input.is_dir() && has_frames(input) => {
            return import_fabscan_scan(input, config.as_deref(), *step_deg, out);
        }
        ImportCommand::Fabscan { input, config: _, step_deg, out } => {
            if step_deg.is_some() {
                bail!(
                    "--step-deg is for a scan folder, and {} holds no FabScanPi frames (raw_laser_raw/, laser_raw/ or \
                     <id>_NNN.jpg files)",
                    input.display()
                );
            }
            let file: PathBuf = if input.is_dir() { input.join("config.json") } else { input.clone() };
            if !file.is_file() {
                bail!(
                    "{} is not a FabScanPi config.json{}",
                    file.display(),
                    if input.is_dir() {
                        " (the folder holds neither a config.json nor FabScanPi frames: raw_laser_raw/, laser_raw/ or \
                         <id>_NNN.jpg files)"
                    } else {
                        ""
                    }
                );
            }
            let rig = rig::scanner_calibration::rig_from_fabscan(&read_text(&file)?)
                .with_context(|| format!("importing FabScanPi config {}", file.display()))?;
            (rig, file, out)
        }
    };
    rig.write(out)?;
    println!(
        "{}: camera {}×{} (frames turned: transpose {}, hflip {}, vflip {}), {} laser plane(s), turntable axis from \
         the platform pose; from {}",
        out.display(),
        rig.camera.width,
        rig.camera.height,
        rig.image.transpose,
        rig.image.hflip,
        rig.image.vflip,
        rig.lasers.len(),
        source.display()
    );
    Ok(())
}

fn has_frames(dir: &Path) -> bool {
    rig::fabscan_scan::frame_folder(dir).is_some()
}

/// A FabScanPi scan folder and its config into a scanrig scan folder: built beside `out` and renamed
/// into place when whole, so a refused or interrupted import leaves nothing behind.
fn import_fabscan_scan(dir: &Path, config: Option<&Path>, step_deg: Option<f64>, out: &Path) -> Result<()> {
    // FabScanPi's config does not record the scan's resolution: the step is the user's to say, since
    // any guess from the frame count turns a stopped scan into a whole turn.
    let Some(step_deg) = step_deg else {
        bail!(
            "{}: give the turntable step of the scan with --step-deg (FabScanPi's config.json does not record the \
             scan's resolution; 3.6 for 100 positions a turn): frame k stands at k × step",
            dir.display()
        );
    };
    let config = match config {
        Some(c) => c.to_path_buf(),
        None => [dir.join("config.json"), dir.join("../config.json")].into_iter().find(|p| p.is_file()).with_context(
            || format!("{}: give the scanner's config.json (--config): the scan folder holds none", dir.display()),
        )?,
    };
    if out.exists() {
        bail!("{} exists: importing writes a new scan folder", out.display());
    }
    let rig = rig::scanner_calibration::rig_from_fabscan(&read_text(&config)?)
        .with_context(|| format!("importing FabScanPi config {}", config.display()))?;
    let frames = rig::fabscan_scan::find_frames(dir, rig.lasers.len())?;
    let source = format!("FabScanPi scan {} imported with {}", dir.display(), config.display());
    // Checked (the step, frames beyond a turn) before anything is written.
    let (m, notes) = rig::fabscan_scan::manifest(&frames, step_deg, "frames", &source, dir)?;
    for note in &notes {
        eprintln!("warning: {note}");
    }
    for note in &frames.notes {
        eprintln!("warning: {note}");
    }
    // The first frame must be the size the config says its camera captures.
    let first = dir.join(&frames.folder).join(&frames.files[0][0]);
    let img = rig::image::read_image(&first)?;
    let expect = rig.image.size(rig.camera.width, rig.camera.height);
    if (img.width, img.height) != expect {
        bail!(
            "{} is {}×{} but {} says its camera captures {}×{} (camera.resolution): the config belongs to another \
             scanner",
            first.display(),
            img.width,
            img.height,
            config.display(),
            expect.0,
            expect.1
        );
    }
    // Built in a folder of a name no user owns (`.NAME.scanrig-tmp…`, made for this run), removed with
    // its contents if the import fails: never a folder the run did not create.
    let staging = rig::run_files::temp_folder_beside(out)?;
    let partial = staging.path().to_path_buf();
    let result = (|| -> Result<()> {
        let frames_dir = "frames";
        std::fs::create_dir_all(partial.join(frames_dir)).with_context(|| format!("creating {}", partial.display()))?;
        // The frames the manifest names (a position that repeats another is not among them).
        let names = m.views.iter().flat_map(|v| &v.frames).filter_map(|f| f.file.strip_prefix("frames/"));
        for name in names {
            let (from, to) = (dir.join(&frames.folder).join(name), partial.join(frames_dir).join(name));
            // Only regular files: a FIFO or a device in place of a frame is refused, not linked or waited on.
            rig::input::open_regular(&from)?;
            // The frames as they are: linked where the file system allows, else copied byte for byte.
            if std::fs::hard_link(&from, &to).is_err() {
                std::fs::copy(&from, &to).with_context(|| format!("copying {}", from.display()))?;
            }
        }
        rig.write(&partial.join(&m.rig))?;
        m.write(&partial)?;
        Ok(())
    })();
    result?;
    std::fs::rename(&partial, out).with_context(|| format!("moving {} to {}", partial.display(), out.display()))?;
    // Renamed away: nothing left for the staging folder's cleanup to remove.
    let _ = staging.keep();
    println!(
        "{}: {} positions × {} laser(s) of FabScanPi scan {} ({step_deg}° a step; FabScanPi's +angle is scanrig's \
         −angle), rig from {}",
        out.display(),
        m.views.len(),
        rig.lasers.len(),
        frames.id,
        config.display()
    );
    Ok(())
}

pub fn export(command: &ExportCommand) -> Result<()> {
    let (rig_path, out, text) = match command {
        ExportCommand::Horus { rig, out } => {
            let r = rig::Rig::read(rig)?;
            let text = rig::scanner_calibration::rig_to_horus(&r)
                .map_err(|why| anyhow::anyhow!("{} cannot be written as Horus settings: {why}", rig.display()))?;
            (rig, out, text)
        }
        ExportCommand::Fabscan { rig, out } => {
            let r = rig::Rig::read(rig)?;
            let text = rig::scanner_calibration::rig_to_fabscan(&r)
                .map_err(|why| anyhow::anyhow!("{} cannot be written as a FabScanPi config: {why}", rig.display()))?;
            (rig, out, text)
        }
    };
    rig::write_atomic(out, text.as_bytes())?;
    println!("{}: from {}", out.display(), rig_path.display());
    Ok(())
}
