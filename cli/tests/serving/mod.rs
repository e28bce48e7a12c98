//! For the tests of `raycast serve`: the server as a child process, and a plain HTTP/1.1 client
//! (the server's requests, and WebDriver's).
// Each test binary uses part of it.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, ChildStderr, Command, Stdio};
use std::time::Duration;

/// An HTTP answer.
pub struct Answer {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Answer {
    pub fn header(&self, name: &str) -> Option<&str> {
        let found = self
            .headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name));
        found.map(|(_, v)| v.as_str())
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

/// Sends `head` (a request line and headers, without the blank line; `Connection: close` and
/// the body's length are added) and `body` to `address` (`host:port`), and reads the answer.
pub fn exchange(address: &str, head: &str, body: &[u8]) -> Answer {
    let mut stream = TcpStream::connect(address).expect("the server accepts");
    stream
        .set_read_timeout(Some(Duration::from_secs(120)))
        .unwrap();
    let request = format!(
        "{head}\r\nConnection: close\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    stream.write_all(request.as_bytes()).unwrap();
    stream.write_all(body).unwrap();
    read_answer(&mut stream)
}

/// Reads an answer: to its `Content-Length`, or to the end of a chunked body, or to the end of
/// the stream (some peers keep the connection open despite `Connection: close`).
fn read_answer(stream: &mut TcpStream) -> Answer {
    let mut bytes = Vec::new();
    let mut buffer = [0u8; 65536];
    loop {
        if bytes.windows(4).any(|w| w == b"\r\n\r\n") {
            let (_, headers, start) = head(&bytes);
            let field = |name: &str| {
                let found = headers.iter().find(|(n, _)| n.eq_ignore_ascii_case(name));
                found.map(|(_, v)| v.clone())
            };
            let length = field("Content-Length").map(|l| l.parse::<usize>().unwrap());
            let complete = match length {
                Some(n) => bytes.len() >= start + n,
                None => field("Transfer-Encoding").is_some() && bytes.ends_with(b"\r\n0\r\n\r\n"),
            };
            if complete {
                let n = length.unwrap_or(bytes.len() - start);
                return parse(&bytes[..start + n]);
            }
        }
        let n = stream.read(&mut buffer).expect("the answer arrives");
        if n == 0 {
            return parse(&bytes);
        }
        bytes.extend_from_slice(&buffer[..n]);
    }
}

/// `GET target` from the server at `address` with its own `Host` header.
pub fn get(address: &str, target: &str) -> Answer {
    exchange(
        address,
        &format!("GET {target} HTTP/1.1\r\nHost: {address}"),
        b"",
    )
}

/// The status and headers of an answer's head (up to the blank line, which `bytes` holds).
fn head(bytes: &[u8]) -> (u16, Vec<(String, String)>, usize) {
    let end = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a complete head");
    let text = String::from_utf8_lossy(&bytes[..end]);
    let mut lines = text.split("\r\n");
    let status = lines
        .next()
        .unwrap()
        .split(' ')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim().to_string(), v.trim().to_string()))
        .collect();
    (status, headers, end + 4)
}

/// A whole answer.
fn parse(bytes: &[u8]) -> Answer {
    let (status, headers, start) = head(bytes);
    let mut answer = Answer {
        status,
        headers,
        body: bytes[start..].to_vec(),
    };
    if answer
        .header("Transfer-Encoding")
        .is_some_and(|v| v.eq_ignore_ascii_case("chunked"))
    {
        answer.body = unchunk(&answer.body);
    }
    answer
}

fn unchunk(mut bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line_end = bytes.windows(2).position(|w| w == b"\r\n").unwrap();
        let size = std::str::from_utf8(&bytes[..line_end]).unwrap();
        let size = usize::from_str_radix(size.split(';').next().unwrap().trim(), 16).unwrap();
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&bytes[line_end + 2..line_end + 2 + size]);
        bytes = &bytes[line_end + 4 + size..];
    }
}

/// A running `raycast serve`, stopped with SIGTERM when dropped.
pub struct Server {
    pub child: Child,
    /// `127.0.0.1:PORT`.
    pub address: String,
    pub stderr: Option<ChildStderr>,
}

impl Server {
    /// Starts `raycast serve ARGS --port 0` in `dir` and waits for its address.
    pub fn start(raycast: &Path, dir: &Path, args: &[&str]) -> Server {
        let mut child = Command::new(raycast)
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .current_dir(dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the raycast binary runs");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let stderr = child.stderr.take();
        let Some(address) = line
            .strip_prefix("serving http://")
            .and_then(|rest| rest.split('/').next())
        else {
            let mut text = String::new();
            stderr.unwrap().read_to_string(&mut text).unwrap();
            panic!("serve did not start: {line:?} {text}");
        };
        Server {
            address: address.to_string(),
            child,
            stderr,
        }
    }

    pub fn get(&self, target: &str) -> Answer {
        get(&self.address, target)
    }

    /// Sends `signal` (`-INT`, `-TERM`) and returns the exit code and what it printed on stderr.
    pub fn stop(mut self, signal: &str) -> (Option<i32>, String) {
        signal_child(&self.child, signal);
        let status = self.child.wait().unwrap();
        let mut text = String::new();
        if let Some(mut e) = self.stderr.take() {
            e.read_to_string(&mut text).unwrap();
        }
        (status.code(), text)
    }
}

fn signal_child(child: &Child, signal: &str) {
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            signal_child(&self.child, "-TERM");
            let _ = self.child.wait();
        }
    }
}

/// A hook colouring hits by their normals, opaque, with a `tint` added: a page shows exactly
/// the PNG's levels, and another tint changes every pixel.
pub fn hook(tint: f32) -> String {
    format!(
        "fn shade(hit: ShadeHit) -> vec4<f32> {{\n    if (hit.id < 0) {{\n        return vec4<f32>(0.1, 0.1, {tint:?}, 1.0);\n    }}\n    let c = abs(hit.normal) * 0.5 + vec3<f32>({tint:?});\n    return vec4<f32>(c, 1.0);\n}}\n"
    )
}
