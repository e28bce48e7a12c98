//! `/frame`: one picture of the scene seen by the page's camera, on the GPU, by the CPU
//! reference, or their difference as a heatmap. The pictures are the files `raycast render`
//! writes for that camera, byte for byte.

use std::sync::Arc;
use std::time::Instant;

use raycast::Output;
use raycast::encode_png_rgb;
use raycast::{AnyImages, Cpu, Device, Encoding, Format, Mode, Precision, RenderOptions};
use raycast::{Camera, CameraOverrides};

use super::state::{Current, Shared};
use crate::compare;

/// The largest side of a frame, in pixels.
pub(super) const MAX_SIDE: u32 = 4096;
/// Renders kept for the page's next requests (another tab of the same view, the difference).
const CACHED: usize = 4;

/// Which picture of the render.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tab {
    Color,
    Id,
    Depth,
    Normal,
}

/// Whose render: the GPU's, the CPU reference's, or the difference of the two.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    Gpu,
    Cpu,
    Diff,
}

/// A `/frame` request's parameters; the camera's settings left out are the scene camera's.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct FrameQuery {
    tab: Tab,
    source: Source,
    view: CameraOverrides,
    size: Option<[u32; 2]>,
}

/// A request refused or failed: the HTTP status and a line saying why.
pub(super) type Failure = (u16, String);

impl FrameQuery {
    /// Parses `tab=..&device=..&eye=X,Y,Z&look_at=X,Y,Z&up=X,Y,Z&size=WxH`, each at most once,
    /// values percent-encoded.
    pub fn parse(query: &str) -> Result<FrameQuery, String> {
        let mut q = FrameQuery {
            tab: Tab::Color,
            source: Source::Gpu,
            view: CameraOverrides::default(),
            size: None,
        };
        let mut seen: Vec<String> = Vec::new();
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
            let (key, value) = (decode(key)?, decode(value)?);
            if seen.contains(&key) {
                return Err(format!("`{key}` given twice"));
            }
            let vector = || {
                crate::parse_vector(&value)
                    .map(Some)
                    .map_err(|e| format!("{key}: {e}"))
            };
            match key.as_str() {
                "tab" => q.tab = tab(&value)?,
                "device" => q.source = source(&value)?,
                "eye" => q.view.eye = vector()?,
                "look_at" => q.view.look_at = vector()?,
                "up" => q.view.up = vector()?,
                "size" => q.size = Some(size(&value)?),
                _ => {
                    return Err(format!(
                        "unknown parameter `{}` (expected tab, device, eye, look_at, up, size)",
                        key.chars().take(40).collect::<String>()
                    ));
                }
            }
            seen.push(key);
        }
        Ok(q)
    }
}

fn tab(value: &str) -> Result<Tab, String> {
    match value {
        "color" => Ok(Tab::Color),
        "id" => Ok(Tab::Id),
        "depth" => Ok(Tab::Depth),
        "normal" => Ok(Tab::Normal),
        _ => Err("tab: expected color, id, depth or normal".into()),
    }
}

fn source(value: &str) -> Result<Source, String> {
    match value {
        "gpu" => Ok(Source::Gpu),
        "cpu" => Ok(Source::Cpu),
        "diff" => Ok(Source::Diff),
        _ => Err("device: expected gpu, cpu or diff".into()),
    }
}

fn size(value: &str) -> Result<[u32; 2], String> {
    let [w, h] = crate::parse_size(value).map_err(|e| format!("size: {e}"))?;
    if w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!(
            "size: at most {MAX_SIDE} pixels a side, got {w}x{h}"
        ));
    }
    Ok([w, h])
}

/// Percent-decoding (`+` is a space); a malformed escape or a result that is not UTF-8 is an
/// error.
fn decode(text: &str) -> Result<String, String> {
    let bad = || "malformed percent-encoding in the query".to_string();
    let mut bytes = Vec::with_capacity(text.len());
    let mut rest = text.bytes();
    while let Some(b) = rest.next() {
        bytes.push(match b {
            b'+' => b' ',
            b'%' => {
                let hex = [rest.next().ok_or_else(bad)?, rest.next().ok_or_else(bad)?];
                let hex = std::str::from_utf8(&hex).map_err(|_| bad())?;
                u8::from_str_radix(hex, 16).map_err(|_| bad())?
            }
            b => b,
        });
    }
    String::from_utf8(bytes).map_err(|_| bad())
}

/// One render of the scene from a camera, in one mode.
pub(super) struct Rendered {
    mode: Mode,
    camera: Camera,
    images: AnyImages,
    seconds: f64,
    rays: u64,
}

/// The last few renders, for the page's next requests.
#[derive(Default)]
pub(super) struct Cache {
    renders: Vec<Arc<Rendered>>,
}

/// A frame as the page receives it.
pub(super) struct Frame {
    pub png: Vec<u8>,
    /// The render's wall time.
    pub seconds: f64,
    pub rays: u64,
    /// `gpu:f32:robust`, or `gpu:f32:robust against cpu:f64:robust`.
    pub mode: String,
    /// The state version rendered.
    pub version: u64,
    /// The difference's summary.
    pub summary: Option<String>,
}

