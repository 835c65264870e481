//! Who may ask the station what: the host name a browser used, the token a station bound beyond
//! the loopback interface asks for, and which files under `--data` a path may name. Each check is a
//! plain function of the request's text, so the refusals are tested without a server.

use std::path::{Component, Path, PathBuf};

/// Why a request is refused before it reaches a handler.
#[derive(Debug, PartialEq, Eq)]
pub enum Refusal {
    /// 403: a host name that is not this machine's loopback name (DNS rebinding), or no token where
    /// one is needed.
    Forbidden(String),
    /// 400: a path that could leave the served folders.
    BadPath(String),
    /// 404: nothing there.
    NotFound(String),
}

impl Refusal {
    /// The HTTP status.
    pub fn status(&self) -> u16 {
        match self {
            Refusal::Forbidden(_) => 403,
            Refusal::BadPath(_) => 400,
            Refusal::NotFound(_) => 404,
        }
    }

    /// The message the page shows.
    pub fn message(&self) -> &str {
        match self {
            Refusal::Forbidden(m) | Refusal::BadPath(m) | Refusal::NotFound(m) => m,
        }
    }
}

/// How the station was bound: on the loopback interface any local browser may use it (by its
/// loopback name); elsewhere every request carries the token printed at start.
#[derive(Debug, Clone)]
pub struct Access {
    /// Bound to a loopback address.
    pub loopback: bool,
    /// The port bound (for the Host check).
    pub port: u16,
    /// The token a non-loopback station asks for (`None` on loopback).
    pub token: Option<String>,
}

impl Access {
    /// Checks a request's Host header (on loopback) and token (elsewhere). `token` is what the
    /// request carried: the `X-Scanrig-Token` header or the `token` query parameter.
    pub fn admit(&self, host: Option<&str>, token: Option<&str>) -> Result<(), Refusal> {
        if let Some(want) = &self.token {
            // A constant-time comparison is moot for a token read once from a terminal, but cheap.
            let given = token.unwrap_or("");
            let same =
                given.len() == want.len() && given.bytes().zip(want.bytes()).fold(0u8, |a, (x, y)| a | (x ^ y)) == 0;
            if !same {
                return Err(Refusal::Forbidden(
                    "refused: this station is bound beyond the loopback interface; open the address with the \
                     ?token=… printed when it started"
                        .into(),
                ));
            }
            return Ok(());
        }
        if self.loopback {
            let port = self.port;
            // A browser leaves the port out of Host for port 80.
            let ok = host.is_none_or(|h| {
                let (name, p) = match h.rsplit_once(':') {
                    Some((n, p)) if !n.is_empty() && !p.contains(']') => (n, p),
                    _ => (h, "80"),
                };
                matches!(name, "127.0.0.1" | "localhost" | "[::1]") && p == port.to_string()
            });
            if !ok {
                return Err(Refusal::Forbidden("refused: not a loopback host name".into()));
            }
        }
        Ok(())
    }
}

/// The value of `key` in a URL's query string (percent-decoded), if present.
pub fn query_value(url: &str, key: &str) -> Option<String> {
    let query = url.split_once('?')?.1;
    query.split('&').find_map(|kv| {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        (k == key).then(|| percent_encoding::percent_decode_str(v).decode_utf8_lossy().into_owned())
    })
}

/// The `scanrig_token` cookie's value in a Cookie header.
pub fn cookie_token(cookies: &str) -> Option<String> {
    cookies.split(';').find_map(|c| c.trim().strip_prefix("scanrig_token=").map(str::to_string))
}

