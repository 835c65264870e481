//! The page skeleton: a title, sections with a navigation bar, an optional 3D viewer, and every
//! asset inlined so the file opens offline.

use crate::escape::{esc, href, script_text};
use crate::scene::Scene;
use std::fmt::Write as _;

/// The stylesheet every page inlines.
pub const CSS: &str = include_str!("../assets/page.css");
/// The viewer script (expects the global `THREE`).
pub const VIEWER_JS: &str = include_str!("../assets/viewer.js");
/// three.js 0.187.0 with OrbitControls, one classic script (see `assets/vendor/three-0.187.0/README.md`).
pub const THREE_JS: &str = include_str!("../assets/vendor/three-0.187.0/three.bundle.min.js");
/// The version of three.js inlined, named on every page with a viewer.
pub const THREE_VERSION: &str = "0.187.0";

/// A link from the folder `dir` to `file`: relative when `file` lies under `dir`, else its absolute
/// path (which a `file://` page resolves on the same machine). An empty `dir` is the current folder.
pub fn relative_link(file: &std::path::Path, dir: &std::path::Path) -> String {
    let dir = if dir.as_os_str().is_empty() { std::path::Path::new(".") } else { dir };
    let abs = |p: &std::path::Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (f, d) = (abs(file), abs(dir));
    f.strip_prefix(&d).map_or_else(|_| f.display().to_string(), |r| r.display().to_string())
}

/// A page being assembled.
#[derive(Debug, Default)]
pub struct Page {
    title: String,
    subtitle: String,
    sections: Vec<(String, String, String)>,
    scene: Option<Scene>,
}

impl Page {
    /// An empty page with a title (text) and a line under it (trusted markup the caller escaped).
    pub fn new(title: &str, subtitle: &str) -> Self {
        Page { title: title.into(), subtitle: subtitle.into(), ..Default::default() }
    }

    /// Appends a section (`id` is its anchor; `html` is trusted markup the caller escaped).
    pub fn section(&mut self, id: &str, heading: &str, html: String) {
        self.sections.push((id.into(), heading.into(), html));
    }

    /// Appends a section with a 3D viewer of `scene` and its notes (one viewer a page).
    pub fn viewer_section(&mut self, id: &str, heading: &str, scene: Scene) {
        let notes = scene.notes_html();
        self.scene = Some(scene);
        let html = format!(
            "<div class=\"viewer\"><canvas id=\"viewer-canvas\" class=\"viewer-canvas\" data-background=\"{bg}\"></canvas>\
             <div class=\"viewer-bar\"><span id=\"viewer-layers\"></span><button type=\"button\" id=\"viewer-reset\">Reset view</button>\
             <span id=\"viewer-pick\">Click a point or a surface to read its coordinates.</span></div>\
             <div id=\"viewer-legend\"></div></div>\
             <p class=\"note\">Left drag turns, right drag pans, the wheel zooms. Drawn by three.js {THREE_VERSION}. \
             <span id=\"viewer-status\">Loading…</span></p>{notes}",
            bg = crate::scene::BACKGROUND,
        );
        self.section(id, heading, html);
    }

    /// The whole page.
    pub fn render(&self) -> String {
        let mut h = String::with_capacity(1 << 20);
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
             <meta name=\"generator\" content=\"scanrig {}\"><title>{}</title><style>{CSS}</style>",
            env!("CARGO_PKG_VERSION"),
            esc(&self.title)
        );
        if self.scene.is_some() {
            // Read by the browser test: this page is ready once the viewer has drawn.
            h.push_str("<script>window.scanrigExpectsReady = true;</script>");
        }
        let _ =
            write!(h, "</head><body><header><h1>{}</h1><p class=\"note\">{}</p><nav>", esc(&self.title), self.subtitle);
        for (id, heading, _) in &self.sections {
            let _ = write!(h, "<a href=\"#{}\">{}</a>", esc(id), esc(heading));
        }
        h.push_str("</nav></header><main>");
        for (id, heading, html) in &self.sections {
            let _ = write!(h, "<section id=\"{}\"><h2>{}</h2>{html}</section>", esc(id), esc(heading));
        }
        h.push_str("</main>");
        if let Some(scene) = &self.scene {
            h.push_str(&scene.data_html());
            let _ = write!(h, "<script>{}</script><script>{}</script>", script_text(THREE_JS), script_text(VIEWER_JS));
        }
        h.push_str("</body></html>\n");
        h
    }
}

