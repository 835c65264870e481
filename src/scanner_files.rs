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
        ImportCommand::Fabscan { config, out } => {
            let file: PathBuf = if config.is_dir() { config.join("config.json") } else { config.clone() };
            if !file.is_file() {
                bail!(
                    "{} is not a FabScanPi config.json{}",
                    file.display(),
                    if config.is_dir() { " (the folder holds none; name the file with the calibration)" } else { "" }
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
