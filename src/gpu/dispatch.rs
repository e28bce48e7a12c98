//! Runs the kernel on a device: the one entry for every GPU render is [`run`], which takes a
//! prepared scene ([`Prepared`]) and a [`Job`]: the kernel [`Variant`], the rays to cast (the
//! camera's, in tiles of image rows, or a list of its pixels), whether to time it, and where
//! tiles go when the image is streamed. It uploads the primitives, binds every buffer by the
//! name the kernel gives it (from naga's reflection of the kernel), dispatches and reads back
//! the outputs the variant writes.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use super::Gpu;
use super::shader::{self, Casts, Variant};
use crate::error::{Error, Result};
use crate::images::{Images, MISS, Stages};
use crate::kernel::layout::{
    GpuFrame, GpuParams, GpuPlane, GpuRay, GpuReal, GpuSphere, GpuTriangle, projection_code,
};
use crate::math::Float;
use crate::prepare::{Prepared, Primitives};
use crate::rays::{Hits, INVALID_ID};
use crate::scene::Scene;

/// Workgroup edge in pixels (`@workgroup_size(8, 8)` in shaders/entry.wgsl; the packet kernel
/// numbers the same 64 invocations in one dimension).
const WORKGROUP: u32 = 8;
/// Invocations per workgroup of a pixel-list kernel (`@workgroup_size(64)`).
const LIST_WORKGROUP: u32 = 64;
/// Bytes of output per pixel and unit of precision: `vec4<real>` surface.
const SURFACE_REALS: u64 = 4;
/// Bytes of output per pixel: `i32` id.
const ID_BYTES: u64 = 4;

/// Which rays a [`Job`] casts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Rays<'a> {
    /// The camera's ray through the centre of every pixel, in tiles of image rows.
    Camera,
    /// The camera rays of the listed pixels only (row-major indices), in list order: one
    /// invocation per listed pixel, so the cost follows the length of the list. The images
    /// come back as one row of `list.len()` pixels.
    Pixels(&'a [u32]),
    /// A caller's rays, in world coordinates, hits counted from `t_near` (in units of each
    /// ray's direction): one invocation per ray. The results come back as
    /// [`Rendered::hits`], in list order.
    List {
        list: crate::rays::RayList<'a>,
        t_near: f64,
    },
}

impl Rays<'_> {
    /// Which rays the kernel casts for these.
    fn casts(&self) -> Casts {
        match self {
            Rays::Camera => Casts::Camera,
            Rays::Pixels(_) => Casts::Pixels,
            Rays::List { .. } => Casts::Rays,
        }
    }

    /// How many list entries (pixels or rays) there are; 0 for the camera.
    fn listed(&self) -> usize {
        match self {
            Rays::Camera => 0,
            Rays::Pixels(list) => list.len(),
            Rays::List { list, .. } => list.len(),
        }
    }
}

/// What receives the tiles of a streamed render: the first image row of the tile and its
/// images (the tile's rows only).
pub(crate) type TileSink<'a, R> = &'a mut dyn FnMut(u32, Images<R>) -> Result<()>;

/// One GPU render: what [`run`] does with a prepared scene.
pub(crate) struct Job<'a, R> {
    /// The kernel: the scene's kinds, precision, algorithm, outputs, hook or user kernel,
    /// certainty test, count query. Its `source` is set by [`run`] from `rays`.
    pub variant: Variant,
    pub rays: Rays<'a>,
    /// At most this many image rows per dispatch (fewer where the device's limits require).
    pub max_rows: Option<u32>,
    /// Measure the kernel's GPU time with timestamp queries ([`Stages::kernel_s`]).
    pub timed: bool,
    /// Hand each tile to this sink as soon as it is read back, from the top, instead of
    /// holding the whole image ([`Rendered::images`] is then empty).
    pub sink: Option<TileSink<'a, R>>,
    /// The scene's buffers, uploaded already by [`upload`] (for many jobs on one scene);
    /// without, [`run`] uploads them.
    pub resident: Option<&'a Resident>,
}

impl<'a, R> Job<'a, R> {
    /// The camera's rays through `variant`, untimed, whole.
    pub(crate) fn new(variant: Variant) -> Self {
        Job {
            variant,
            rays: Rays::Camera,
            max_rows: None,
            timed: false,
            sink: None,
            resident: None,
        }
    }

    /// Casts the listed pixels only ([`Rays::Pixels`]).
    pub(crate) fn pixels(self, list: &'a [u32]) -> Self {
        Job {
            rays: Rays::Pixels(list),
            ..self
        }
    }

    /// Casts a caller's rays, hits counted from `t_near` ([`Rays::List`]).
    pub(crate) fn rays(self, list: crate::rays::RayList<'a>, t_near: f64) -> Self {
        Job {
            rays: Rays::List { list, t_near },
            ..self
        }
    }

    /// At most `max_rows` image rows per dispatch.
    pub(crate) fn rows(self, max_rows: u32) -> Self {
        Job {
            max_rows: Some(max_rows.max(1)),
            ..self
        }
    }

    /// Measures the kernel's GPU time.
    pub(crate) fn timed(self, timed: bool) -> Self {
        Job { timed, ..self }
    }

    /// Binds the scene's buffers uploaded by [`upload`] instead of uploading them.
    pub(crate) fn resident(self, resident: &'a Resident) -> Self {
        Job {
            resident: Some(resident),
            ..self
        }
    }

    /// Streams the tiles to `sink`.
    pub(crate) fn sink(self, sink: TileSink<'a, R>) -> Self {
        Job {
            sink: Some(sink),
            ..self
        }
    }
}

/// What [`run`] returns.
pub(crate) struct Rendered<R> {
    /// The images (one row of the listed pixels for [`Rays::Pixels`]; empty when streamed or
    /// for [`Rays::List`]).
    pub images: Images<R>,
    /// Per ray of a [`Rays::List`], what the kernel wrote: primitives as their index among
    /// their kind in the scene's order ([`crate::rays`] turns them into indices within their
    /// object).
    pub hits: Option<Hits<R>>,
    /// Per-pixel (or per-ray) certainty flags, in a certainty variant.
    pub certainty: Option<Vec<bool>>,
    pub stages: Stages,
}

/// `scene` prepared for `variant`: in its precision and algorithm, through a BVH where the
/// variant traverses one. A scene with more spheres and triangles than the variant's storage
/// bindings hold is refused here, before its BVH is built ([`run`] checks the prepared
/// buffers again).
pub(crate) fn prepare<R: GpuReal>(scene: &Scene, variant: &Variant) -> Result<Prepared<R>> {
    check_capacity(scene, variant)?;
    Ok(Prepared::new(scene, variant.algorithm, variant.search()))
}

