//! `raycast serve` over HTTP: its frames are the files `raycast render` and `raycast compare`
//! write for the same camera, a saved file is pushed to the page as an event (an error with its
//! line), bad requests get a 4xx answer and change nothing, and SIGINT or SIGTERM stop it.
#![cfg(unix)]

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::{raycast, repo_path};
use crate::serving::{Server, exchange, hook};

const SIZE: &str = "160x90";

fn binary() -> &'static Path {
    Path::new(env!("CARGO_BIN_EXE_raycast"))
}

/// The bunny with the test hook in `dir/hook.wgsl`, at [`SIZE`].
fn serve_bunny(dir: &Path, extra: &[&str]) -> Server {
    std::fs::write(dir.join("hook.wgsl"), hook(0.0)).unwrap();
    let bunny = repo_path("scenes/course/bunny.json");
    let mut args = vec![bunny.to_str().unwrap(), "--size", SIZE];
    args.extend(extra);
    Server::start(binary(), dir, &args)
}

fn state(server: &Server) -> serde_json::Value {
    let answer = server.get("/state");
    assert_eq!(answer.status, 200, "{}", answer.text());
    serde_json::from_slice(&answer.body).unwrap()
}

/// The scene camera's eye, moved, and its look_at and up, as `--eye X,Y,Z`, `--look-at`, `--up`
/// values.
fn moved_camera(state: &serde_json::Value) -> [String; 3] {
    let vector = |name: &str, shift: [f64; 3]| {
        let v = state["camera"][name].as_array().unwrap();
        let v: Vec<String> = (v.iter().zip(shift))
            .map(|(x, s)| (x.as_f64().unwrap() + s).to_string())
            .collect();
        v.join(",")
    };
    [
        vector("eye", [0.3, 0.2, 0.1]),
        vector("look_at", [0.0; 3]),
        vector("up", [0.0; 3]),
    ]
}

fn render_files(out: &Path, args: &[&str]) {
    let bunny = repo_path("scenes/course/bunny.json");
    let output = raycast()
        .arg("render")
        .arg(bunny)
        .args(["--size", SIZE, "-o"])
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    assert!(output.status.success(), "{:?}", output);
}

