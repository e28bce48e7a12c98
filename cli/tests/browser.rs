//! `raycast serve`'s page in a real headless browser (Debian's Chromium, driven over WebDriver
//! by chromedriver): it shows the frame's exact pixels; a saved hook changes the picture within
//! 2 s; a broken hook shows its error with its line and keeps the picture; a drag orbits the
//! camera. A test binary of its own, so that no other test competes for the cores meanwhile.
//!
//! Needs `/usr/bin/chromium` and `/usr/bin/chromedriver` (Debian's `chromium` and
//! `chromium-driver`: `scripts/install-browser.sh`).
#![cfg(unix)]

#[path = "serving/mod.rs"]
mod serving;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use serving::{Server, exchange, hook};

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";
/// WebDriver's key for an element reference.
const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// A Chromium session through chromedriver, ended when dropped.
struct Browser {
    driver: Child,
    address: String,
    session: String,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn start() -> Browser {
        for program in [CHROMIUM, CHROMEDRIVER] {
            assert!(
                Path::new(program).exists(),
                "{program} is missing: install Debian's chromium and chromium-driver (scripts/install-browser.sh)"
            );
        }
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let driver = Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver runs");
        let address = format!("127.0.0.1:{port}");
        let start = Instant::now();
        while std::net::TcpStream::connect(&address).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "chromedriver listens"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let profile = tempfile::tempdir().unwrap();
        // As this machine's closed network needs: no background connections, no sandbox (root).
        let args = [
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
            "--window-size=1200,900",
            &format!("--user-data-dir={}", profile.path().display()),
        ];
        let capabilities = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": CHROMIUM, "args": args},
        }}});
        let mut browser = Browser {
            driver,
            address,
            session: String::new(),
            _profile: profile,
        };
        let created = browser.call("POST", "/session", Some(capabilities));
        browser.session = created["sessionId"].as_str().unwrap().to_string();
        browser
    }

    /// A WebDriver command; its `value`.
    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        let path = path.replace("{session}", &format!("/session/{}", self.session));
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let head = format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nContent-Type: application/json",
            self.address
        );
        let answer = exchange(&self.address, &head, body.as_bytes());
        let value: Value = serde_json::from_slice(&answer.body).expect("WebDriver answers JSON");
        assert_eq!(answer.status, 200, "{method} {path}: {value}");
        value["value"].clone()
    }

    fn open(&self, url: &str) {
        self.call("POST", "{session}/url", Some(json!({ "url": url })));
    }

    /// Runs `script` (a function body) in the page; its return value.
    fn script(&self, script: &str) -> Value {
        let body = json!({"script": script, "args": []});
        self.call("POST", "{session}/execute/sync", Some(body))
    }

    /// Polls `script` until it returns something other than null or false.
    fn wait_for(&self, what: &str, limit: Duration, script: &str) -> Value {
        let start = Instant::now();
        loop {
            let value = self.script(script);
            if !(value.is_null() || value == json!(false)) {
                return value;
            }
            assert!(start.elapsed() < limit, "{what}: not within {limit:?}");
            std::thread::sleep(Duration::from_millis(25));
        }
    }

    fn click(&self, css: &str) {
        let element = self.element(css);
        self.call(
            "POST",
            &format!("{{session}}/element/{element}/click"),
            Some(json!({})),
        );
    }

    fn element(&self, css: &str) -> String {
        let body = json!({"using": "css selector", "value": css});
        let found = self.call("POST", "{session}/element", Some(body));
        found[ELEMENT].as_str().unwrap().to_string()
    }

    /// Drags the mouse from the centre of `element` by `dx`, `dy` CSS pixels.
    fn drag(&self, element: &str, dx: i64, dy: i64) {
        let mut origin = serde_json::Map::new();
        origin.insert(ELEMENT.into(), element.into());
        let actions = json!({"actions": [{
            "type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [
                {"type": "pointerMove", "duration": 0, "origin": origin, "x": 0, "y": 0},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerMove", "duration": 300, "origin": "pointer", "x": dx, "y": dy},
                {"type": "pointerUp", "button": 0},
            ],
        }]});
        self.call("POST", "{session}/actions", Some(actions));
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let head = format!(
                "DELETE /session/{} HTTP/1.1\r\nHost: {}",
                self.session, self.address
            );
            let _ = std::panic::catch_unwind(|| exchange(&self.address, &head, b""));
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

fn base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=').map(value).collect();
    let mut out = Vec::new();
    for chunk in digits.chunks(4) {
        let bits =
            chunk.iter().fold(0u32, |acc, &d| acc << 6 | d as u32) << (6 * (4 - chunk.len()));
        out.extend_from_slice(&bits.to_be_bytes()[1..chunk.len()]);
    }
    out
}