/// `variant` as [`run`] compiles it for `scene`: its traversal stack sized to the scene's BVH,
/// which is built again here, and its plane loops to the scene's planes (for `--emit-shader`,
/// which writes the kernel a render ran).
pub(crate) fn as_run(scene: &Scene, variant: Variant) -> Variant {
    let bvh = crate::prepare::bvh_of(scene, variant.algorithm, variant.search());
    variant
        .with_stack_for(bvh.as_ref())
        .with_planes(scene.primitive_counts()[1])
}

/// An error if `scene` has more spheres and triangles than `variant`'s storage bindings hold.
pub(crate) fn check_capacity(scene: &Scene, variant: &Variant) -> Result<()> {
    let bounded = crate::prepare::bvh::bounded_count(scene) as u64;
    let capacity = (shader::MAX_CHUNKS as u64) << variant.chunk_bits;
    if bounded > capacity {
        return Err(Error::Device(format!(
            "{bounded} spheres and triangles are more than this device's storage bindings hold (at most {capacity} triangles on this device)"
        )));
    }
    Ok(())
}

/// Runs `job` on `prepared` (module docs).
/// `variant` as [`run`] compiles it for rays from `source` at `prepared`: the traversal stack
/// sized to its BVH, its plane loops to its planes, `RAYS_FROM_ORIGIN` where every camera ray
/// starts at the kernel's origin, `LIST_ORIGIN` kept for a caller's list only, and a ray list's outputs (every per-ray one, or
/// with COUNT the counts alone).
pub(crate) fn specialized<R: GpuReal>(
    variant: Variant,
    casts: Casts,
    prepared: &Prepared<R>,
) -> Result<Variant> {
    let variant = Variant {
        casts,
        rays_from_origin: variant.rays_from_origin
            && casts != Casts::Rays
            && prepared.camera_rays_from_origin(),
        list_origin: variant.list_origin && casts == Casts::Rays,
        ..variant
            .with_stack_for(prepared.bvh().map(|b| &**b))
            .with_planes(prepared.primitives.planes.len())
    };
    match (casts, variant.count) {
        (Casts::Rays, false) => Ok(variant.with_outputs(crate::images::Outputs::GEOMETRY)),
        (Casts::Rays, true) => Ok(variant.with_outputs(crate::images::Outputs::NONE)),
        (_, false) => Ok(variant),
        (_, true) => Err(Error::Device(
            "intersections are counted for a list of rays only".into(),
        )),
    }
}

