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
        ImportCommand::Fabscan { input, config, step_deg, out, pass } if input.is_dir() && has_frames(input) => {
            return match *pass {
                1 => import_fabscan_scan(input, config.as_deref(), *step_deg, out),
                p => import_fabscan_pass(input, config.as_deref(), *step_deg, out, p),
            };
        }
        ImportCommand::Fabscan { input, config: _, step_deg, out, pass } => {
            if *pass != 1 {
                bail!("--pass is for a scan folder, and {} holds no FabScanPi frames", input.display());
            }
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

/// A FabScanPi scan folder read and checked, ready to write: its rig (from the config), frames and
/// manifest (frames referenced under `frames_dir`), and the config's path. Nothing is written.
struct FabscanImport {
    rig: rig::Rig,
    frames: rig::fabscan_scan::FabscanFrames,
    manifest: rig::Manifest,
    config: PathBuf,
    step_deg: f64,
}

fn read_fabscan_scan(
    dir: &Path,
    config: Option<&Path>,
    step_deg: Option<f64>,
    frames_dir: &str,
) -> Result<FabscanImport> {
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
    let rig = rig::scanner_calibration::rig_from_fabscan(&read_text(&config)?)
        .with_context(|| format!("importing FabScanPi config {}", config.display()))?;
    let frames = rig::fabscan_scan::find_frames(dir, rig.lasers.len())?;
    let source = format!("FabScanPi scan {} imported with {}", dir.display(), config.display());
    // Checked (the step, frames beyond a turn) before anything is written.
    let (manifest, notes) = rig::fabscan_scan::manifest(&frames, step_deg, frames_dir, &source, dir)?;
    for note in notes.iter().chain(&frames.notes) {
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
    Ok(FabscanImport { rig, frames, manifest, config, step_deg })
}

/// The frames a manifest names under `frames_dir/`, from the FabScanPi folder into `into`: linked
/// where the file system allows, else copied byte for byte; only regular files.
fn bring_frames(dir: &Path, import: &FabscanImport, frames_dir: &str, into: &Path) -> Result<()> {
    std::fs::create_dir_all(into).with_context(|| format!("creating {}", into.display()))?;
    let prefix = format!("{frames_dir}/");
    // The frames the manifest names (a position that repeats another is not among them).
    let names = import.manifest.views.iter().flat_map(|v| &v.frames).filter_map(|f| f.file.strip_prefix(&prefix));
    for name in names {
        let (from, to) = (dir.join(&import.frames.folder).join(name), into.join(name));
        // A FIFO or a device in place of a frame is refused, not linked or waited on.
        rig::input::open_regular(&from)?;
        if std::fs::hard_link(&from, &to).is_err() {
            std::fs::copy(&from, &to).with_context(|| format!("copying {}", from.display()))?;
        }
    }
    Ok(())
}

/// A FabScanPi scan folder and its config into a scanrig scan folder: built beside `out` and renamed
/// into place when whole, so a refused or interrupted import leaves nothing behind.
fn import_fabscan_scan(dir: &Path, config: Option<&Path>, step_deg: Option<f64>, out: &Path) -> Result<()> {
    if out.exists() {
        bail!("{} exists: importing writes a new scan folder (a further pass of its object: --pass 2)", out.display());
    }
    let import = read_fabscan_scan(dir, config, step_deg, "frames")?;
    let FabscanImport { rig, frames, manifest: m, config, step_deg } = &import;
    // Built in a folder of a name no user owns (`.NAME.scanrig-tmp…`, made for this run), removed with
    // its contents if the import fails: never a folder the run did not create.
    let staging = rig::run_files::temp_folder_beside(out)?;
    let partial = staging.path().to_path_buf();
    let result = (|| -> Result<()> {
        bring_frames(dir, &import, "frames", &partial.join("frames"))?;
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

/// A FabScanPi scan of the same object, turned over, as pass `pass` of the scanrig scan `out` (the
/// scan's other passes imported or captured before): its frames under `frames/pass_N/`, its views
/// appended. The rig must be the scan's; `process` then aligns the pass by its shape.
fn import_fabscan_pass(dir: &Path, config: Option<&Path>, step_deg: Option<f64>, out: &Path, pass: u32) -> Result<()> {
    if !(2..=rig::scan_folder::MAX_PASSES).contains(&pass) {
        bail!("--pass must be 1 to {}, got {pass}", rig::scan_folder::MAX_PASSES);
    }
    let first = || format!("{}: --pass {pass} adds to a scan folder; import its first pass there first", out.display());
    let manifest = out.join(rig::scan_folder::MANIFEST_NAME);
    if !manifest.is_file() {
        bail!("{}", first());
    }
    // The manifest is read and written again on purpose (its views extended).
    rig::run_files::updates(&manifest);
    let mut scan = rig::Manifest::read(out).with_context(first)?;
    if scan.passes() + 1 != pass {
        bail!("{} holds {} pass(es): the next is --pass {}", out.display(), scan.passes(), scan.passes() + 1);
    }
    if scan.method != rig::Method::Laser || scan.views.iter().any(|v| !v.complete) {
        bail!("{} is not a complete laser scan: a FabScanPi pass joins only one", out.display());
    }
    let frames_dir = format!("frames/pass_{pass}");
    let import = read_fabscan_scan(dir, config, step_deg, &frames_dir)?;
    let recorded = rig::Rig::read(&rig::Manifest::inside(out, &scan.rig, "rig")?)?;
    if recorded.camera != import.rig.camera || recorded.lasers != import.rig.lasers {
        bail!(
            "{} describes another camera or other lasers than {}'s rig: the passes of one scan share one rig",
            import.config.display(),
            out.display()
        );
    }
    let target = out.join(&frames_dir);
    if target.exists() {
        bail!("{} exists: a pass's frames go into a folder of their own", target.display());
    }
    // Built beside, renamed into place whole; the manifest names the pass only once its frames are there.
    let staging = rig::run_files::temp_folder_beside(&target)?;
    bring_frames(dir, &import, &frames_dir, staging.path())?;
    std::fs::rename(staging.path(), &target)
        .with_context(|| format!("moving {} to {}", staging.path().display(), target.display()))?;
    let _ = staging.keep();
    let views = import.manifest.views.len();
    scan.views.extend(import.manifest.views.into_iter().map(|v| rig::scan_folder::View { pass, ..v }));
    if let Err(e) = scan.write(out) {
        // The frames this run moved in go again: the scan stays as it was.
        let _ = std::fs::remove_dir_all(&target);
        return Err(e.into());
    }
    println!(
        "{}: pass {pass}, {views} positions of FabScanPi scan {} ({}° a step) appended; `scanrig process {}` aligns it",
        out.display(),
        import.frames.id,
        import.step_deg,
        out.display()
    );
    Ok(())
}

pub fn export(command: &ExportCommand) -> Result<()> {
    let (rig_path, out, into, scanner) = match command {
        ExportCommand::Horus { rig, out, into } => (rig, out, into, "Horus settings"),
        ExportCommand::Fabscan { rig, out, into } => (rig, out, into, "a FabScanPi config"),
    };
    let mut inputs = vec![("RIG", rig_path.as_path())];
    if let Some(into) = into {
        inputs.push(("--into", into.as_path()));
    }
    crate::outputs::plan(&inputs, &[("--out", Some(out.as_path()))])?;
    let r = rig::Rig::read(rig_path)?;
    let kind = match command {
        ExportCommand::Horus { .. } => rig::scanner_calibration::Scanner::Horus,
        ExportCommand::Fabscan { .. } => rig::scanner_calibration::Scanner::Fabscan,
    };
    let ours = match command {
        ExportCommand::Horus { .. } => rig::scanner_calibration::rig_to_horus(&r),
        ExportCommand::Fabscan { .. } => rig::scanner_calibration::rig_to_fabscan(&r),
    }
    .map_err(|why| anyhow::anyhow!("{} cannot be written as {scanner}: {why}", rig_path.display()))?;
    let text = match into {
        Some(into) => rig::scanner_calibration::merge_into(&read_text(into)?, &ours, kind)
            .with_context(|| format!("--into {}: laying the rig over the scanner's own file", into.display()))?,
        None => {
            // The scanner reads everything from this one file: what a rig does not hold is missing.
            let missing = match command {
                ExportCommand::Horus { .. } => "every category but calibration_settings",
                ExportCommand::Fabscan { .. } => {
                    "turntable.steps (a wrong one half-inverts the clouds), calibration.pattern, folders and connector"
                }
            };
            crate::progress::note(format!(
                "note: {} holds only the rig's numbers, not {missing}; give --into with the scanner's own file to \
                 keep those",
                out.display()
            ));
            ours
        }
    };
    rig::write_atomic(out, text.as_bytes())?;
    match into {
        Some(into) => println!("{}: {} with the numbers of {}", out.display(), into.display(), rig_path.display()),
        None => println!("{}: from {}", out.display(), rig_path.display()),
    }
    Ok(())
}