/// RGBA pixels of a PNG (8 bits a channel; RGB gets alpha 255).
fn rgba(png_bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    pixels.truncate(info.buffer_size());
    let pixels = match info.color_type {
        png::ColorType::Rgba => pixels,
        png::ColorType::Rgb => pixels
            .chunks(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        other => panic!("unexpected colour type {other:?}"),
    };
    (info.width, info.height, pixels)
}

/// What the page shows: the query of the frame on screen and its pixels, read back through a
/// canvas.
fn shown(browser: &Browser) -> (String, (u32, u32, Vec<u8>)) {
    let value = browser.script(
        "const img = document.getElementById('picture');
         const canvas = document.createElement('canvas');
         canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
         canvas.getContext('2d').drawImage(img, 0, 0);
         return [img.dataset.query, canvas.toDataURL('image/png')];",
    );
    let url = value[1].as_str().unwrap();
    let data = url.strip_prefix("data:image/png;base64,").unwrap();
    (value[0].as_str().unwrap().to_string(), rgba(&base64(data)))
}

/// The page's picture is exactly the server's frame for the query it shows.
fn assert_shows_the_frame(browser: &Browser, server: &Server) -> (String, Vec<u8>) {
    let (query, (w, h, pixels)) = shown(browser);
    let frame = server.get(&format!("/frame?{query}"));
    assert_eq!(frame.status, 200, "{query}: {}", frame.text());
    let (fw, fh, expected) = rgba(&frame.body);
    assert_eq!((w, h), (fw, fh), "{query}");
    assert!(
        pixels == expected,
        "{query}: the page's pixels are not the frame's"
    );
    (query, pixels)
}

/// Waits until the page shows a full-size frame and has nothing in flight; the frame's query.
fn settled(browser: &Browser, what: &str, limit: Duration) -> Value {
    browser.wait_for(
        what,
        limit,
        "const r = window.raycast; const img = document.getElementById('picture');
         if (!r || r.busy || !r.frames || !img.complete) return null;
         const size = r.state && r.state.camera.size.join('x');
         return img.dataset.query && img.dataset.query.includes('size=' + size) ? img.dataset.query : null;",
    )
}

#[test]
fn the_page_shows_the_render_follows_saves_shows_errors_and_orbits() {
    let dir = tempfile::tempdir().unwrap();
    let hook_file = dir.path().join("hook.wgsl");
    std::fs::write(&hook_file, hook(0.0)).unwrap();
    let bunny = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/course/bunny.json");
    let raycast = Path::new(env!("CARGO_BIN_EXE_raycast"));
    let args = [
        bunny.to_str().unwrap(),
        "--shader",
        "hook.wgsl",
        "--size",
        "320x180",
    ];
    let server = Server::start(raycast, dir.path(), &args);
    let browser = Browser::start();
    browser.open(&format!("http://{}/", server.address));

    // The picture, pixel for pixel.
    settled(&browser, "the first frame", Duration::from_secs(60));
    let (first_query, first) = assert_shows_the_frame(&browser, &server);
    assert!(first_query.contains("tab=color"), "{first_query}");

    // A saved hook: the picture changes within 2 s of the write.
    let saved = Instant::now();
    std::fs::write(&hook_file, hook(0.25)).unwrap();
    browser.wait_for(
        "the new hook's picture",
        Duration::from_secs(2),
        "const img = document.getElementById('picture');
         return img.dataset.version === '2' && img.complete;",
    );
    let took = saved.elapsed();
    settled(&browser, "the new hook's frame", Duration::from_secs(10));
    let (_, changed) = assert_shows_the_frame(&browser, &server);
    assert!(changed != first, "the new hook's picture differs");
    eprintln!("saved hook to new picture: {took:?}");

    // A broken hook: its error, with its line, on the page; the picture stays.
    let frames = browser.script("return window.raycast.frames;");
    let broken = hook(0.25).replacen("1.0);\n", "1.0)\n", 1);
    std::fs::write(&hook_file, broken).unwrap();
    let error = browser.wait_for(
        "the hook's error",
        Duration::from_secs(5),
        "const e = document.getElementById('error');
         return e && !e.hidden && e.offsetParent !== null && e.textContent.includes('hook.wgsl:4:5') ? e.textContent : null;",
    );
    let error = error.as_str().unwrap();
    assert!(error.contains("error: expected `;`"), "{error}");
    assert!(
        error.lines().any(|l| l == "    }"),
        "the offending line: {error}"
    );
    assert_eq!(browser.script("return window.raycast.frames;"), frames);
    let (_, still) = shown(&browser);
    assert!(still.2 == changed, "the last good picture stays");

    // Mended, then a drag: the camera orbits (the eye keeps its distance to the point looked
    // at) and the picture is the new camera's.
    std::fs::write(&hook_file, hook(0.25)).unwrap();
    browser.wait_for(
        "the error to go",
        Duration::from_secs(5),
        "const e = document.getElementById('error'); return e.hidden || e.offsetParent === null;",
    );
    let camera = browser.script("return window.raycast.camera;");
    let picture = browser.element("#picture");
    browser.drag(&picture, 80, 30);
    let query = settled(&browser, "the orbited frame", Duration::from_secs(20));
    let moved = browser.script("return window.raycast.camera;");
    assert_ne!(moved["eye"], camera["eye"], "the drag moved the eye");
    assert_eq!(
        moved["look_at"], camera["look_at"],
        "an orbit keeps its centre"
    );
    let distance = |c: &Value| {
        let (eye, at) = (
            c["eye"].as_array().unwrap(),
            c["look_at"].as_array().unwrap(),
        );
        (0..3)
            .map(|i| (eye[i].as_f64().unwrap() - at[i].as_f64().unwrap()).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (before, after) = (distance(&camera), distance(&moved));
    assert!((after - before).abs() <= 1e-9 * before, "{before} {after}");
    let (_, orbited) = assert_shows_the_frame(&browser, &server);
    assert!(orbited != changed, "{query}: the orbited picture differs");

    // The CPU reference's difference on the depth tab: the heatmap, its summary, and no
    // colour tab (the reference runs no custom hook).
    browser.click("[data-tab=depth]");
    browser.click("[data-device=diff]");
    let query = settled(&browser, "the difference", Duration::from_secs(30));
    let query = query.as_str().unwrap();
    assert!(query.contains("tab=depth&device=diff"), "{query}");
    assert_shows_the_frame(&browser, &server);
    let stats = browser.script("return document.getElementById('stats').textContent;");
    assert!(
        stats.as_str().unwrap().contains("hit mismatches"),
        "{stats}"
    );
    let colour_off = browser.script("return document.querySelector('[data-tab=color]').disabled;");
    assert_eq!(colour_off, json!(true));
    assert!(took < Duration::from_secs(2), "{took:?}");
}
