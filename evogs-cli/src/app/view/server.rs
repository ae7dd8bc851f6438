//! The viewer's HTTP server on 127.0.0.1 (`tiny_http`, one thread): the embedded page, the
//! scene description, the colours once and a frame per requested time (`docs/viewer.md`,
//! "Protocol").

use super::assets::{asset, content_type};
use super::frames::FrameSource;
use super::scene::SceneInfo;
use crate::app::error::CommandError;
use crate::app::{Reporter, interrupt};
use std::io::Read as _;
use std::time::Duration;
use tiny_http::{Header, Method, Request, Response, Server, StatusCode};

/// The longest request line path accepted (longer: 414).
pub const MAX_URL_BYTES: usize = 2048;
/// The largest body accepted (the page's log messages; larger: 413).
pub const MAX_BODY_BYTES: usize = 4096;

/// What a request is answered with.
struct Reply {
    status: u16,
    kind: &'static str,
    body: Vec<u8>,
}

impl Reply {
    fn ok(kind: &'static str, body: Vec<u8>) -> Self {
        Self {
            status: 200,
            kind,
            body,
        }
    }
    fn text(status: u16, msg: &str) -> Self {
        Self {
            status,
            kind: "text/plain; charset=utf-8",
            body: msg.as_bytes().to_vec(),
        }
    }
}

/// A bound viewer server, not yet answering.
pub struct ViewServer {
    server: Server,
    port: u16,
    scene_json: Vec<u8>,
    static_bin: Vec<u8>,
    frames: FrameSource,
}

impl std::fmt::Debug for ViewServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ViewServer")
            .field("port", &self.port)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

/// The value of `key` in a query string (`t=0.5&x=1`), undecoded.
fn query_value<'a>(query: &'a str, key: &str) -> Option<&'a str> {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find_map(|(k, v)| (k == key).then_some(v))
}

impl ViewServer {
    /// Binds 127.0.0.1:`port` (a free port when `None`).
    ///
    /// # Errors
    /// The port is taken or cannot be bound.
    pub fn bind(
        port: Option<u16>,
        scene: &SceneInfo,
        static_bin: Vec<u8>,
        frames: FrameSource,
    ) -> Result<Self, CommandError> {
        let addr = format!("127.0.0.1:{}", port.unwrap_or(0));
        let server = Server::http(&addr)
            .map_err(|e| CommandError::new(format!("cannot listen on {addr}: {e}")))?;
        let port = server
            .server_addr()
            .to_ip()
            .map(|a| a.port())
            .ok_or_else(|| CommandError::new(format!("{addr}: not an IP address")))?;
        Ok(Self {
            server,
            port,
            scene_json: serde_json::to_vec(scene).unwrap_or_default(),
            static_bin,
            frames,
        })
    }

    /// The page's address.
    #[must_use]
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }

    /// Answers requests until an interrupt (Ctrl-C). Page log messages are passed to `rep`
    /// as `page: ...` lines.
    ///
    /// # Errors
    /// None yet; the signature leaves room for a fatal server error.
    pub fn serve(mut self, rep: &mut dyn Reporter) -> Result<(), CommandError> {
        loop {
            if interrupt::take() {
                rep.info("stopped");
                return Ok(());
            }
            let req = match self.server.recv_timeout(Duration::from_millis(200)) {
                Ok(Some(r)) => r,
                Ok(None) => continue,
                Err(e) => return Err(CommandError::new(format!("server: {e}"))),
            };
            self.answer(req, rep);
        }
    }

    fn answer(&mut self, mut req: Request, rep: &mut dyn Reporter) {
        let reply = self.route(&mut req, rep);
        let mut resp = Response::from_data(reply.body).with_status_code(StatusCode(reply.status));
        for (k, v) in [
            ("Content-Type", reply.kind),
            ("Cache-Control", "no-store"),
            ("X-Content-Type-Options", "nosniff"),
        ] {
            if let Ok(h) = Header::from_bytes(k.as_bytes(), v.as_bytes()) {
                resp.add_header(h);
            }
        }
        // A page that went away before its answer is not an error of the server.
        let _ = req.respond(resp);
    }

    fn route(&mut self, req: &mut Request, rep: &mut dyn Reporter) -> Reply {
        let url = req.url().to_string();
        if url.len() > MAX_URL_BYTES {
            return Reply::text(414, "request line too long");
        }
        let (path, query) = url.split_once('?').unwrap_or((&url, ""));
        let path = path.trim_start_matches('/');
        match (req.method(), path) {
            (Method::Get, "scene.json") => Reply::ok("application/json", self.scene_json.clone()),
            (Method::Get, "static.bin") => {
                Reply::ok("application/octet-stream", self.static_bin.clone())
            }
            (Method::Get, "frame") => {
                let Some(t) = query_value(query, "t").and_then(|v| v.parse::<f64>().ok()) else {
                    return Reply::text(400, "frame needs ?t=TIME (a number)");
                };
                match self.frames.frame(t) {
                    Ok(b) => Reply::ok("application/octet-stream", b.to_vec()),
                    Err(e) => Reply::text(422, &e),
                }
            }
            (Method::Post, "log") => {
                if req.body_length().is_some_and(|n| n > MAX_BODY_BYTES) {
                    return Reply::text(413, "log message too long");
                }
                let mut body = String::new();
                let limit = u64::try_from(MAX_BODY_BYTES).unwrap_or(u64::MAX);
                if req
                    .as_reader()
                    .take(limit)
                    .read_to_string(&mut body)
                    .is_err()
                {
                    return Reply::text(400, "log message is not UTF-8");
                }
                let line: String = body.chars().filter(|c| !c.is_control()).collect();
                rep.info(&format!("page: {line}"));
                Reply::text(204, "")
            }
            (Method::Get, p) => asset(p).map_or_else(
                || Reply::text(404, "not found"),
                |f| {
                    let kind = content_type(&f.path().to_string_lossy());
                    Reply::ok(kind, f.contents().to_vec())
                },
            ),
            _ => Reply::text(405, "method not allowed"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::query_value;

    #[test]
    fn query_values_are_found_by_key() {
        assert_eq!(query_value("t=0.5&camera=2", "camera"), Some("2"));
        assert_eq!(query_value("tt=1&t=-3", "t"), Some("-3"));
        assert_eq!(query_value("x", "t"), None);
    }
}