pub(crate) fn run<R: GpuReal>(
    gpu: &Gpu,
    prepared: &Prepared<R>,
    job: Job<'_, R>,
) -> Result<Rendered<R>> {
    gpu.check_alive()?;
    let Job {
        variant,
        rays,
        max_rows,
        timed,
        mut sink,
        resident,
    } = job;
    let variant = specialized(variant, rays.casts(), prepared)?;
    if variant.casts != Casts::Camera && sink.is_some() {
        return Err(Error::Device(
            "a list comes back whole; only camera rays are streamed".into(),
        ));
    }
    if variant.precision != R::PRECISION || variant.uses_bvh() != prepared.bvh().is_some() {
        return Err(Error::Device(format!(
            "the kernel variant ({} precision, BVH {}) does not fit the prepared scene ({}, BVH {})",
            variant.precision.name(),
            variant.uses_bvh(),
            R::PRECISION.name(),
            prepared.bvh().is_some()
        )));
    }
    let mut stages = Stages {
        build_s: prepared.build_s,
        ..Stages::default()
    };
    let [nx, ny] = prepared.resolution();
    let tile_rows =
        check_limits(gpu, [nx, ny], &variant, prepared)?.min(max_rows.unwrap_or(u32::MAX));
    // Entries of a list per dispatch: as many as the largest per-entry buffer allows.
    let entry_bytes = surface_bytes(R::PRECISION).max(size_of::<GpuRay<R>>() as u64);
    let list_capacity = (gpu.max_binding() / entry_bytes).min(u32::MAX as u64) as u32;
    // An image's rays traced by packets go in 8x8 blocks of whole rows (`grid_slot` in
    // shaders/entry.wgsl), so each dispatch holds whole bands of 8 rows.
    let grid = match rays {
        Rays::List { list, .. } if variant.uses_packets() => list
            .width
            .and_then(|w| u32::try_from(w).ok())
            .filter(|&w| w <= list_capacity / 8),
        _ => None,
    };
    let list_step = grid.map_or(list_capacity, |w| list_capacity / (8 * w) * (8 * w));
    // The dispatches: (first row or list entry, rows or entries).
    let parts: Vec<(u32, u32)> = match rays {
        Rays::Camera => (0..ny)
            .step_by(tile_rows as usize)
            .map(|row| (row, tile_rows.min(ny - row)))
            .collect(),
        _ => {
            let n = u32::try_from(rays.listed()).map_err(|_| {
                Error::Device(format!(
                    "{} rays are more than one job casts (at most {})",
                    rays.listed(),
                    u32::MAX
                ))
            })?;
            (0..n)
                .step_by(list_step as usize)
                .map(|start| (start, list_step.min(n - start)))
                .collect()
        }
    };
    let capacity = match rays {
        Rays::Camera => tile_rows as u64 * nx as u64,
        // An empty list dispatches nothing, but its buffers may not be empty.
        _ => (rays.listed() as u64).clamp(1, list_capacity as u64),
    };

    let clock = std::time::Instant::now();
    let kernel = pipeline(gpu, variant)?;
    stages.compile_s = clock.elapsed().as_secs_f64();
    let device = &gpu.device;

    let clock = std::time::Instant::now();
    let uploaded_here;
    let resident = match resident {
        Some(r) => {
            r.check_fits(gpu, &variant)?;
            r
        }
        None => {
            uploaded_here = upload(gpu, prepared, &variant)?;
            &uploaded_here
        }
    };
    stages.upload_s = clock.elapsed().as_secs_f64();

    let clock = std::time::Instant::now();
    let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: size_of::<GpuParams<R>>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // The list's buffer, by the kernel's name for it.
    let list = match rays {
        Rays::Camera => None,
        Rays::Pixels(_) => Some(("pixel_list", 4)),
        Rays::List { .. } => Some(("ray_list", size_of::<GpuRay<R>>() as u64)),
    };
    let list_buffer = list.map(|(name, entry)| {
        let filled_by = match gpu.host_memory() {
            true => wgpu::BufferUsages::MAP_WRITE,
            false => wgpu::BufferUsages::COPY_DST,
        };
        let buffer = gpu.transient_buffer(&wgpu::BufferDescriptor {
            label: Some(name),
            size: capacity * entry,
            usage: wgpu::BufferUsages::STORAGE | filled_by,
            mapped_at_creation: false,
        });
        (name, buffer)
    });
    let outputs = OutputBuffers::new(gpu, &variant, capacity);
    let mut buffers: Vec<(String, &wgpu::Buffer)> = resident
        .buffers
        .iter()
        .map(|(name, b)| (name.clone(), b))
        .collect();
    buffers.push(("params".into(), &params_buffer));
    buffers.extend(list_buffer.iter().map(|(name, b)| (name.to_string(), b)));
    buffers.extend(outputs.named());
    let mut hook_rays = variant.hook_rays.then(|| HookRayCounter::new(gpu));
    if let Some(counter) = &hook_rays {
        buffers.push(("hook_ray_count".into(), &counter.counter));
    }
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("raycast"),
        layout: &kernel.pipeline.get_bind_group_layout(0),
        entries: &kernel.entries(&buffers)?,
    });

    // Streamed, the tiles go to the sink and only the tile in hand is held.
    let whole = match rays {
        Rays::Camera if sink.is_some() => [nx, 0],
        Rays::Camera => [nx, ny],
        Rays::Pixels(list) => [list.len() as u32, 1],
        Rays::List { .. } => [0, 0],
    };
    let mut hits = match rays {
        Rays::List { list, .. } => Some(Hits::with_capacity(list.len(), variant.count)),
        _ => None,
    };
    let new_images = |[w, h]: [u32; 2]| {
        let mut images = Images::new_miss(w, h, prepared.focal_length);
        images.color = variant.outputs.color.then(|| vec![[0; 4]; images.len()]);
        images
    };
    let mut images = new_images(whole);
    let mut certainty = variant
        .certainty
        .then(|| vec![false; images.len().max(rays.listed())]);
    let timer = if timed { PassTimer::new(gpu) } else { None };
    let mut kernel_s = timer.as_ref().map(|_| 0.0);
    let mut frame = GpuFrame::new(&prepared.frame);
    if let Rays::List { t_near, .. } = rays {
        frame.min_t = R::from_f64(t_near);
    }
    let origin = prepared.origin.cast::<R>().to_array();
    for (first, count) in parts {
        let params = GpuParams::<R> {
            frame,
            projection: projection_code(prepared.frame.projection),
            // A ray list's nx is its image width (0 when it is not an image's).
            nx: match variant.casts {
                Casts::Rays => grid.unwrap_or(0),
                _ => nx,
            },
            ny,
            row_offset: if variant.casts == Casts::Camera {
                first
            } else {
                0
            },
            tile_rows: count,
            sphere_count: prepared.primitives.spheres.len() as u32,
            plane_count: prepared.primitives.planes.len() as u32,
            triangle_count: prepared.primitives.triangles.len() as u32,
            origin,
            unit: R::from_f64(prepared.unit),
        };
        gpu.queue
            .write_buffer(&params_buffer, 0, bytemuck::bytes_of(&params));
        // Workgroups, pixels cast, and the index of the first in the images.
        let range = first as usize..(first + count) as usize;
        // Fills the list buffer with `count` entries of `entry` bytes: `fill(k, bytes)` writes
        // the entries from `k` of the part on, as many as `bytes` holds.
        let write_list = |entry: usize, fill: &EntryFill<'_>| -> Result<_> {
            let (_, buffer) = list_buffer.as_ref().expect("a list has its buffer");
            fill_buffer(gpu, buffer, count as usize, entry, fill)?;
            let groups = match grid {
                Some(w) => w.div_ceil(8) * count.div_ceil(w).div_ceil(8),
                None => count.div_ceil(LIST_WORKGROUP),
            };
            Ok((list_groups(gpu, groups), count as u64, first as usize))
        };
        let writing = std::time::Instant::now();
        let (groups, pixels, start) = match rays {
            Rays::Camera => (
                [nx.div_ceil(WORKGROUP), count.div_ceil(WORKGROUP)],
                count as u64 * nx as u64,
                first as usize * nx as usize,
            ),
            Rays::Pixels(list) => write_list(4, &|k, bytes| {
                let pixels = &list[range.start + k..];
                for (to, pixel) in bytes.chunks_exact_mut(4).zip(pixels) {
                    to.copy_from_slice(&pixel.to_ne_bytes());
                }
            })?,
            Rays::List { list, .. } => {
                // The rays are checked as they are written (rays::check_rays names a bad one).
                let bad = std::sync::atomic::AtomicBool::new(false);
                let written = write_list(size_of::<GpuRay<R>>(), &|k, bytes| {
                    let entries = bytes.chunks_exact_mut(size_of::<GpuRay<R>>());
                    let mut valid = true;
                    for (j, to) in entries.enumerate() {
                        let ray = list.get(range.start + k + j);
                        valid &= crate::rays::is_valid(&ray);
                        let stored = GpuRay::from(&prepared.kernel_ray(&ray));
                        to.copy_from_slice(bytemuck::bytes_of(&stored));
                    }
                    if !valid {
                        bad.store(true, std::sync::atomic::Ordering::Relaxed);
                    }
                })?;
                if bad.into_inner() {
                    crate::rays::check_rays(list)?;
                }
                written
            }
        };
        stages.write_s += writing.elapsed().as_secs_f64();
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("raycast"),
                timestamp_writes: timer.as_ref().map(PassTimer::pass_writes),
            });
            pass.set_pipeline(&kernel.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], 1);
        }
        if let Some(timer) = &timer {
            timer.resolve(&mut encoder);
        }
        outputs.copy_to_readback(&mut encoder, pixels);
        if let Some(counter) = &hook_rays {
            counter.copy_and_reset(&mut encoder);
        }
        gpu.queue.submit([encoder.finish()]);
        if let Some(counter) = &mut hook_rays {
            counter.add(gpu)?;
        }
        stages.readback_bytes += outputs.bytes(pixels);
        match (sink.as_mut(), hits.as_mut()) {
            (_, Some(hits)) => read_hits(
                gpu,
                &outputs,
                &mut stages,
                pixels as usize,
                start,
                hits,
                certainty.as_deref_mut(),
            )?,
            (Some(sink), None) => {
                let mut tile = new_images([nx, count]);
                let read = (pixels as usize, 0);
                read_tile(gpu, &outputs, &mut stages, &variant, read, &mut tile, None)?;
                sink(first, tile)?;
            }
            (None, None) => read_tile(
                gpu,
                &outputs,
                &mut stages,
                &variant,
                (pixels as usize, start),
                &mut images,
                certainty.as_deref_mut(),
            )?,
        }
        if let (Some(timer), Some(total)) = (&timer, &mut kernel_s) {
            *total += timer.read_seconds(gpu)?;
        }
    }
    stages.trace_s = clock.elapsed().as_secs_f64();
    stages.kernel_s = kernel_s;
    stages.hook_rays = hook_rays.map(|c| c.total);
    images.hook_rays = stages.hook_rays;
    let list_buffer = list_buffer.map(|(_, b)| b);
    gpu.keep_transient(outputs.into_buffers().chain(list_buffer).collect());
    Ok(Rendered {
        images,
        hits,
        certainty,
        stages,
    })
}

