//! The viewer shows the cameras: it answers its own page only — a foreign `Host` (DNS
//! rebinding) or `Origin` (another web page's script) gets 403.

use crate::common;

use std::io::{Read, Write};
use std::net::TcpStream;

use flexshape_viewer::Viewer;

/// The status code of a request with these headers.
fn status(addr: std::net::SocketAddr, path: &str, headers: &[&str]) -> u16 {
    let mut s = TcpStream::connect(addr).unwrap();
    let mut request = format!("GET {path} HTTP/1.1\r\n");
    for h in headers {
        request.push_str(h);
        request.push_str("\r\n");
    }
    request.push_str("Connection: close\r\n\r\n");
    s.write_all(request.as_bytes()).unwrap();
    let mut reply = String::new();
    let _ = s.read_to_string(&mut reply);
    reply
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0)
}

#[test]
fn foreign_hosts_and_origins_are_refused() {
    let scene = common::scene();
    let viewer = Viewer::start("127.0.0.1:0", false, scene).unwrap();
    let addr = viewer.addr();
    let own = format!("Host: 127.0.0.1:{}", addr.port());
    assert_eq!(status(addr, "/", &[&own]), 200);
    let own_origin = format!("Origin: http://127.0.0.1:{}", addr.port());
    assert_eq!(status(addr, "/health", &[&own, &own_origin]), 200);
    assert_eq!(status(addr, "/", &["Host: attacker.example"]), 403);
    for origin in ["Origin: http://evil.example", "Origin: null"] {
        assert_eq!(status(addr, "/", &[&own, origin]), 403, "{origin}");
        // The WebSocket handshake too.
        let ws = [
            own.as_str(),
            origin,
            "Upgrade: websocket",
            "Connection: Upgrade",
            "Sec-WebSocket-Version: 13",
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        ];
        assert_eq!(status(addr, "/ws", &ws), 403, "{origin}");
    }
}
