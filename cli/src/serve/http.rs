//! The server's answers: the page's three files (compiled in: no path reaches the file
//! system), `/state`, `/events` (server-sent events) and `/frame`. Anything else is a 4xx
//! answer that changes nothing.

use std::io::Write;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use tiny_http::{Header, Method, Request, Response};

use super::frame::{self, FrameQuery};
use super::state::Shared;

/// The longest request target served, and the most bytes of headers.
const MAX_URL: usize = 2048;
const MAX_HEADERS: usize = 16 * 1024;
/// Requests handled at once, and `/events` streams open at once; beyond them, 503.
const MAX_REQUESTS: usize = 64;
const MAX_STREAMS: usize = 16;
/// A comment sent on a quiet event stream, so that a closed page's thread ends.
const KEEP_ALIVE: Duration = Duration::from_secs(15);

const INDEX: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/app.js");
const STYLE: &str = include_str!("page/style.css");

/// Nothing loaded from elsewhere, no inline code: the page's own files and its frames' blobs.
const POLICY: &str = "default-src 'self'; img-src 'self' blob:; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

/// `127.0.0.1:8421`, `[::1]:8421`: the host part of the page's address.
pub(super) fn host_of(address: SocketAddr) -> String {
    address.to_string()
}

/// The `Host` headers accepted: on a loopback address only its own names, so that a page of
/// another site cannot reach the server through a name it controls (DNS rebinding).
#[derive(Clone, Debug)]
pub(super) struct Origin {
    hosts: Option<Vec<String>>,
}

impl Origin {
    pub fn new(local: SocketAddr) -> Origin {
        let port = local.port();
        let hosts = local.ip().is_loopback().then(|| {
            vec![
                host_of(local),
                format!("localhost:{port}"),
                format!("127.0.0.1:{port}"),
                format!("[::1]:{port}"),
            ]
        });
        Origin { hosts }
    }

    fn allows(&self, request: &Request) -> bool {
        let Some(hosts) = &self.hosts else {
            return true;
        };
        let host = header(request, "Host").unwrap_or_default();
        hosts.iter().any(|h| h.eq_ignore_ascii_case(host))
    }
}

fn header<'a>(request: &'a Request, name: &'static str) -> Option<&'a str> {
    let found = request.headers().iter().find(|h| h.field.equiv(name));
    found.map(|h| h.value.as_str())
}

/// Decrements a counter when dropped.
struct Counted<'a>(&'a AtomicUsize);

impl<'a> Counted<'a> {
    /// Counts one more, unless `most` are counted already.
    fn take(counter: &'a AtomicUsize, most: usize) -> Option<Counted<'a>> {
        let taken = Counted(counter);
        (counter.fetch_add(1, Ordering::SeqCst) < most).then_some(taken)
    }
}

impl Drop for Counted<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// An answer: status, content type, body and further headers.
struct Reply {
    status: u16,
    content_type: &'static str,
    body: Vec<u8>,
    headers: Vec<(&'static str, String)>,
}

impl Reply {
    fn ok(content_type: &'static str, body: impl Into<Vec<u8>>) -> Reply {
        Reply {
            status: 200,
            content_type,
            body: body.into(),
            headers: Vec::new(),
        }
    }

    /// A refusal or failure, its reason in one line of text.
    fn error(status: u16, message: impl Into<String>) -> Reply {
        let mut body = message.into();
        body.push('\n');
        Reply {
            status,
            ..Reply::ok("text/plain; charset=utf-8", body)
        }
    }