/// A prepared scene's buffers on one device ([`upload`]), for jobs that cast many times at
/// one scene ([`Job::resident`]): uploading the torus's 18 MB took longer than casting a
/// few rays at it.
pub(crate) struct Resident {
    /// By the kernel's names (shaders/bindings.wgsl).
    buffers: Vec<(String, wgpu::Buffer)>,
    /// How they are laid out: `(chunks, chunk_bits, hooked)` of the variant.
    laid_out: (u8, u8, bool),
    /// The device's identity ([`Gpu`]).
    device: std::sync::Arc<()>,
}

impl Resident {
    /// Whether these buffers are on `gpu` and laid out as `variant` binds them.
    pub(crate) fn fits(&self, gpu: &Gpu, variant: &Variant) -> bool {
        self.check_fits(gpu, variant).is_ok()
    }

    /// An error unless these buffers are on `gpu` and laid out as `variant` binds them.
    fn check_fits(&self, gpu: &Gpu, variant: &Variant) -> Result<()> {
        if !std::sync::Arc::ptr_eq(&self.device, gpu.identity()) {
            return Err(Error::Device(
                "the scene's buffers were uploaded to another device".into(),
            ));
        }
        if self.laid_out != layout_of(variant) {
            return Err(Error::Device(
                "the scene's buffers were uploaded for another kernel layout".into(),
            ));
        }
        Ok(())
    }
}

/// What decides the scene's buffers: the primitives' chunks, and whether a shade hook reads
/// the scene's materials and lights.
fn layout_of(variant: &Variant) -> (u8, u8, bool) {
    (variant.chunks, variant.chunk_bits, variant.shade.is_some())
}

/// `prepared`'s primitives and BVH uploaded to `gpu`, laid out for `variant`.
pub(crate) fn upload<R: GpuReal>(
    gpu: &Gpu,
    prepared: &Prepared<R>,
    variant: &Variant,
) -> Result<Resident> {
    let mut buffers = Layout::new(&prepared.primitives).upload(gpu, variant);
    if variant.shade.is_some() {
        buffers.extend(upload_hook_scene(gpu, prepared));
    }
    // The copies out of the buffers' staging memory wait for the next submission: made here,
    // they count as the upload, not as the first cast's wait.
    gpu.queue.submit([]);
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Device(format!("GPU upload did not finish: {e}")))?;
    Ok(Resident {
        buffers,
        laid_out: layout_of(variant),
        device: gpu.identity().clone(),
    })
}

/// The scene's materials, lights and per-object values for shade hooks (shaders/hooks.wgsl),
/// uploaded for kernels with a hook.
fn upload_hook_scene<R: GpuReal>(gpu: &Gpu, prepared: &Prepared<R>) -> Vec<(String, wgpu::Buffer)> {
    let (materials, lights, objects) =
        crate::kernel::layout::hook_buffers(&prepared.lighting, prepared.objects);
    vec![
        (
            "hook_materials".to_owned(),
            storage_buffer(gpu, "hook_materials", &materials),
        ),
        (
            "hook_lights".to_owned(),
            storage_buffer(gpu, "hook_lights", &lights),
        ),
        (
            "hook_objects".to_owned(),
            storage_buffer(gpu, "hook_objects", &objects),
        ),
    ]
}

/// The counter of the rays a shade hook casts (`hook_ray_count`, shaders/shade.wgsl), read
/// back and zeroed after every dispatch, so that its 32 bits need hold one dispatch's rays.
struct HookRayCounter {
    counter: wgpu::Buffer,
    readback: wgpu::Buffer,
    total: u64,
}

impl HookRayCounter {
    fn new(gpu: &Gpu) -> HookRayCounter {
        HookRayCounter {
            counter: gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("hook_ray_count"),
                    contents: bytemuck::bytes_of(&0u32),
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_SRC
                        | wgpu::BufferUsages::COPY_DST,
                }),
            readback: readback_buffer(gpu, 4),
            total: 0,
        }
    }

    /// Copies the dispatch's count for reading and zeroes the counter for the next.
    fn copy_and_reset(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_buffer_to_buffer(&self.counter, 0, &self.readback, 0, 4);
        encoder.clear_buffer(&self.counter, 0, None);
    }

    /// Adds the count copied by [`HookRayCounter::copy_and_reset`] to the total.
    fn add(&mut self, gpu: &Gpu) -> Result<()> {
        let slice = self.readback.slice(..);
        map_buffers(gpu, &[slice], wgpu::MapMode::Read)?;
        let count = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| Error::Device(format!("GPU ray count readback failed: {e}")))?;
            u32::from_ne_bytes(view[..4].try_into().expect("4 bytes"))
        };
        self.readback.unmap();
        self.total += count as u64;
        Ok(())
    }
}

/// `groups` workgroups for a list, laid out in rows of at most the device's limit per dimension.
fn list_groups(gpu: &Gpu, groups: u32) -> [u32; 2] {
    let max_groups = gpu.device.limits().max_compute_workgroups_per_dimension;
    [groups.min(max_groups), groups.div_ceil(max_groups)]
}

/// Writes consecutive entries of a list: the index of the first and their bytes (a whole
/// number of entries: a call per entry was slower).
type EntryFill<'f> = dyn Fn(usize, &mut [u8]) + Sync + 'f;

/// Writes `count` entries of `entry` bytes at the start of `buffer`, in parallel (on one core
/// it is a visible share of a cast): into its own memory where the host maps the kernel's buffers
/// ([`Gpu::host_memory`]; the GPU is idle between dispatches), else into the queue's staging
/// memory, copied at the next submission.
fn fill_buffer(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    count: usize,
    entry: usize,
    fill: &EntryFill<'_>,
) -> Result<()> {
    let size = (count * entry) as u64;
    if size == 0 {
        return Ok(());
    }
    if gpu.host_memory() {
        let part = buffer.slice(..size);
        map_buffers(gpu, &[part], wgpu::MapMode::Write)?;
        {
            let mut view = part
                .get_mapped_range_mut()
                .map_err(|e| Error::Device(format!("cannot write the list to the GPU: {e}")))?;
            fill_entries(view.slice(..), entry, fill);
        }
        buffer.unmap();
    } else {
        let size = wgpu::BufferSize::new(size).expect("not empty");
        let mut view = gpu
            .queue
            .write_buffer_with(buffer, 0, size)
            .ok_or_else(|| Error::Device("cannot write the list to the GPU".into()))?;
        fill_entries(view.slice(..), entry, fill);
    }
    Ok(())
}

