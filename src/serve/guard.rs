//! Who the editor answers: pages of its own, not every page in the user's browser.
//!
//! Two attacks reach a server on loopback through the user's browser. DNS rebinding: a page at
//! `evil.example` re-points its own name to 127.0.0.1 and reads the editor's puppet and
//! textures as if same-origin — its requests carry `Host: evil.example`, so only the names
//! the editor serves are answered. Cross-site requests: any page may POST a "simple" request
//! (`text/plain`, a form) to the editor without asking; its browser names the page in `Origin`
//! (and `Sec-Fetch-Site`), so a request that changes anything is refused from any other origin.
//! Requests without these headers come from programs, not pages, and are let through.

use std::net::{IpAddr, SocketAddr};

use axum::extract::{Request, State};
use axum::http::{header, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;

/// The host names and port the editor serves.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostGuard {
    /// The address it listens on; an unspecified one (0.0.0.0) serves any address of the machine.
    address: SocketAddr,
}

impl HostGuard {
    /// The guard of a server listening on `address`: loopback names (`localhost`, 127.0.0.1,
    /// `[::1]`) and the listening address itself; any IP address when it listens on all of them.
    pub fn new(address: SocketAddr) -> Self {
        HostGuard { address }
    }

    /// Whether a `Host` header's value (`name` or `name:port`) names this server.
    pub fn serves_host(&self, host: &str) -> bool {
        let name = strip_port(host);
        if name.eq_ignore_ascii_case("localhost") {
            return true;
        }
        let Ok(ip) = name.trim_start_matches('[').trim_end_matches(']').parse::<IpAddr>() else {
            // A name: only a loopback name is known to be this machine (a page may own any other).
            return false;
        };
        ip.is_loopback() || ip == self.address.ip() || self.address.ip().is_unspecified()
    }

    /// Whether an `Origin` header's value is a page of this server (same scheme, host and port).
    pub fn serves_origin(&self, origin: &str) -> bool {
        let Some(authority) = origin.strip_prefix("http://") else {
            return false;
        };
        let port = authority.rsplit_once(':').filter(|(_, p)| !p.contains(']')).map(|(_, p)| p);
        let port = match port {
            Some(p) => p.parse::<u16>().ok(),
            None => Some(80),
        };
        port == Some(self.address.port()) && self.serves_host(authority)
    }

    /// Why `request` is refused, if it is.
    fn refusal(&self, request: &Request) -> Option<String> {
        let text = |name: header::HeaderName| request.headers().get(name).map(|v| v.to_str().unwrap_or(""));
        if let Some(host) = text(header::HOST) {
            if !self.serves_host(host) {
                return Some(format!(
                    "this editor answers only for localhost and this machine's own addresses, not host {host:?}"
                ));
            }
        }
        let reads = matches!(*request.method(), Method::GET | Method::HEAD);
        if reads {
            return None;
        }
        if let Some(origin) = text(header::ORIGIN) {
            if !self.serves_origin(origin) {
                return Some(format!("this editor takes changes only from its own pages, not from {origin:?}"));
            }
        }
        if text(header::HeaderName::from_static("sec-fetch-site")) == Some("cross-site") {
            return Some("this editor takes changes only from its own pages, not from another site".into());
        }
        None
    }
}

/// The part of a `Host` value before its port (`[::1]:8080` → `[::1]`).
fn strip_port(host: &str) -> &str {
    match host.rsplit_once(':') {
        Some((name, port)) if !port.contains(']') && port.bytes().all(|b| b.is_ascii_digit()) => name,
        _ => host,
    }
}

/// The middleware: a request the guard refuses is answered 403 with its reason, and goes no
/// further.
pub async fn check(State(guard): State<HostGuard>, request: Request, next: Next) -> Response {
    match guard.refusal(&request) {
        Some(message) => ApiError {
            status: StatusCode::FORBIDDEN,
            message,
        }
        .into_response(),
        None => next.run(request).await,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(address: &str) -> HostGuard {
        HostGuard::new(address.parse().unwrap())
    }

    #[test]
    fn loopback_names_and_the_listening_address_are_served_and_other_names_are_not() {
        let g = guard("127.0.0.1:8080");
        for host in [
            "localhost",
            "LOCALHOST:8080",
            "127.0.0.1:8080",
            "127.0.0.1",
            "[::1]:8080",
            "127.0.0.2",
        ] {
            assert!(g.serves_host(host), "{host}");
        }
        for host in [
            "evil.example.com",
            "evil.example.com:8080",
            "192.168.1.5:8080",
            "localhost.evil.com",
            "",
        ] {
            assert!(!g.serves_host(host), "{host}");
        }
        let lan = guard("192.168.1.5:8080");
        assert!(lan.serves_host("192.168.1.5:8080"));
        assert!(!lan.serves_host("10.0.0.1:8080"));
        let all = guard("0.0.0.0:8080");
        assert!(all.serves_host("10.0.0.1:8080"), "listening everywhere serves every address");
        assert!(!all.serves_host("evil.example.com"), "but still no name a page could own");
    }

    #[test]
    fn only_the_editors_own_origin_is_its_own() {
        let g = guard("127.0.0.1:8080");
        for origin in ["http://127.0.0.1:8080", "http://localhost:8080", "http://[::1]:8080"] {
            assert!(g.serves_origin(origin), "{origin}");
        }
        for origin in [
            "http://evil.example.com:8080",
            "http://localhost:3000",
            "http://localhost",
            "https://localhost:8080",
            "null",
            "http://[::1]",
        ] {
            assert!(!g.serves_origin(origin), "{origin}");
        }
        assert!(guard("127.0.0.1:80").serves_origin("http://localhost"));
    }
}
