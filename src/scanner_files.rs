//! `scanrig import` and `scanrig export`: other scanners' calibration files (Horus' settings.json,
//! FabScanPi's config.json) to and from rig files, through `rig::scanner_calibration`.

use crate::cli::{ExportCommand, ImportCommand};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

/// Reads a text file, naming it on failure.
fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
}

pub fn import(command: &ImportCommand) -> Result<()> {
    let (rig, source, out) = match command {
        ImportCommand::Horus { settings, out } => {
            let rig = rig::scanner_calibration::rig_from_horus(&read_text(settings)?)
                .with_context(|| format!("importing Horus settings {}", settings.display()))?;
            (rig, settings.clone(), out)
        }
        ImportCommand::Fabscan { input, config, out } if input.is_dir() && has_frames(input) => {
            return import_fabscan_scan(input, config.as_deref(), out);
        }
        ImportCommand::Fabscan { input, config: _, out } => {
            let file: PathBuf = if input.is_dir() { input.join("config.json") } else { input.clone() };
            if !file.is_file() {
                bail!(
                    "{} is not a FabScanPi config.json{}",
                    file.display(),
                    if input.is_dir() {
                        " (the folder holds neither a config.json nor raw_laser_raw frames)"
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
    rig::fabscan_scan::FRAME_FOLDERS.iter().any(|f| dir.join(f).is_dir())
}

/// A FabScanPi scan folder and its config into a scanrig scan folder: built beside `out` and renamed
/// into place when whole, so a refused or interrupted import leaves nothing behind.
fn import_fabscan_scan(dir: &Path, config: Option<&Path>, out: &Path) -> Result<()> {
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
    let partial = out.with_extension("partial");
    let _ = std::fs::remove_dir_all(&partial);
    let result = (|| -> Result<rig::Manifest> {
        let frames_dir = "frames";
        std::fs::create_dir_all(partial.join(frames_dir)).with_context(|| format!("creating {}", partial.display()))?;
        for name in frames.files.iter().flatten() {
            let (from, to) = (dir.join(&frames.folder).join(name), partial.join(frames_dir).join(name));
            // The frames as they are: linked where the file system allows, else copied byte for byte.
            if std::fs::hard_link(&from, &to).is_err() {
                std::fs::copy(&from, &to).with_context(|| format!("copying {}", from.display()))?;
            }
        }
        let source = format!("FabScanPi scan {} imported with {}", dir.display(), config.display());
        let m = rig::fabscan_scan::manifest(&frames, frames_dir, &source);
        rig.write(&partial.join(&m.rig))?;
        m.write(&partial)?;
        Ok(m)
    })();
    let m = match result {
        Ok(m) => m,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&partial);
            return Err(e);
        }
    };
    std::fs::rename(&partial, out).with_context(|| format!("moving {} to {}", partial.display(), out.display()))?;
    println!(
        "{}: {} positions × {} laser(s) of FabScanPi scan {} ({}° a step; FabScanPi's +angle is scanrig's −angle), \
         rig from {}",
        out.display(),
        m.views.len(),
        rig.lasers.len(),
        frames.id,
        360.0 / m.views.len() as f64,
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