/// Writes entries of `entry` bytes into `to` by `fill`: in parallel, in runs of [`RUN_BYTES`]
/// made in a buffer of each thread's and copied (mapped memory is written, never read; a run,
/// unlike the whole slice, can be sent to another thread).
fn fill_entries(to: wgpu::WriteOnly<'_, [u8]>, entry: usize, fill: &EntryFill<'_>) {
    use rayon::prelude::*;
    const RUN_BYTES: usize = 1 << 16;
    assert!(RUN_BYTES.is_multiple_of(entry), "whole entries in a run");
    let (runs, mut rest) = to.into_chunks::<RUN_BYTES>();
    let runs: Vec<wgpu::WriteOnly<'_, [u8; RUN_BYTES]>> = runs.into_iter().collect();
    let count = runs.len();
    runs.into_par_iter().enumerate().for_each_init(
        || vec![0u8; RUN_BYTES],
        |local, (r, run)| {
            fill(r * RUN_BYTES / entry, local);
            wgpu::WriteOnly::<[u8]>::from(run).copy_from_slice(local);
        },
    );
    if !rest.is_empty() {
        let mut local = vec![0u8; rest.len()];
        fill(count * RUN_BYTES / entry, &mut local);
        rest.copy_from_slice(&local);
    }
}

/// A scene's primitives in the GPU's layout (the values of [`Primitives`], as WGSL lays them
/// out), and the object id of each: spheres first, then planes, then triangles. With a
/// BVH, spheres and triangles are in its order, and `order` holds each one's index in the
/// scene's.
struct Layout<'a, R: GpuReal> {
    spheres: Vec<GpuSphere<R>>,
    planes: Vec<GpuPlane<R>>,
    triangles: Vec<GpuTriangle<R>>,
    objects: Vec<u32>,
    nodes: &'a [crate::prepare::bvh::BvhNode],
    order: Vec<u32>,
}

impl<'a, R: GpuReal> Layout<'a, R> {
    fn new(p: &'a Primitives<R>) -> Layout<'a, R> {
        let (nodes, order) = match &p.bvh {
            Some(bvh) => {
                let planes = 0..p.planes.len() as u32;
                let order = [
                    &bvh.sphere_order[..],
                    &planes.collect::<Vec<_>>(),
                    &bvh.triangle_order,
                ]
                .concat();
                (&bvh.nodes[..], order)
            }
            None => (&[][..], Vec::new()),
        };
        Layout {
            spheres: p.spheres.iter().map(GpuSphere::from).collect(),
            planes: (p.planes.iter().zip(&p.plane_objects))
                .map(|(q, &object)| GpuPlane::new(q, object))
                .collect(),
            triangles: p.triangles.iter().map(GpuTriangle::from).collect(),
            objects: [&p.sphere_objects[..], &p.plane_objects, &p.triangle_objects].concat(),
            nodes,
            order,
        }
    }

    /// The scene's buffers, named as the kernel's globals (shaders/bindings.wgsl): spheres,
    /// planes, triangles and object ids, and the BVH's nodes and primitive order; triangles
    /// and nodes in `variant.chunks` buffers each (`triangles`, `triangles_2`, ...).
    fn upload(&self, gpu: &Gpu, variant: &Variant) -> Vec<(String, wgpu::Buffer)> {
        let spheres = storage_buffer(gpu, "spheres", &self.spheres);
        let planes = storage_buffer(gpu, "planes", &self.planes);
        let triangles = chunked_upload(gpu, "triangles", &self.triangles, variant);
        let mut named = vec![
            ("spheres".to_owned(), spheres),
            ("planes".to_owned(), planes),
            (
                "objects".to_owned(),
                storage_buffer(gpu, "objects", &self.objects),
            ),
            (
                "prim_order".to_owned(),
                storage_buffer(gpu, "prim_order", &self.order),
            ),
        ];
        named.extend(chunk_names("triangles").zip(triangles));
        let nodes = chunked_upload(gpu, "bvh_nodes", self.nodes, variant);
        named.extend(chunk_names("bvh_nodes").zip(nodes));
        named
    }
}

/// The names of the chunks of a chunked binding: `name`, `name_2`, `name_3`, ...
fn chunk_names(name: &str) -> impl Iterator<Item = String> + '_ {
    (1..).map(move |k| match k {
        1 => name.to_owned(),
        k => format!("{name}_{k}"),
    })
}

/// A compiled kernel and the resources its entry point uses, by name and binding number.
#[derive(Clone)]
pub(crate) struct Compiled {
    pipeline: wgpu::ComputePipeline,
    bindings: Vec<(String, u32)>,
}

impl Compiled {
    /// The bind group entries: for each resource the kernel uses, the buffer of that name.
    fn entries<'a>(
        &self,
        buffers: &[(String, &'a wgpu::Buffer)],
    ) -> Result<Vec<wgpu::BindGroupEntry<'a>>> {
        self.bindings
            .iter()
            .map(|(name, binding)| {
                let (_, buffer) = buffers.iter().find(|(n, _)| n == name).ok_or_else(|| {
                    Error::Device(format!(
                        "the kernel binds `{name}` (@binding({binding})), which this render does not provide"
                    ))
                })?;
                Ok(wgpu::BindGroupEntry {
                    binding: *binding,
                    resource: buffer.as_entire_binding(),
                })
            })
            .collect()
    }
}

/// The kernel for `variant`, compiled once per [`Gpu`].
fn pipeline(gpu: &Gpu, variant: Variant) -> Result<Compiled> {
    let mut cache = gpu.pipelines.lock().expect("pipeline cache lock");
    if let Some(p) = cache.get(&variant) {
        return Ok(p.clone());
    }
    let p = create_pipeline(gpu, &variant)?;
    cache.insert(variant, p.clone());
    Ok(p)
}

fn create_pipeline(gpu: &Gpu, variant: &Variant) -> Result<Compiled> {
    let source = shader::kernel_source(variant)?;
    // Validated with naga first, so a shader error reads as WGSL line and column, and so the
    // bindings are known by name.
    let (module, info) = shader::validate(&source, std::path::Path::new("kernel"))?;
    let bindings = super::source::bindings(&module, &info, shader::ENTRY_POINT)
        .into_iter()
        .filter(|b| b.used)
        .map(|b| (b.name, b.binding))
        .collect();
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some("raycast kernel"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    };
    let shader_module = match variant.is_ours() {
        // SAFETY: a kernel assembled from shaders/ alone indexes its fixed-size arrays within
        // bounds: the traversal's stacks hold at least the tree's depth in entries, one waiting
        // node per level at most (`with_stack_for` in `specialized`; tests check it). Its loops
        // end (the traversal visits each node at most once), and it divides only by nonzero
        // values. The driver still bounds storage accesses (robustBufferAccess).
        true => unsafe {
            gpu.device
                .create_shader_module_trusted(descriptor, wgpu::ShaderRuntimeChecks::unchecked())
        },
        false => gpu.device.create_shader_module(descriptor),
    };
    let pipeline = gpu
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("raycast kernel"),
            layout: None,
            module: &shader_module,
            entry_point: Some(shader::ENTRY_POINT),
            compilation_options: Default::default(),
            cache: None,
        });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Device(format!(
            "cannot create the kernel pipeline: {e}"
        )));
    }
    Ok(Compiled { pipeline, bindings })
}