/// Renders the scene's own view on the GPU, as the page's first frame will ask: what cannot
/// render is refused before the page opens, and the kernel is compiled by then.
pub(super) fn warm_up(shared: &Shared) -> raycast::Result<()> {
    let mut current = shared.current.lock().expect("the render lock");
    let camera = current.viewer.as_ref().camera.clone();
    rendered(shared, &mut current, Device::Gpu, camera).map(drop)
}

/// The frame `query` asks for, from the scene and hook last loaded.
pub(super) fn render(shared: &Shared, query: &FrameQuery) -> Result<Frame, Failure> {
    let refused = |e: raycast::Error| (400, crate::error_text(e));
    let failed = |e: raycast::Error| (500, crate::error_text(e));
    if query.tab == Tab::Color && query.source != Source::Gpu && shared.options.shader.is_some() {
        return Err((
            400,
            "tab=color: the CPU reference runs no custom shade hook".into(),
        ));
    }
    let mut current = shared.current.lock().expect("the render lock");
    let mut camera = (query.view.apply(&current.viewer.as_ref().camera)).map_err(refused)?;
    if let Some(size) = query.size {
        camera.resolution = size;
    }
    let mut render = |device| rendered(shared, &mut current, device, camera.clone());
    let (frame, png, mode, summary) = match query.source {
        Source::Gpu | Source::Cpu => {
            let device = match query.source {
                Source::Cpu => Device::Cpu,
                _ => Device::Gpu,
            };
            let frame = render(device).map_err(failed)?;
            let png = picture(&frame, query.tab);
            let mode = frame.mode.to_string();
            (frame, png, mode, None)
        }
        Source::Diff => {
            let gpu = render(Device::Gpu).map_err(failed)?;
            let cpu = render(Device::Cpu).map_err(failed)?;
            let (png, summary) = difference(&gpu, &cpu, query.tab);
            let mode = format!("{} against {}", gpu.mode, cpu.mode);
            (gpu, png, mode, Some(summary))
        }
    };
    Ok(Frame {
        png,
        seconds: frame.seconds,
        rays: frame.rays,
        mode,
        version: current.version,
        summary,
    })
}

/// The render of `camera` on `device`, from the cache or made now.
fn rendered(
    shared: &Shared,
    current: &mut Current,
    device: Device,
    camera: Camera,
) -> raycast::Result<Arc<Rendered>> {
    let cache = &mut current.cache.renders;
    if let Some(r) = cache
        .iter()
        .find(|r| r.mode.device == device && r.camera == camera)
    {
        return Ok(Arc::clone(r));
    }
    let (precision, shade) = match device {
        Device::Gpu => (shared.options.precision, current.hook.clone()),
        // The reference colours only by the course's ray tracer, its mirror.
        Device::Cpu => (
            Precision::F64,
            current.hook.clone().filter(|_| shared.options.lit),
        ),
    };
    let options = RenderOptions {
        precision: Some(precision),
        shade,
        ..RenderOptions::default()
    };
    let start = Instant::now();
    let images = current
        .viewer
        .render(camera.clone(), |scene| match device {
            Device::Gpu => shared.gpu.render(scene, &options),
            Device::Cpu => Cpu.render(scene, &options),
        })?;
    let seconds = start.elapsed().as_secs_f64();
    let rays = crate::pixels(&camera) + images.hook_rays().unwrap_or(0);
    let rendered = Arc::new(Rendered {
        mode: Mode {
            device,
            precision,
            algorithm: options.algorithm,
        },
        camera,
        images,
        seconds,
        rays,
    });
    let cache = &mut current.cache.renders;
    if cache.len() == CACHED {
        cache.remove(0);
    }
    cache.push(Arc::clone(&rendered));
    Ok(rendered)
}

/// The tab's file of `raycast render --format png` for this render.
fn picture(r: &Rendered, tab: Tab) -> Vec<u8> {
    let (output, name) = match tab {
        Tab::Color => (Output::Color, "color.png"),
        Tab::Id => (Output::Id, "id.png"),
        Tab::Depth => (Output::Distance, "depth.png"),
        Tab::Normal => (Output::Normal, "normal.png"),
    };
    let encoding = Encoding::new(&[Format::Png], Some(&[output])).expect("a png output");
    let files = r.images.encode(&encoding, &r.camera);
    let file = files.into_iter().find(|f| f.name == name);
    file.expect("the png encoding writes the tab's picture")
        .bytes
}

/// The heatmap of `raycast compare`'s pictures that fits the tab, and the comparison's summary.
fn difference(gpu: &Rendered, cpu: &Rendered, tab: Tab) -> (Vec<u8>, String) {
    let c = compare::compare(&gpu.images, &cpu.images);
    let picture = match (tab, gpu.images.color(), cpu.images.color()) {
        (Tab::Color, Some(a), Some(b)) => compare::color_error_picture(&c, a, b),
        (Tab::Depth, _, _) => compare::distance_error_picture(&c),
        _ => compare::mismatch_picture(&c, &cpu.images.pictures().normal),
    };
    let r = &c.report;
    let number = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.3e}"));
    let mut summary = format!(
        "{} hit mismatches, {} id mismatches, relative distance error up to {}, normals up to {} degrees apart",
        r.hit_mismatch,
        r.id_mismatch,
        number(r.distance.rel_max),
        number(r.normal_angle_deg.max)
    );
    if let Some(color) = &r.color {
        summary.push_str(&format!(", colours up to {} levels apart", color.max));
    }
    (encode_png_rgb(&picture), summary)
}