/// A URL's path without its query, percent-decoded once, and refused when it could name anything
/// outside the folder it is resolved in: `..` or `.` segments (also encoded, `%2e%2e`), a
/// backslash, a NUL, an encoded slash or a `%` left after decoding (double encoding, `%252e`).
pub fn clean_path(url: &str) -> Result<String, Refusal> {
    let raw = url.split(['?', '#']).next().unwrap_or("");
    let bad = |why: &str| Refusal::BadPath(format!("refused: the path {raw:?} {why}"));
    // An encoded slash would turn one segment into two after the check.
    let lower = raw.to_ascii_lowercase();
    if lower.contains("%2f") || lower.contains("%5c") {
        return Err(bad("hides a slash in an escape"));
    }
    let decoded =
        percent_encoding::percent_decode_str(raw).decode_utf8().map_err(|_| bad("is not UTF-8 once decoded"))?;
    if decoded.contains('%') {
        return Err(bad("is encoded twice"));
    }
    if decoded.contains('\\') || decoded.contains('\0') {
        return Err(bad("holds a backslash or a NUL"));
    }
    if decoded.split('/').any(|s| s == ".." || s == ".") {
        return Err(bad("steps out of its folder (`..`)"));
    }
    Ok(decoded.into_owned())
}

/// `relative` (a cleaned path's tail) as a file under `root`: only normal components, and the file
/// found must still lie under `root` once links are resolved.
pub fn file_under(root: &Path, relative: &str) -> Result<PathBuf, Refusal> {
    let rel = Path::new(relative.trim_start_matches('/'));
    if rel.components().any(|c| !matches!(c, Component::Normal(_))) || rel.as_os_str().is_empty() {
        return Err(Refusal::BadPath(format!("refused: {relative:?} is not a file under the data folder")));
    }
    let joined = root.join(rel);
    let (Ok(real), Ok(real_root)) = (joined.canonicalize(), root.canonicalize()) else {
        return Err(Refusal::NotFound(format!("not found: {relative}")));
    };
    if !real.starts_with(&real_root) {
        return Err(Refusal::BadPath(format!("refused: {relative:?} leads out of the data folder")));
    }
    Ok(real)
}

/// A fresh random token: 128 bits from the operating system, in hex.
pub fn new_token() -> std::io::Result<String> {
    use std::io::Read;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_that_leave_their_folder_are_refused_in_every_spelling() {
        for p in [
            "/files/../etc/passwd",
            "/files/%2e%2e/etc/passwd",
            "/files/%2E%2E/x",
            "/files/..%2fetc",
            "/files/a/%252e%252e/b",
            "/files/a\\..\\b",
            "/files/a/./b",
            "/files/a%00b",
        ] {
            assert!(clean_path(p).is_err(), "{p} was let through");
        }
        assert_eq!(
            clean_path("/files/scan%201/processed/report.html?x=1").unwrap(),
            "/files/scan 1/processed/report.html"
        );
    }

    #[test]
    fn loopback_names_only_and_the_token_beyond_loopback() {
        let local = Access { loopback: true, port: 8720, token: None };
        assert!(local.admit(Some("127.0.0.1:8720"), None).is_ok());
        assert!(local.admit(Some("localhost:8720"), None).is_ok());
        assert!(local.admit(Some("evil.example:8720"), None).is_err());
        assert!(local.admit(Some("localhost"), None).is_err(), "port 80 only");
        assert!(Access { loopback: true, port: 80, token: None }.admit(Some("localhost"), None).is_ok());
        assert_eq!(cookie_token("a=1; scanrig_token=abc; b=2").as_deref(), Some("abc"));
        let wide = Access { loopback: false, port: 8720, token: Some("abc123".into()) };
        assert!(wide.admit(Some("scanner.lan:8720"), None).is_err());
        assert!(wide.admit(Some("scanner.lan:8720"), Some("abc12")).is_err());
        assert!(wide.admit(Some("scanner.lan:8720"), Some("abc123")).is_ok());
        assert_eq!(query_value("/api/events?x=1&token=ab%20c", "token").as_deref(), Some("ab c"));
    }

    #[test]
    fn files_resolve_under_the_root_only() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("scan")).unwrap();
        std::fs::write(dir.path().join("scan/a.txt"), "a").unwrap();
        assert!(file_under(dir.path(), "scan/a.txt").is_ok());
        assert!(file_under(dir.path(), "/scan/a.txt").is_ok());
        assert!(file_under(dir.path(), "scan/../../x").is_err());
        assert!(file_under(dir.path(), "").is_err());
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("/etc", dir.path().join("scan/out")).unwrap();
            assert!(file_under(dir.path(), "scan/out/hostname").is_err());
        }
    }
}