/// The image rows one dispatch may cover for `variant` on this device: an error when not one
/// row fits, when f64 is asked for without `SHADER_F64`, or when the primitives exceed the
/// bindings the variant declares.
fn check_limits<R: GpuReal>(
    gpu: &Gpu,
    [nx, ny]: [u32; 2],
    variant: &Variant,
    prepared: &Prepared<R>,
) -> Result<u32> {
    let p = &prepared.primitives;
    let nodes = prepared.bvh().map_or(0, |b| b.nodes.len());
    if R::PRECISION == Float::F64 && !gpu.has_f64() {
        return Err(Error::Device(format!(
            "`precision` f64: the adapter {} has no f64 shader support (SHADER_F64); use `precision` f32",
            gpu.info().name
        )));
    }
    let limits = gpu.device.limits();
    let max_width = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    let rows = max_tile_rows(&limits, nx, R::PRECISION);
    if nx as u64 > max_width || rows == 0 {
        return Err(Error::Argument {
            option: "resolution".into(),
            message: format!(
                "{nx}x{ny} is wider than this device can dispatch (at most {} pixels per row)",
                max_width.min(limits.max_storage_buffer_binding_size / surface_bytes(R::PRECISION))
            ),
        });
    }
    let chunk = 1u64 << variant.chunk_bits;
    let needed = (p.triangles.len().max(nodes) as u64).div_ceil(chunk);
    if needed > variant.chunks as u64 {
        return Err(Error::Device(format!(
            "{} triangles ({} BVH nodes) need {needed} storage bindings of {chunk}; this kernel binds {} (at most {} triangles on this device)",
            p.triangles.len(),
            nodes,
            variant.chunks,
            chunk * shader::MAX_CHUNKS as u64
        )));
    }
    Ok(rows.min(ny))
}

/// `items` in `variant.chunks` storage buffers of 2^`variant.chunk_bits` items (the last ones
/// possibly a zeroed placeholder), each padded with zeros to a multiple of 16 bytes.
fn chunked_upload<T: Pod>(
    gpu: &Gpu,
    label: &str,
    items: &[T],
    variant: &Variant,
) -> Vec<wgpu::Buffer> {
    let chunk = 1usize << variant.chunk_bits;
    (0..variant.chunks as usize)
        .map(|k| {
            let part = items.get(k * chunk..).unwrap_or(&[]);
            // Kernels with WIDE_TRIANGLES read a triangle as the 16-byte elements it lies in,
            // the last one's up to 8 bytes beyond it.
            padded_storage_buffer(gpu, label, &part[..part.len().min(chunk)], 16)
        })
        .collect()
}

fn surface_bytes(precision: Float) -> u64 {
    SURFACE_REALS
        * match precision {
            Float::F32 => 4,
            Float::F64 => 8,
        }
}

/// The most image rows one dispatch can cover at `width` pixels per row under `limits`
/// (output binding size and workgroups per dimension); 0 if not even one row fits.
pub(crate) fn max_tile_rows(limits: &wgpu::Limits, width: u32, precision: Float) -> u32 {
    let binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
    let by_memory = binding / (width as u64 * surface_bytes(precision));
    let by_dispatch = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    by_memory.min(by_dispatch).min(u32::MAX as u64) as u32
}

/// A buffer the kernel writes and the host copies out of, or maps itself (`direct`).
fn output_buffer(gpu: &Gpu, label: &str, size: u64, direct: bool) -> wgpu::Buffer {
    let read_by = match direct {
        true => wgpu::BufferUsages::MAP_READ,
        false => wgpu::BufferUsages::COPY_SRC,
    };
    gpu.transient_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | read_by,
        mapped_at_creation: false,
    })
}

/// A buffer the host maps to read results.
fn readback_buffer(gpu: &Gpu, size: u64) -> wgpu::Buffer {
    gpu.transient_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A storage buffer holding `items`, or one zeroed element when there are none
/// (WGSL bindings may not be empty; the count in `Params` stays 0).
fn storage_buffer<T: Pod>(gpu: &Gpu, label: &str, items: &[T]) -> wgpu::Buffer {
    padded_storage_buffer(gpu, label, items, wgpu::COPY_BUFFER_ALIGNMENT)
}

/// [`storage_buffer`] with zeros after `items` to a multiple of `align` bytes, written into the
/// buffer's memory as it is created (no padded copy of a large mesh first).
fn padded_storage_buffer<T: Pod>(gpu: &Gpu, label: &str, items: &[T], align: u64) -> wgpu::Buffer {
    let placeholder = [T::zeroed()];
    let items = if items.is_empty() {
        &placeholder
    } else {
        items
    };
    let bytes: &[u8] = bytemuck::cast_slice(items);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (bytes.len() as u64).next_multiple_of(align),
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: true,
    });
    // A new buffer's memory reads as zeros, the padding included.
    buffer
        .get_mapped_range_mut(..)
        .expect("a buffer mapped at creation has a mapped range")
        .slice(..bytes.len())
        .copy_from_slice(bytes);
    buffer.unmap();
    buffer
}

/// GPU time of compute passes from timestamp queries: one written at the beginning and one at
/// the end of each pass, resolved and copied to a mappable buffer after it.
struct PassTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

impl PassTimer {
    const BYTES: u64 = 2 * wgpu::QUERY_SIZE as u64;

    /// A timer, or `None` when the device has no `TIMESTAMP_QUERY`.
    fn new(gpu: &Gpu) -> Option<PassTimer> {
        if !gpu
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            return None;
        }
        let period_ns = f64::from(gpu.queue.get_timestamp_period());
        if period_ns <= 0.0 {
            return None;
        }
        let device = &gpu.device;
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: Self::BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PassTimer {
            query_set,
            resolve: buffer(
                "timestamp resolve",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "timestamp readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            period_ns,
        })
    }

    /// The pass's timestamp writes: index 0 at its beginning, 1 at its end.
    fn pass_writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records the resolve and the copy to the readback buffer, after the timed pass.
    fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.query_set, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, Self::BYTES);
    }

    /// Seconds between the two timestamps of the last submitted timed pass.
    fn read_seconds(&self, gpu: &Gpu) -> Result<f64> {
        map_buffers(gpu, &[self.readback.slice(..)], wgpu::MapMode::Read)?;
        let ticks = {
            let view = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| Error::Device(format!("GPU timestamp readback failed: {e}")))?;
            let t: &[u64] = bytemuck::cast_slice(&view[..]);
            t[1].saturating_sub(t[0])
        };
        self.readback.unmap();
        Ok(ticks as f64 * self.period_ns * 1e-9)
    }
}