    fn send(self, request: Request) {
        let mut response = Response::from_data(self.body).with_status_code(self.status);
        let fixed = [
            ("Content-Type", self.content_type.to_string()),
            ("Cache-Control", "no-store".into()),
            ("X-Content-Type-Options", "nosniff".into()),
            ("Referrer-Policy", "no-referrer".into()),
            ("Content-Security-Policy", POLICY.into()),
        ];
        for (name, value) in fixed.into_iter().chain(self.headers) {
            if let Ok(h) = Header::from_bytes(name.as_bytes(), value.as_bytes()) {
                response.add_header(h);
            }
        }
        // A page that went away is not the server's error.
        let _ = request.respond(response);
    }
}

/// Answers one request.
pub(super) fn handle(request: Request, shared: &Shared, origin: &Origin) {
    let Some(_counted) = Counted::take(&shared.requests, MAX_REQUESTS) else {
        return Reply::error(503, "too many requests at once").send(request);
    };
    if !origin.allows(&request) {
        return Reply::error(403, "unexpected Host header").send(request);
    }
    if !matches!(request.method(), Method::Get | Method::Head) {
        let mut reply = Reply::error(405, "only GET and HEAD");
        reply.headers.push(("Allow", "GET, HEAD".into()));
        return reply.send(request);
    }
    let headers: usize = (request.headers().iter())
        .map(|h| h.field.as_str().as_str().len() + h.value.as_str().len())
        .sum();
    if headers > MAX_HEADERS {
        return Reply::error(431, format!("headers over {MAX_HEADERS} bytes")).send(request);
    }
    let url = request.url();
    if url.len() > MAX_URL {
        return Reply::error(414, format!("request target over {MAX_URL} bytes")).send(request);
    }
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let reply = match path {
        "/" | "/index.html" => Reply::ok("text/html; charset=utf-8", INDEX),
        "/app.js" => Reply::ok("text/javascript; charset=utf-8", SCRIPT),
        "/style.css" => Reply::ok("text/css; charset=utf-8", STYLE),
        "/state" => Reply::ok(
            "application/json",
            serde_json::to_string(&shared.status()).expect("the status serialises"),
        ),
        "/events" => return events(request, shared),
        "/frame" => frame(query, shared),
        _ => Reply::error(404, "not found"),
    };
    reply.send(request)
}

/// `/frame?...`: the picture, with its time, rays, mode and version in headers.
fn frame(query: &str, shared: &Shared) -> Reply {
    let query = match FrameQuery::parse(query) {
        Ok(query) => query,
        Err(message) => return Reply::error(400, message),
    };
    match frame::render(shared, &query) {
        Ok(frame) => {
            let mut reply = Reply::ok("image/png", frame.png);
            reply.headers = vec![
                ("X-Frame-Seconds", frame.seconds.to_string()),
                ("X-Rays", frame.rays.to_string()),
                ("X-Mode", frame.mode),
                ("X-Version", frame.version.to_string()),
            ];
            reply
                .headers
                .extend(frame.summary.map(|s| ("X-Summary", s)));
            reply
        }
        Err((status, message)) => Reply::error(status, message),
    }
}

/// `/events`: the status now, then again whenever it changes, as server-sent events named
/// `state`; the stream ends when the page goes away.
fn events(request: Request, shared: &Shared) {
    let Some(_counted) = Counted::take(&shared.streams, MAX_STREAMS) else {
        return Reply::error(503, "too many event streams open").send(request);
    };
    let mut out = request.into_writer();
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n";
    let mut send = |text: &str| {
        out.write_all(text.as_bytes())
            .and_then(|()| out.flush())
            .is_ok()
    };
    if !send(head) {
        return;
    }
    let mut sent = None;
    loop {
        let status = shared.status.lock().expect("the status lock");
        let (status, waited) = match sent.as_ref() == Some(&*status) {
            true => {
                let (s, w) =
                    (shared.changed.wait_timeout(status, KEEP_ALIVE)).expect("the status lock");
                (s.clone(), w.timed_out())
            }
            false => (status.clone(), false),
        };
        let text = match (waited, sent.as_ref() == Some(&status)) {
            (true, true) => ": keep-alive\n\n".to_string(),
            (_, true) => continue,
            (_, false) => {
                let data = serde_json::to_string(&status).expect("the status serialises");
                format!("event: state\ndata: {data}\n\n")
            }
        };
        if !send(&text) {
            return;
        }
        sent = Some(status);
    }
}