#[test]
fn frames_are_the_files_render_and_compare_write() {
    let dir = tempfile::tempdir().unwrap();
    let server = serve_bunny(dir.path(), &["--shader", "hook.wgsl"]);
    let [eye, look_at, up] = moved_camera(&state(&server));
    let camera = format!("eye={eye}&look_at={look_at}&up={up}&size={SIZE}");
    let flags = ["--eye", &eye, "--look-at", &look_at, "--up", &up];

    // Both without --precision: serve's default is render's (f32 with a hook).
    let gpu = dir.path().join("gpu");
    let hook_file = dir.path().join("hook.wgsl");
    let mut args = vec!["--shader", hook_file.to_str().unwrap()];
    args.extend(flags);
    render_files(&gpu, &args);
    for (tab, file) in [
        ("color", "color.png"),
        ("id", "id.png"),
        ("depth", "depth.png"),
        ("normal", "normal.png"),
    ] {
        let answer = server.get(&format!("/frame?tab={tab}&device=gpu&{camera}"));
        assert_eq!(answer.status, 200, "{tab}: {}", answer.text());
        assert_eq!(answer.header("Content-Type"), Some("image/png"));
        assert_eq!(answer.header("X-Mode"), Some("gpu:f32:robust"));
        assert_eq!(answer.header("X-Rays"), Some("14400"));
        assert_eq!(answer.header("X-Version"), Some("1"));
        let seconds: f64 = answer.header("X-Frame-Seconds").unwrap().parse().unwrap();
        assert!(seconds > 0.0 && seconds < 60.0, "{seconds}");
        let written = std::fs::read(gpu.join(file)).unwrap();
        assert!(answer.body == written, "{tab}: the frame is not {file}");
    }

    let cpu = dir.path().join("cpu");
    let mut args = vec!["--device", "cpu", "--precision", "f64"];
    args.extend(flags);
    render_files(&cpu, &args);
    for (tab, file) in [("id", "id.png"), ("depth", "depth.png")] {
        let answer = server.get(&format!("/frame?tab={tab}&device=cpu&{camera}"));
        assert_eq!(answer.status, 200, "{tab}: {}", answer.text());
        assert_eq!(answer.header("X-Mode"), Some("cpu:f64:robust"));
        assert!(
            answer.body == std::fs::read(cpu.join(file)).unwrap(),
            "cpu {tab}"
        );
    }
    let refused = server.get(&format!("/frame?tab=color&device=cpu&{camera}"));
    assert_eq!(refused.status, 400);
    assert!(
        refused.text().contains("no custom shade hook"),
        "{}",
        refused.text()
    );

    // The difference at the scene's own camera is `raycast compare`'s pictures.
    let compared = dir.path().join("compare");
    let output = raycast()
        .args(["compare", "scenes/course/bunny.json", "--size", SIZE])
        .args(["--a", "gpu:f32", "--b", "cpu:f64", "-o"])
        .arg(&compared)
        .output()
        .unwrap();
    assert!(output.status.success(), "{output:?}");
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    for (tab, file) in [("depth", "distance_error.png"), ("id", "mismatch.png")] {
        let answer = server.get(&format!("/frame?tab={tab}&device=diff&size={SIZE}"));
        assert_eq!(answer.status, 200, "{tab}: {}", answer.text());
        let written = std::fs::read(compared.join(file)).unwrap();
        assert!(
            answer.body == written,
            "diff {tab}: the frame is not {file}"
        );
        let summary = answer.header("X-Summary").unwrap();
        let expected = format!(
            "{} hit mismatches, {} id mismatches",
            report["hit_mismatch"], report["id_mismatch"]
        );
        assert!(summary.starts_with(&expected), "{summary} / {expected}");
    }
}

/// Reads server-sent events from `/events` until one satisfies `wanted`, for at most `limit`.
fn next_event(
    reader: &mut BufReader<TcpStream>,
    limit: Duration,
    wanted: impl Fn(&serde_json::Value) -> bool,
) -> serde_json::Value {
    let start = Instant::now();
    let mut line = String::new();
    loop {
        assert!(start.elapsed() < limit, "no such event within {limit:?}");
        line.clear();
        reader.read_line(&mut line).expect("the stream stays open");
        if let Some(data) = line.strip_prefix("data: ") {
            let state: serde_json::Value = serde_json::from_str(data).unwrap();
            if wanted(&state) {
                return state;
            }
        }
    }
}

#[test]
fn a_saved_file_reaches_the_page_as_an_event_and_a_broken_one_as_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let server = serve_bunny(dir.path(), &["--shader", "hook.wgsl"]);
    let mut stream = TcpStream::connect(&server.address).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let head = format!("GET /events HTTP/1.1\r\nHost: {}\r\n\r\n", server.address);
    stream.write_all(head.as_bytes()).unwrap();
    let mut reader = BufReader::new(stream);
    let first = next_event(&mut reader, Duration::from_secs(10), |_| true);
    assert_eq!(first["version"], 1);
    assert!(first["error"].is_null());
    let before = server.get(&format!("/frame?size={SIZE}"));

    std::fs::write(dir.path().join("hook.wgsl"), hook(0.25)).unwrap();
    let changed = next_event(&mut reader, Duration::from_secs(5), |s| s["version"] == 2);
    assert!(changed["error"].is_null());
    let after = server.get(&format!("/frame?size={SIZE}"));
    assert_eq!(after.header("X-Version"), Some("2"));
    assert!(after.body != before.body, "the new hook's frame differs");

    // Line 3 of the hook loses its semicolon: the error names the file, line and column, and
    // quotes the line; frames still render with the last good hook.
    let broken = hook(0.25).replacen("1.0);\n", "1.0)\n", 1);
    std::fs::write(dir.path().join("hook.wgsl"), &broken).unwrap();
    let failed = next_event(&mut reader, Duration::from_secs(5), |s| {
        !s["error"].is_null()
    });
    let error = failed["error"].as_str().unwrap();
    assert!(error.contains("hook.wgsl:4:5: error:"), "{error}");
    assert!(error.contains("    }"), "{error}");
    assert_eq!(failed["version"], 2);
    let still = server.get(&format!("/frame?size={SIZE}"));
    assert!(still.body == after.body, "the last good hook renders");

    std::fs::write(dir.path().join("hook.wgsl"), hook(0.0)).unwrap();
    let mended = next_event(&mut reader, Duration::from_secs(5), |s| s["version"] == 3);
    assert!(mended["error"].is_null());
    let again = server.get(&format!("/frame?size={SIZE}"));
    assert!(
        again.body == before.body,
        "the first hook again, the first frame again"
    );
}