/// Maps `parts` in `mode` and waits until the GPU has finished what was submitted.
fn map_buffers(gpu: &Gpu, parts: &[wgpu::BufferSlice<'_>], mode: wgpu::MapMode) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    for part in parts {
        let tx = tx.clone();
        part.map_async(mode, move |r| {
            let _ = tx.send(r);
        });
    }
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Device(format!("GPU did not finish: {e}")))?;
    for _ in parts {
        rx.recv()
            .map_err(|e| Error::Device(format!("GPU buffer mapping failed: {e}")))?
            .map_err(|e| Error::Device(format!("GPU buffer mapping failed: {e}")))?;
    }
    Ok(())
}

/// A per-pixel output buffer of the kernel (shaders/bindings.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    /// `out_surface`: normal and distance, `vec4<real>`.
    Surface,
    /// `out_id`: `i32`.
    Id,
    /// `out_certain`: `u32` flags (certainty variants).
    Certain,
    /// `out_color`: the shade hook's colour, `pack4x8unorm`.
    Color,
    /// `out_primitive`: `u32` (ray lists).
    Primitive,
    /// `out_uv`: `vec2<real>` (ray lists).
    Uv,
    /// `out_count`: `u32` (COUNT).
    Count,
}

impl Slot {
    /// The kernel's name for the buffer (shaders/bindings.wgsl).
    fn name(self) -> &'static str {
        match self {
            Slot::Surface => "out_surface",
            Slot::Id => "out_id",
            Slot::Certain => "out_certain",
            Slot::Color => "out_color",
            Slot::Primitive => "out_primitive",
            Slot::Uv => "out_uv",
            Slot::Count => "out_count",
        }
    }

    fn pixel_bytes(self, precision: Float) -> u64 {
        match self {
            Slot::Surface => surface_bytes(precision),
            Slot::Uv => surface_bytes(precision) / 2,
            Slot::Id | Slot::Certain | Slot::Color | Slot::Primitive | Slot::Count => ID_BYTES,
        }
    }
}

/// The output buffers a variant writes, each for `capacity` pixels, and, unless the host maps
/// them directly ([`Gpu::host_memory`]), one readback buffer holding them one after another (at
/// `capacity` pixels each).
struct OutputBuffers {
    /// Slot, buffer, and its offset in the readback buffer.
    slots: Vec<(Slot, wgpu::Buffer, u64)>,
    readback: Option<wgpu::Buffer>,
    precision: Float,
}

impl OutputBuffers {
    /// The buffers of the outputs `variant` writes: the surface when it asks for distance or
    /// normal, the ids when it asks for them, the certainty flags in a certainty variant, the
    /// colours with a shade hook, a ray list's primitives and barycentrics or counts.
    fn new(gpu: &Gpu, variant: &Variant, capacity: u64) -> OutputBuffers {
        let o = variant.outputs;
        let hit_detail = variant.casts == Casts::Rays && !variant.count;
        // Reals first, so that each slot starts aligned to its element in the readback
        // buffer whatever the capacity.
        let wanted = [
            (o.distance || o.normal, Slot::Surface),
            (hit_detail, Slot::Uv),
            (o.id, Slot::Id),
            (variant.certainty, Slot::Certain),
            (o.color, Slot::Color),
            (hit_detail, Slot::Primitive),
            (variant.count, Slot::Count),
        ];
        let direct = gpu.host_memory();
        let mut slots = Vec::new();
        let mut offset = 0;
        for (present, slot) in wanted {
            if present {
                let size = capacity * slot.pixel_bytes(variant.precision);
                slots.push((slot, output_buffer(gpu, slot.name(), size, direct), offset));
                offset += size;
            }
        }
        OutputBuffers {
            slots,
            // A mapped buffer may not be empty.
            readback: (!direct).then(|| readback_buffer(gpu, offset.max(4))),
            precision: variant.precision,
        }
    }

    /// Every buffer, for the next job ([`Gpu::keep_transient`]).
    fn into_buffers(self) -> impl Iterator<Item = wgpu::Buffer> {
        let slots = self.slots.into_iter().map(|(_, b, _)| b);
        slots.chain(self.readback)
    }

    /// The buffers by the kernel's names.
    fn named(&self) -> impl Iterator<Item = (String, &wgpu::Buffer)> {
        self.slots
            .iter()
            .map(|(slot, b, _)| (slot.name().to_owned(), b))
    }

    /// Records the copies of the first `pixels` pixels of each output to the readback buffer
    /// (none where the host maps the outputs).
    fn copy_to_readback(&self, encoder: &mut wgpu::CommandEncoder, pixels: u64) {
        if let Some(readback) = &self.readback {
            for (slot, buffer, offset) in &self.slots {
                let size = pixels * slot.pixel_bytes(self.precision);
                encoder.copy_buffer_to_buffer(buffer, 0, readback, *offset, size);
            }
        }
    }

    /// Bytes of the first `pixels` pixels of every output.
    fn bytes(&self, pixels: u64) -> u64 {
        let per_pixel: u64 = (self.slots.iter())
            .map(|(slot, _, _)| slot.pixel_bytes(self.precision))
            .sum();
        pixels * per_pixel
    }

    /// Runs `f` on the first `pixels` pixels of each output, mapped once the GPU has finished;
    /// adds the time waited for the GPU and the time of `f` to `stages`.
    fn read(
        &self,
        gpu: &Gpu,
        stages: &mut Stages,
        pixels: u64,
        f: impl FnOnce(&Mapped),
    ) -> Result<()> {
        let size = |slot: Slot| pixels * slot.pixel_bytes(self.precision);
        // What is mapped: the readback buffer whole (its slots need not start at the mapping
        // alignment), or each output's first `pixels` pixels.
        let parts: Vec<wgpu::BufferSlice<'_>> = match &self.readback {
            Some(readback) => vec![readback.slice(..)],
            None => self
                .slots
                .iter()
                .map(|(slot, buffer, _)| buffer.slice(..size(*slot).max(4)))
                .collect(),
        };
        let waiting = std::time::Instant::now();
        map_buffers(gpu, &parts, wgpu::MapMode::Read)?;
        stages.wait_s += waiting.elapsed().as_secs_f64();
        let converting = std::time::Instant::now();
        {
            let views = parts
                .iter()
                .map(|part| part.get_mapped_range())
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?;
            // Each slot's bytes: in which view, where.
            let at = self
                .slots
                .iter()
                .enumerate()
                .map(|(k, (slot, _, offset))| match &self.readback {
                    Some(_) => (*slot, 0, *offset as usize..(offset + size(*slot)) as usize),
                    None => (*slot, k, 0..size(*slot) as usize),
                })
                .collect();
            f(&Mapped { views, at });
        }
        parts.iter().for_each(|part| part.buffer().unmap());
        stages.convert_s += converting.elapsed().as_secs_f64();
        Ok(())
    }
}

