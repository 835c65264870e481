//! Text made safe for where a page puts it: HTML content and attributes, link targets, and the
//! insides of `<script>` elements. Every page and the viewer's scene use these; they depend on nothing
//! else in the crate (the page and the scene both import them, neither imports the other for them).

use std::fmt::Write as _;

/// Escapes text for HTML content and attribute values.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A relative link's `href`: path segments percent-encoded where HTML or URLs would misread them.
pub fn href(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    for b in path.bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' | b'/' => out.push(b as char),
            _ => {
                let _ = write!(out, "%{b:02X}");
            }
        }
    }
    out
}

/// Script source for inside a `<script>` element: `</` could end it early, so it is written `<\/`,
/// which JavaScript strings read back as `</` (the inlined scripts hold neither `<!--` nor `</script`;
/// a test checks).
pub fn script_text(s: &str) -> String {
    s.replace("</", "<\\/")
}

/// JSON for inside a `<script>` element: every `<` written `\u003c`, so no text in it (a file named
/// `<!--<script>.ply`) can end the element or put the HTML parser in a state where it would not end.
pub fn json_text(s: &str) -> String {
    s.replace('<', "\\u003c")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_and_script_ends() {
        assert_eq!(esc("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
        assert_eq!(script_text("a = '</script>'"), "a = '<\\/script>'");
        let j = json_text(&serde_json::json!({"s": "<!--<script></script>"}).to_string());
        assert!(!j.contains('<'));
        assert_eq!(serde_json::from_str::<serde_json::Value>(&j).unwrap()["s"], "<!--<script></script>");
        assert_eq!(href("views/view 1#.ply"), "views/view%201%23.ply");
    }
}