/// A two-column table of label and value rows (values are trusted markup).
pub fn facts(rows: &[(&str, String)]) -> String {
    let mut h = String::from("<table>");
    for (k, v) in rows {
        let _ = write!(h, "<tr><th>{}</th><td>{v}</td></tr>", esc(k));
    }
    h.push_str("</table>");
    h
}

/// A list of warnings, or a line saying there were none.
pub fn warnings(items: &[String]) -> String {
    if items.is_empty() {
        return "<p class=\"ok\">No warnings: every plausibility check passed.</p>".into();
    }
    list("warnings", items)
}

/// A list of plain-text items with a CSS class.
pub fn list(class: &str, items: &[String]) -> String {
    let mut h = format!("<ul class=\"{}\">", esc(class));
    for w in items {
        let _ = write!(h, "<li>{}</li>", esc(w));
    }
    h.push_str("</ul>");
    h
}

/// Links to files, relative to the page's folder.
pub fn file_links(files: &[String]) -> String {
    let mut h = String::from("<ul class=\"files\">");
    for f in files {
        let _ = write!(h, "<li><a href=\"{}\">{}</a></li>", esc(&href(f)), esc(f));
    }
    h.push_str("</ul>");
    h
}

/// The page without its inlined scripts and data: the markup a reader sees (for tests).
#[cfg(test)]
pub(crate) fn markup(html: &str) -> String {
    html.split("<script").map(|part| part.split_once("</script>").map_or(part, |(_, rest)| rest)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_are_relative_to_the_page() {
        assert_eq!(relative_link(std::path::Path::new("a/b.ply"), std::path::Path::new("")), "a/b.ply");
    }

    #[test]
    fn vendored_three_js_is_the_pinned_bundle() {
        // The bundle must not contain what would end or confuse the inline <script> it is put in.
        assert!(THREE_JS.len() > 500_000, "three.js bundle missing or truncated");
        assert!(!THREE_JS.contains("</script") && !THREE_JS.contains("<!--"));
        assert!(THREE_JS.contains("OrbitControls"));
        assert!(include_str!("../assets/vendor/three-0.187.0/LICENSE").contains("MIT License"));
    }

    proptest::proptest! {
        /// Whatever text a page is given (file names, warnings, layer names come from users' files),
        /// it cannot open or close an element, end a script early or break the page's structure.
        #[test]
        fn any_text_stays_text(
            title in ".*",
            warning in ".*",
            layer in proptest::prop_oneof![".*", proptest::strategy::Just("<!--<script></script>".to_string())],
        ) {
            let mut scene = crate::scene::Scene::new();
            scene.add_points(&layer, &[rig::math::Point3::origin()], None, true, None);
            scene.note(layer.clone());
            let mut p = Page::new(&title, &esc(&title));
            p.section("w", &warning, warnings(std::slice::from_ref(&warning)));
            p.viewer_section("v", &layer, scene);
            // The inlined scripts (checked above for what would end their element) aside.
            let h = p.render().replace(&script_text(THREE_JS), "").replace(&script_text(VIEWER_JS), "");
            proptest::prop_assert_eq!(h.matches("</html>").count(), 1);
            proptest::prop_assert_eq!(h.matches("<script").count(), h.matches("</script>").count());
            proptest::prop_assert_eq!(h.matches("<section").count(), 2);
            // The scene JSON still parses, and carries the layer's name as given.
            let json = h.split("id=\"scene\">").nth(1).unwrap().split("</script>").next().unwrap();
            let spec: serde_json::Value = serde_json::from_str(json).unwrap();
            proptest::prop_assert_eq!(spec["layers"][0]["name"].as_str().unwrap(), layer.as_str());
        }
    }

    #[test]
    fn a_page_without_a_viewer_carries_no_script() {
        let mut p = Page::new("T <1>", "sub");
        p.section("a", "A", "<p>x</p>".into());
        let h = p.render();
        assert!(h.contains("<title>T &lt;1&gt;</title>") && h.contains("<section id=\"a\">"));
        assert!(!h.contains("<script"), "no viewer, no script");
    }
}