/// The outputs of one dispatch as the host reads them ([`OutputBuffers::read`]).
struct Mapped {
    views: Vec<wgpu::BufferView>,
    /// Per slot the variant writes: the view holding it and its bytes there.
    at: Vec<(Slot, usize, std::ops::Range<usize>)>,
}

impl Mapped {
    /// The bytes of `slot`, if the variant writes it.
    fn bytes(&self, slot: Slot) -> Option<&[u8]> {
        let (_, view, range) = self.at.iter().find(|(s, _, _)| *s == slot)?;
        Some(&self.views[*view][range.clone()])
    }

    /// Copies the certainty flags into `certainty` from `start`, where the variant writes them.
    fn copy_certainty(&self, start: usize, certainty: Option<&mut [bool]>) {
        if let (Some(certainty), Some(flags)) = (certainty, self.bytes(Slot::Certain)) {
            let flags: &[u32] = bytemuck::cast_slice(flags);
            for (k, flag) in flags.iter().enumerate() {
                certainty[start + k] = *flag != 0;
            }
        }
    }
}

/// Copies one dispatch's results out of the readback buffer into `images` from pixel index
/// `start` (row-major; and into `certainty` alike): only the outputs
/// `variant` asks for; the others keep their miss values. A pixel is a hit where its id says
/// so, or, without ids, where its surface is not zero (every hit has a distance of at least
/// `min_t |dir| > 0` and a unit normal).
fn read_tile<R: GpuReal>(
    gpu: &Gpu,
    outputs: &OutputBuffers,
    stages: &mut Stages,
    variant: &Variant,
    (pixels, start): (usize, usize),
    images: &mut Images<R>,
    certainty: Option<&mut [bool]>,
) -> Result<()> {
    outputs.read(gpu, stages, pixels as u64, |view| {
        let surface: Option<&[[R; 4]]> = view.bytes(Slot::Surface).map(bytemuck::cast_slice);
        let ids: Option<&[i32]> = view.bytes(Slot::Id).map(bytemuck::cast_slice);
        view.copy_certainty(start, certainty);
        if let (Some(colors), Some(bytes)) = (&mut images.color, view.bytes(Slot::Color)) {
            let packed: &[u32] = bytemuck::cast_slice(bytes);
            for (k, c) in packed.iter().enumerate() {
                // pack4x8unorm puts red in the lowest byte.
                colors[start + k] = c.to_le_bytes();
            }
        }
        let o = variant.outputs;
        for k in 0..pixels {
            let px = start + k;
            let hit = match (ids, surface) {
                (Some(ids), _) => ids[k] != MISS,
                (None, Some(s)) => s[k] != [R::ZERO; 4],
                (None, None) => false,
            };
            if let Some(ids) = ids {
                images.id[px] = ids[k];
            }
            if let (true, Some(s)) = (hit, surface) {
                let s = s[k];
                if o.normal {
                    images.normal[px] = [s[0], s[1], s[2]];
                }
                if o.distance {
                    images.distance[px] = s[3];
                }
            }
        }
    })
}

/// Appends the hits of one dispatch to `hits` in one parallel pass over the kernel's outputs
/// (a pass per result reads each hit's memory again). The kernel writes a miss's id only: the
/// rest is the miss's values here.
fn read_hit_values<R: GpuReal>(
    hits: &mut Hits<R>,
    ids: &[i32],
    surface: &[[R; 4]],
    primitives: &[u32],
    uvs: &[[R; 2]],
) {
    use rayon::prelude::*;
    const RUN: usize = 4096;
    let n = ids.len();
    hits.t.reserve(n);
    hits.id.reserve(n);
    hits.normal.reserve(n);
    hits.primitive.reserve(n);
    hits.uv.reserve(n);
    let runs = (
        hits.t.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        hits.id.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        hits.normal.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        hits.primitive.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        hits.uv.spare_capacity_mut()[..n].par_chunks_mut(RUN),
    );
    runs.into_par_iter()
        .enumerate()
        .for_each(|(r, (t, id, normal, primitive, uv))| {
            for j in 0..t.len() {
                let k = r * RUN + j;
                let hit = ids[k] != MISS;
                let [x, y, z, w] = surface[k];
                id[j].write(ids[k]);
                t[j].write(if hit { w } else { R::INFINITY });
                normal[j].write(if hit { [x, y, z] } else { [R::ZERO; 3] });
                primitive[j].write(if hit { primitives[k] } else { INVALID_ID });
                uv[j].write(if hit { uvs[k] } else { [R::ZERO; 2] });
            }
        });
    // SAFETY: the pass above wrote the first `n` spare elements of each vector (the runs of
    // each cover `..n` alike), and `reserve` made room for them.
    unsafe {
        hits.t.set_len(hits.t.len() + n);
        hits.id.set_len(hits.id.len() + n);
        hits.normal.set_len(hits.normal.len() + n);
        hits.primitive.set_len(hits.primitive.len() + n);
        hits.uv.set_len(hits.uv.len() + n);
    }
}

/// Appends one dispatch's results for a ray list (rays `start..start + rays`, after those read
/// before) to `hits` (and copies them into `certainty`): t, id, normal, primitive and
/// barycentrics ([`read_hit_values`]), or counts.
fn read_hits<R: GpuReal>(
    gpu: &Gpu,
    outputs: &OutputBuffers,
    stages: &mut Stages,
    rays: usize,
    start: usize,
    hits: &mut Hits<R>,
    certainty: Option<&mut [bool]>,
) -> Result<()> {
    use rayon::prelude::*;
    outputs.read(gpu, stages, rays as u64, |view| {
        let slot = |slot| view.bytes(slot);
        view.copy_certainty(start, certainty);
        if let Some(counts) = slot(Slot::Count) {
            let counts: &[u32] = bytemuck::cast_slice(counts);
            hits.count.par_extend(counts.par_iter().copied());
        }
        if let (Some(ids), Some(surface), Some(primitives), Some(uvs)) = (
            slot(Slot::Id),
            slot(Slot::Surface),
            slot(Slot::Primitive),
            slot(Slot::Uv),
        ) {
            let ids: &[i32] = bytemuck::cast_slice(ids);
            let surface: &[[R; 4]] = bytemuck::cast_slice(surface);
            let primitives: &[u32] = bytemuck::cast_slice(primitives);
            let uvs: &[[R; 2]] = bytemuck::cast_slice(uvs);
            read_hit_values(hits, ids, surface, primitives, uvs);
        }
    })
}
