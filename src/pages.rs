//! `scanrig report` and `scanrig view`, and the report pages `process`, `demo` and `calibrate`
//! write: thin wrappers over the `web` crate that say where each page went.

use crate::cli::{ReportArgs, ViewArgs};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `processed/report.html` for `scan`, saying where on stderr (stdout may carry JSON).
pub fn write_scan_report(scan: &Path, processed: &Path) -> Result<web::scan_report::ScanPage> {
    write_scan_report_prepared(scan, processed, None)
}

/// [`write_scan_report`] with its 3D scene made beforehand (see [`web::scan_report::PreparedScene`]).
fn write_scan_report_prepared(
    scan: &Path,
    processed: &Path,
    prepared: Option<web::scan_report::PreparedScene>,
) -> Result<web::scan_report::ScanPage> {
    let t = std::time::Instant::now();
    let page = web::scan_report::write_prepared(scan, processed, prepared)
        .with_context(|| format!("writing the report page of {}", processed.display()))?;
    crate::progress::note(format!(
        "report page {} ({:.1} MB, {:.1} s): open it in a browser",
        page.path.display(),
        page.bytes as f64 / 1e6,
        t.elapsed().as_secs_f64()
    ));
    Ok(page)
}

/// [`write_scan_report`] after a pipeline run: its outputs are written whatever happens to the page,
/// so a page that cannot be made is a warning, not a failed run.
pub fn scan_report_after_run(
    scan: &Path,
    processed: &Path,
    prepared: Option<web::scan_report::PreparedScene>,
) -> Option<web::scan_report::ScanPage> {
    match write_scan_report_prepared(scan, processed, prepared) {
        Ok(page) => Some(page),
        Err(e) => {
            eprintln!("warning: the report page was not written ({e:#}); `scanrig report` retries it");
            None
        }
    }
}

pub fn report(args: &ReportArgs) -> Result<()> {
    let processed = args.out.clone().unwrap_or_else(|| args.scan.join("processed"));
    let page = write_scan_report(&args.scan, &processed)?;
    let mut o = std::io::stdout().lock();
    writeln!(o, "{}", page.path.display())?;
    if let Some(rms) = page.truth_rms_percent {
        writeln!(o, "  mesh against the truth: RMS {rms:.4} % of the diagonal above the bottom 3 mm")?;
    }
    Ok(())
}

/// Whether `path` starts as the pages scanrig writes do (their `generator` meta tag, in the head).
fn written_by_scanrig(path: &Path) -> bool {
    use std::io::Read;
    let mut head = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| f.take(4096).read_to_end(&mut head));
    const MARK: &[u8] = b"<meta name=\"generator\" content=\"scanrig";
    read.is_ok() && head.windows(MARK.len()).any(|w| w == MARK)
}

/// `mesh.ply` → `mesh.view.html` beside it.
fn default_page(first: &Path) -> PathBuf {
    let stem = first.file_stem().map_or("view".into(), |s| s.to_string_lossy().into_owned());
    first.with_file_name(format!("{stem}.view.html"))
}

pub fn view(args: &ViewArgs) -> Result<()> {
    if args.serve {
        let page = web::view_page::build(&args.files, None)?;
        let server =
            web::serve::Server::bind(page, args.port).with_context(|| format!("serving on 127.0.0.1:{}", args.port))?;
        let addr = server.addr().context("the server has no TCP address")?;
        let mut o = std::io::stdout().lock();
        writeln!(o, "http://{addr}/")?;
        o.flush()?;
        drop(o);
        crate::progress::note("serving the page until interrupted (Ctrl-C)");
        server.run(|| false).context("serving the page")?;
        return Ok(());
    }
    let out = match &args.out {
        Some(out) => out.clone(),
        None => {
            // A name chosen for the user, not by them: what is there is replaced only where an earlier
            // page of scanrig's is (a user's own `bunny.view.html` was overwritten without a word).
            let page = default_page(&args.files[0]);
            if page.exists() && !written_by_scanrig(&page) {
                anyhow::bail!(
                    "{}: a file of that name is there and is not a page scanrig wrote; name the page with --out",
                    page.display()
                );
            }
            page
        }
    };
    let bytes = web::view_page::write(&args.files, &out)?;
    crate::progress::note(format!("{:.1} MB: open it in a browser", bytes as f64 / 1e6));
    println!("{}", out.display());
    Ok(())
}