#[test]
fn bad_requests_get_a_4xx_answer_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = serve_bunny(dir.path(), &[]);
    let address = server.address.clone();
    let frame = format!("/frame?tab=normal&size={SIZE}");
    let before = server.get(&frame);
    assert_eq!(before.status, 200);
    // Without a hook or --precision, render's default.
    assert_eq!(before.header("X-Mode"), Some("gpu:adaptive:robust"));
    let state_before = state(&server);
    let long = format!("/frame?tab={}", "x".repeat(5000));
    let gets: [(&str, u16, &str); 18] = [
        ("/../../etc/passwd", 404, "not found"),
        ("/%2e%2e/%2e%2e/etc/passwd", 404, "not found"),
        ("/scenes/course/bunny.json", 404, "not found"),
        ("/frame?size=100000x2", 400, "size: at most 4096"),
        ("/frame?size=0x10", 400, "size:"),
        ("/frame?size=abc", 400, "size:"),
        ("/frame?eye=1,2", 400, "eye: expected X,Y,Z"),
        ("/frame?eye=nan,0,0", 400, "--eye: needs finite numbers"),
        ("/frame?eye=1e300,0,0", 400, "--eye: needs finite numbers"),
        ("/frame?up=0,0,0", 400, "--up: must be a non-zero vector"),
        ("/frame?foo=1", 400, "unknown parameter `foo`"),
        ("/frame?tab=sepia", 400, "tab: expected"),
        ("/frame?device=tpu", 400, "device: expected"),
        ("/frame?tab=id&tab=id", 400, "`tab` given twice"),
        ("/frame?tab=%zz", 400, "malformed percent-encoding"),
        ("/frame?tab=%ff", 400, "malformed percent-encoding"),
        (&long, 414, "request target over 2048 bytes"),
        ("/state/../frame", 404, "not found"),
    ];
    for (target, status, message) in gets {
        let answer = server.get(target);
        let shown = &target[..target.len().min(60)];
        assert_eq!(answer.status, status, "{shown}: {}", answer.text());
        assert!(
            answer.text().contains(message),
            "{shown}: {}",
            answer.text()
        );
        assert_eq!(answer.text().lines().count(), 1, "{shown}: one line");
    }
    let posted = exchange(
        &address,
        &format!("POST /frame HTTP/1.1\r\nHost: {address}"),
        b"x",
    );
    assert_eq!(posted.status, 405);
    assert_eq!(posted.header("Allow"), Some("GET, HEAD"));
    // A page of another site reaching the server through a name of its own (DNS rebinding).
    let rebound = exchange(
        &address,
        "GET /state HTTP/1.1\r\nHost: evil.example:80",
        b"",
    );
    assert_eq!(rebound.status, 403);
    let huge_header = format!(
        "GET /state HTTP/1.1\r\nHost: {address}\r\nX-Big: {}",
        "y".repeat(100_000)
    );
    let answer = exchange(&address, &huge_header, b"");
    assert_eq!(answer.status, 431, "{}", answer.text());

    assert_eq!(state(&server), state_before);
    let after = server.get(&frame);
    assert!(
        after.body == before.body,
        "the same frame as before the bad requests"
    );
    let page = server.get("/");
    assert_eq!(page.status, 200);
    let policy = page.header("Content-Security-Policy").unwrap();
    assert!(policy.starts_with("default-src 'self'"), "{policy}");
}

