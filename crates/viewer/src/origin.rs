//! Who may talk to the viewer: it shows the cameras, so a request is served only when its
//! `Host` names the viewer itself and its `Origin` (when a browser sends one) is the viewer's
//! own page. That stops other web pages the operator opens from reading the cameras through
//! the browser (cross-site WebSockets, DNS rebinding, which sends a foreign `Host`).

/// Which requests the viewer serves.
#[derive(Debug, Clone)]
pub(crate) struct Guard {
    /// The viewer's port.
    pub port: u16,
    /// Served on loopback only: `Host` must be `localhost`, `127.0.0.1` or `[::1]`. Otherwise
    /// (`--allow-remote`) any `Host`, but the `Origin` must still match it.
    pub loopback: bool,
}

impl Guard {
    /// Whether a request with these `Host` and `Origin` headers is served.
    pub fn allows(&self, host: Option<&str>, origin: Option<&str>) -> bool {
        let Some(host) = host else {
            return false;
        };
        let host = host.trim().to_ascii_lowercase();
        if self.loopback && !self.is_loopback_host(&host) {
            return false;
        }
        match origin {
            None => true,
            Some(origin) => {
                let origin = origin.trim().to_ascii_lowercase();
                origin == format!("http://{host}")
                    || (self.loopback
                        && origin
                            .strip_prefix("http://")
                            .is_some_and(|h| self.is_loopback_origin(h)))
            }
        }
    }

    /// An origin's `name:port` naming the viewer on loopback: a loopback name with the
    /// viewer's port (written out, or left implicit when the viewer serves on 80). A page on
    /// another port of the same machine is another origin.
    fn is_loopback_origin(&self, host: &str) -> bool {
        let explicit = host
            .rsplit_once(':')
            .is_some_and(|(_, port)| !port.ends_with(']'));
        (explicit || self.port == 80) && self.is_loopback_host(host)
    }

    /// `name` or `name:port` with the viewer's port, `name` a loopback name.
    fn is_loopback_host(&self, host: &str) -> bool {
        let name = match host.rsplit_once(':') {
            // `[::1]:8080`, `localhost:8080`; `[::1]` alone has colons inside the brackets.
            Some((name, port)) if !port.ends_with(']') => {
                if port.parse::<u16>() != Ok(self.port) {
                    return false;
                }
                name
            }
            _ => host,
        };
        matches!(name, "localhost" | "127.0.0.1" | "[::1]")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_viewers_serve_only_their_own_host_and_origin() {
        let g = Guard {
            port: 8080,
            loopback: true,
        };
        assert!(g.allows(Some("127.0.0.1:8080"), None));
        assert!(g.allows(Some("localhost:8080"), Some("http://localhost:8080")));
        assert!(g.allows(Some("[::1]:8080"), Some("http://[::1]:8080")));
        // DNS rebinding: a foreign name resolving to 127.0.0.1.
        assert!(!g.allows(Some("attacker.example:8080"), None));
        // Another page's script, or a sandboxed one.
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("http://evil.example")));
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("null")));
        // Another port on the same machine is another origin.
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("http://127.0.0.1:9999")));
        // …and so is the default port (80) an origin without one stands for.
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("http://localhost")));
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("http://127.0.0.1")));
        assert!(!g.allows(Some("127.0.0.1:8080"), Some("http://[::1]")));
        assert!(g.allows(Some("127.0.0.1:8080"), Some("http://localhost:8080")));
        let on_80 = Guard {
            port: 80,
            loopback: true,
        };
        assert!(on_80.allows(Some("localhost"), Some("http://127.0.0.1")));
        assert!(!g.allows(Some("127.0.0.1:9999"), None));
        assert!(!g.allows(None, None));
    }

    #[test]
    fn remote_viewers_serve_any_host_from_its_own_origin() {
        let g = Guard {
            port: 8080,
            loopback: false,
        };
        assert!(g.allows(Some("lab-pc.local:8080"), Some("http://lab-pc.local:8080")));
        assert!(g.allows(Some("10.0.0.5:8080"), None));
        assert!(!g.allows(Some("10.0.0.5:8080"), Some("http://evil.example")));
    }
}
