//! The station's one page (`scanrig serve`): devices and check, live view, calibration, scan with
//! the object appearing view by view, processing and projects. Static markup and one script,
//! everything inlined (three.js too), so it works with no network; all it knows it gets from the
//! station's JSON API and event stream.

use crate::escape::script_text;
use crate::page::{CSS, THREE_JS, THREE_VERSION};

/// The page's markup, its own styles and its script.
const HTML: &str = include_str!("../assets/station.html");
const STATION_CSS: &str = include_str!("../assets/station.css");
const STATION_JS: &str = include_str!("../assets/station.js");

/// The whole page.
pub fn build() -> String {
    HTML.replace("/*CSS*/", &format!("{CSS}\n{STATION_CSS}")).replace("THREE_VERSION", THREE_VERSION).replace(
        "<!--SCRIPTS-->",
        &format!("<script>{}</script><script>{}</script>", script_text(THREE_JS), script_text(STATION_JS)),
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_page_is_whole_and_offline() {
        let page = super::build();
        assert!(page.starts_with("<!DOCTYPE html>"));
        // No script, style or font from elsewhere: the station works with no network.
        for needle in ["src=\"http", "href=\"http", "@import", "cdn"] {
            assert!(!page.contains(needle), "the page reaches out: {needle}");
        }
        for id in ["take-control", "check-run", "live-take", "calib-held", "scan-start", "projects-table", "viewer3d"] {
            assert!(page.contains(&format!("id=\"{id}\"")), "no #{id}");
        }
        assert!(!super::STATION_JS.contains("</script"));
    }
}
