//! The `raycast` command's parts that are more than parsing options: comparing two renders, the
//! studies (accuracy, tradeoff, specializations, bench, self-test, workloads), their pictures
//! and progress bars. A client of the `raycast` library; `main.rs` is the `clap` front end.

pub mod adapter;
pub mod compare;
pub mod progress;
pub mod render;
pub mod serve;
pub mod study;
pub mod text;
pub mod watch;

/// The option of this command line that sets what the library calls `name` (an argument of
/// its API: `RenderOptions::samples_per_pixel`, say), with the value it implies where the name
/// is a choice (`Gpu`).
pub fn flag(name: &str) -> Option<String> {
    let flag = match name {
        "precision" => "--precision",
        "device" => "--device",
        "Gpu" => "--device gpu",
        "lit" | "ShadeHook::raytrace" => "--lit",
        "shade" | "shader" => "--shader",
        "kernel" => "--kernel",
        "samples_per_pixel" => "--spp",
        "size" => "--size",
        "formats" => "--format",
        "outputs" => "--outputs",
        "background" => "--background",
        "band_rows" => "--band-rows",
        "emit_shader" => "--emit-shader",
        "eye" => "--eye",
        "look_at" => "--look-at",
        "up" => "--up",
        "fov" => "--fov",
        "orbit" => "--orbit",
        "orbit_radius" => "--orbit-radius",
        "orbit_elevation" => "--orbit-elevation",
        "views" => "--views",
        "poses" => "--poses",
        "split" => "--split",
        "shard" => "--shard",
        _ => return None,
    };
    Some(flag.to_string())
}

/// An error as the command prints it: one `error: ` line, or a shader error's own block (which
/// says `error:` after its location, as compilers do), with the arguments it names spelled as
/// options of this command line.
pub fn error_text(e: raycast::Error) -> String {
    let e = e.spelled(&flag);
    match e {
        raycast::Error::Shader { .. } => e.to_string(),
        _ => format!("error: {e}"),
    }
}

/// A point or direction written `X,Y,Z`.
/// Pixels of `camera`'s image: its rays at one sample per pixel.
pub fn pixels(camera: &raycast::Camera) -> u64 {
    let [nx, ny] = camera.resolution;
    u64::from(nx) * u64::from(ny)
}

pub fn parse_vector(s: &str) -> std::result::Result<glam::DVec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    let numbers: Vec<f64> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 => Ok(glam::DVec3::new(x, y, z)),
        _ => Err(format!("expected X,Y,Z (three numbers), got `{s}`")),
    }
}

/// An image size written `WIDTHxHEIGHT` (`--size 640x360`), each at least 1.
pub fn parse_size(s: &str) -> std::result::Result<[u32; 2], String> {
    let err = || format!("expected WIDTHxHEIGHT such as 640x360, got `{s}`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let w: u32 = w.trim().parse().map_err(|_| err())?;
    let h: u32 = h.trim().parse().map_err(|_| err())?;
    if w == 0 || h == 0 {
        return Err(format!("image size must be at least 1x1, got `{s}`"));
    }
    Ok([w, h])
}

/// An opaque colour as `--background` takes it: `R,G,B`, each in 0..255.
pub fn parse_background(s: &str) -> std::result::Result<[u8; 3], String> {
    let err = || {
        format!("expected R,G,B with each of the three in 0..255, such as 255,255,255, got `{s}`")
    };
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(err());
    }
    let mut rgb = [0u8; 3];
    for (c, part) in rgb.iter_mut().zip(parts) {
        *c = part.trim().parse().map_err(|_| err())?;
    }
    Ok(rgb)
}

/// `VmHWM` (peak resident set) of this process (Linux; `None` elsewhere) in MiB, from /proc/self/status.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line
        .trim_start_matches("VmHWM:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib / 1024.0)
}

/// Removes the files being written ([`raycast_files::remove_partial_files`]), prints
/// `message` (unless empty) as the one line on stderr and exits with `code`: for a signal
/// handler on the way out, and for the allocator when the system refuses memory. On unix it
/// leaves by `_exit`, without the exit handlers (a GPU driver's among them) that could hang
/// while another thread is inside the driver.
pub fn abandon(code: i32, message: &str) -> ! {
    match raycast_files::remove_partial_files(|| -> std::convert::Infallible {
        if !message.is_empty() {
            eprintln!("{message}");
        }
        #[cfg(unix)]
        // SAFETY: `_exit` ends the process at once; stderr is unbuffered, so the message is out.
        unsafe {
            libc::_exit(code)
        }
        #[cfg(not(unix))]
        std::process::exit(code)
    }) {}
}
