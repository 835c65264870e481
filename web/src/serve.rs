//! One page over HTTP on the loopback interface, for `scanrig view --serve`: a browser on the same
//! machine (or through an SSH tunnel) opens it without file access. Only `127.0.0.1` is bound, so
//! nothing is offered to the network.

use std::net::SocketAddr;

/// A page being served.
pub struct Server {
    server: tiny_http::Server,
    page: Vec<u8>,
}

impl Server {
    /// Binds `127.0.0.1:port` (0 picks a free port) to serve `page` at `/`.
    pub fn bind(page: String, port: u16) -> std::io::Result<Server> {
        let server = tiny_http::Server::http(("127.0.0.1", port)).map_err(std::io::Error::other)?;
        Ok(Server { server, page: page.into_bytes() })
    }

    /// The address bound.
    pub fn addr(&self) -> Option<SocketAddr> {
        self.server.server_addr().to_ip()
    }

    /// Answers requests until `stop` returns true (checked between requests and every half second):
    /// the page at `/` and `/index.html`, 404 elsewhere.
    pub fn run(&self, mut stop: impl FnMut() -> bool) -> std::io::Result<()> {
        while !stop() {
            let Some(request) = self.server.recv_timeout(std::time::Duration::from_millis(500))? else {
                continue;
            };
            // Only a browser that asked for this machine by its loopback name: a page elsewhere that
            // rebinds its own host name to 127.0.0.1 (DNS rebinding) sends its own name, and is refused.
            let port = self.addr().map_or(0, |a| a.port());
            let local = request.headers().iter().filter(|h| h.field.equiv("Host")).all(|h| {
                let host = h.value.as_str();
                host == format!("127.0.0.1:{port}") || host == format!("localhost:{port}")
            });
            let found = matches!(request.url(), "/" | "/index.html") && *request.method() == tiny_http::Method::Get;
            let response = if !local {
                tiny_http::Response::from_data(b"refused: not a loopback host name".to_vec()).with_status_code(403)
            } else if found {
                let header =
                    tiny_http::Header::from_bytes("Content-Type", "text/html; charset=utf-8").expect("a valid header");
                tiny_http::Response::from_data(self.page.clone()).with_header(header)
            } else {
                tiny_http::Response::from_data(b"not found: scanrig serves one page, at /".to_vec())
                    .with_status_code(404)
            };
            // A browser that went away mid-answer is not an error of ours.
            let _ = request.respond(response);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    fn get(addr: SocketAddr, path: &str, host: &str) -> String {
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        write!(s, "GET {path} HTTP/1.0\r\nHost: {host}\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    }

    #[test]
    fn serves_the_page_on_loopback_only() {
        let server = Server::bind("<p>hello</p>".into(), 0).unwrap();
        let addr = server.addr().unwrap();
        assert!(addr.ip().is_loopback());
        let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let d = done.clone();
        let t = std::thread::spawn(move || server.run(|| d.load(std::sync::atomic::Ordering::SeqCst)));
        let host = format!("127.0.0.1:{}", addr.port());
        let page = get(addr, "/", &host);
        assert!(page.starts_with("HTTP/1.0 200") && page.ends_with("<p>hello</p>"), "{page}");
        assert!(get(addr, "/etc/passwd", &host).starts_with("HTTP/1.0 404"));
        assert!(get(addr, "/", &format!("evil.example:{}", addr.port())).starts_with("HTTP/1.0 403"));
        done.store(true, std::sync::atomic::Ordering::SeqCst);
        t.join().unwrap().unwrap();
    }
}