#[test]
fn sigint_and_sigterm_stop_the_server_cleanly() {
    for signal in ["-INT", "-TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let server = serve_bunny(dir.path(), &[]);
        let address = server.address.clone();
        // An open event stream does not hold the server up.
        let mut stream = TcpStream::connect(&address).unwrap();
        let head = format!("GET /events HTTP/1.1\r\nHost: {address}\r\n\r\n");
        stream.write_all(head.as_bytes()).unwrap();
        assert_eq!(server.get("/state").status, 200);
        let (code, stderr) = server.stop(signal);
        assert_eq!(code, Some(0), "{signal}: {stderr}");
        assert_eq!(
            stderr.lines().last(),
            Some("raycast serve: stopped"),
            "{signal}"
        );
        assert!(
            TcpStream::connect(&address).is_err(),
            "{signal}: nothing listens"
        );
    }
}

#[test]
fn what_cannot_be_served_is_refused_before_listening() {
    let dir = tempfile::tempdir().unwrap();
    let broken = hook(0.0).replacen("1.0);\n", "1.0)\n", 1);
    std::fs::write(dir.path().join("broken.wgsl"), broken).unwrap();
    let busy = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = busy.local_addr().unwrap().port().to_string();
    let cases: [(&[&str], &str); 4] = [
        (&["--shader", "broken.wgsl"], "broken.wgsl:4:5: error:"),
        (&["missing.json"], "missing.json"),
        (&["--port", &port], "--port: cannot listen on 127.0.0.1:"),
        (&["--size", "0x5"], "--size"),
    ];
    for (args, message) in cases {
        let output = raycast()
            .arg("serve")
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert!(output.stdout.is_empty(), "{args:?}: no address printed");
    }
}

#[test]
fn a_saved_scene_reloads_and_a_broken_one_shows_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |radius: &str| {
        format!(
            "{{\n  \"camera\": {{\"eye\": [0, 0, 5], \"look_at\": [0, 0, 0], \"up\": [0, 1, 0], \"fov\": 40, \"resolution\": [64, 36]}},\n  \"objects\": [\n    {{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": {radius}}}\n  ]\n}}\n"
        )
    };
    let file = dir.path().join("ball.json");
    std::fs::write(&file, scene("1")).unwrap();
    let server = Server::start(binary(), dir.path(), &["ball.json"]);
    let before = server.get("/frame?tab=id");
    assert_eq!(before.status, 200, "{}", before.text());

    std::fs::write(&file, scene("1.5")).unwrap();
    let start = Instant::now();
    while state(&server)["version"] != 2 {
        assert!(start.elapsed() < Duration::from_secs(5), "reloaded");
        std::thread::sleep(Duration::from_millis(20));
    }
    let bigger = server.get("/frame?tab=id");
    assert!(bigger.body != before.body, "a larger ball");

    std::fs::write(&file, scene("1.5,")).unwrap();
    let start = Instant::now();
    let error = loop {
        if let Some(error) = state(&server)["error"].as_str() {
            break error.to_string();
        }
        assert!(start.elapsed() < Duration::from_secs(5), "the error shows");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(error.starts_with("error: ball.json:4:"), "{error}");
    assert_eq!(state(&server)["version"], 2);
    assert!(
        server.get("/frame?tab=id").body == bigger.body,
        "the last good scene renders"
    );
}
