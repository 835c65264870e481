//! scanrig's pages: what a user looks at after a scan or a calibration, and a viewer for any cloud or
//! mesh scanrig reads. Each page is one HTML file that opens offline from a `file://` path: its
//! stylesheet, scripts (three.js, vendored in `assets/vendor`) and data are inlined, and it links
//! only to files beside it.
//!
//! - [`page`]: the page skeleton, HTML escaping, inlined assets;
//! - [`scene`]: the viewer's layers (clouds, meshes, line drawings), decimated and packed for the page;
//! - [`plot`]: SVG charts (bars, series across views, histograms, colour bars, residual vectors);
//! - [`picture`]: images for the page (depth maps scaled to the object, thumbnails, PNG/JPEG data URLs);
//! - [`scan_report`], [`calib_report`], [`view_page`]: the three pages;
//! - [`serve`]: a page on `127.0.0.1` for `scanrig view --serve`.
//!
//! This is the seed of a live operator interface: its pieces are plain functions from data to HTML,
//! so a server can assemble the same sections from a running scan.

pub mod calib_report;
pub mod escape;
pub mod page;
pub mod picture;
pub mod plot;
pub mod scan_report;
pub mod scene;
pub mod serve;
pub mod station_page;
pub mod view_page;

/// Why a page could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PageError {
    /// A file the page is built from (or the page itself) could not be read, parsed or written.
    #[error(transparent)]
    File(#[from] rig::Error),
    /// A folder lacks what the page needs.
    #[error("{0}")]
    Missing(String),
}
