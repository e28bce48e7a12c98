//! Runs the kernel on a device: the one entry for every GPU render is [`run`], which takes a
//! prepared scene ([`Prepared`]) and a [`Job`]: the kernel [`Variant`], the rays to cast (the
//! camera's, in tiles of image rows, or a list of its pixels), whether to time it, and where
//! tiles go when the image is streamed. It uploads the primitives, binds every buffer by the
//! name the kernel gives it (from naga's reflection of the kernel), dispatches and reads back
//! the outputs the variant writes.

use bytemuck::Pod;

use super::Gpu;
use super::readback::{
    HookRayCounter, Mapped, OutputBuffers, PartTimer, append_hits, append_occluded, append_pixels,
    empty_images, map_buffers, surface_bytes,
};
use super::shader::{self, Casts, Variant};
use crate::error::{Error, Result};
use crate::images::{Images, Outputs, Stages};
use crate::kernel::layout::{
    GpuFrame, GpuParams, GpuPlane, GpuRay, GpuReal, GpuSphere, GpuTriangle, projection_code,
};
use crate::math::Float;
use crate::prepare::{Prepared, Primitives};
use crate::rays::Hits;
use crate::scene::Scene;

/// Workgroup edge in pixels (`@workgroup_size(8, 8)` in shaders/entry.wgsl; the packet kernel
/// numbers the same 64 invocations in one dimension).
const WORKGROUP: u32 = 8;
/// Invocations per workgroup of a pixel-list kernel (`@workgroup_size(64)`).
const LIST_WORKGROUP: u32 = 64;

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
    /// ray's direction; an occlusion variant's up to `t_far`): one invocation per ray. The
    /// results come back as [`Rendered::hits`] (or [`Rendered::occluded`]), in list order.
    List {
        list: crate::rays::RayList<'a>,
        t_near: f64,
        t_far: f64,
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
            rays: Rays::List {
                list,
                t_near,
                t_far: f64::INFINITY,
            },
            ..self
        }
    }

    /// Where the rays are a list: hits beyond `t_far` do not occlude (an occlusion variant).
    pub(crate) fn t_far(self, t_far: f64) -> Self {
        match self.rays {
            Rays::List { list, t_near, .. } => Job {
                rays: Rays::List {
                    list,
                    t_near,
                    t_far,
                },
                ..self
            },
            _ => self,
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
    /// Per ray of a [`Rays::List`] in an occlusion variant: whether it hits anything from
    /// `t_near` to `t_far`.
    pub occluded: Option<Vec<bool>>,
    pub stages: Stages,
}

/// `scene` prepared for `variant`: in its precision and algorithm, through a BVH where the
/// variant traverses one. A scene with more spheres and triangles than the variant's storage
/// bindings hold is refused here, before its BVH is built ([`run`] checks the prepared
/// buffers again).
pub(crate) fn prepare<R: GpuReal>(scene: &Scene, variant: &Variant) -> Result<Prepared<R>> {
    check_capacity(scene, variant)?;
    Ok(match variant.instances {
        true => Prepared::instanced(scene, variant.algorithm),
        false => Prepared::new(scene, variant.algorithm, variant.search()),
    })
}

/// `variant` as [`run`] compiles it for `scene`: its traversal stack sized to the scene's BVH,
/// which is built again here, and its plane loops to the scene's planes (for `--emit-shader`,
/// which writes the kernel a render ran).
pub(crate) fn as_run(scene: &Scene, variant: Variant) -> Variant {
    let bvh = match variant.instances {
        true => crate::prepare::instanced_bvh_of(scene, variant.algorithm),
        false => crate::prepare::bvh_of(scene, variant.algorithm, variant.search()),
    };
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
    let sized = match variant.as_given {
        false => variant
            .with_stack_for(prepared.bvh().map(|b| &**b))
            .with_planes(prepared.primitives.planes.len()),
        true => variant,
    };
    let variant = Variant {
        casts,
        rays_from_origin: variant.rays_from_origin
            && casts != Casts::Rays
            && prepared.camera_rays_from_origin(),
        list_origin: variant.list_origin && casts == Casts::Rays,
        ..sized
    };
    match (casts, variant.count || variant.occluded) {
        (Casts::Rays, false) => Ok(variant.with_outputs(crate::images::Outputs::GEOMETRY)),
        (Casts::Rays, true) => Ok(variant.with_outputs(crate::images::Outputs::NONE)),
        (_, false) => Ok(variant),
        (_, true) => Err(Error::Device(
            "intersections are counted, and occlusion tested, for a list of rays only".into(),
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
    check_job(&variant, sink.is_some(), prepared)?;
    let mut stages = Stages {
        build_s: prepared.build_s,
        packets: variant.uses_bvh().then(|| variant.uses_packets()),
        ..Stages::default()
    };
    let plan = Plan::new(gpu, prepared, &variant, rays, max_rows)?;

    let clock = std::time::Instant::now();
    let kernel = pipeline(gpu, variant)?;
    stages.compile_s = clock.elapsed().as_secs_f64();

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
    let slots = (0..plan.slots())
        .map(|_| PartBuffers::new::<R>(gpu, &kernel, &variant, &plan, resident, timed))
        .collect::<Result<Vec<_>>>()?;
    let mut delivery = Delivery::new(prepared, &variant, &plan, sink.is_some());
    // The counters' totals, summed part by part.
    stages.kernel_s = (timed && slots[0].timer.is_some()).then_some(0.0);
    stages.hook_rays = variant.hook_rays.then_some(0);
    // Part k is written and submitted before part k - 1 is read back, so that the host's
    // readback of one part overlaps the device's work on the next.
    let mut in_flight: Option<InFlight<'_>> = None;
    for (k, &part) in plan.parts.iter().enumerate() {
        let buffers = &slots[k % slots.len()];
        let writing = std::time::Instant::now();
        buffers.write_inputs(gpu, prepared, &plan, part)?;
        stages.write_s += writing.elapsed().as_secs_f64();
        let submitted = buffers.submit(gpu, &kernel, &plan, part);
        if let Some(done) = in_flight.replace((buffers, part, submitted)) {
            take_part(gpu, done, &plan, &mut stages, &mut delivery, sink.as_mut())?;
        }
    }
    if let Some(done) = in_flight {
        take_part(gpu, done, &plan, &mut stages, &mut delivery, sink.as_mut())?;
    }
    stages.trace_s = clock.elapsed().as_secs_f64();
    let mut rendered = delivery.finish();
    rendered.images.hook_rays = stages.hook_rays;
    rendered.stages = stages;
    gpu.keep_transient(
        slots
            .into_iter()
            .flat_map(PartBuffers::into_buffers)
            .collect(),
    );
    Ok(rendered)
}

/// An error where `variant` cannot run on `prepared` or cannot stream its results.
fn check_job<R: GpuReal>(variant: &Variant, streamed: bool, prepared: &Prepared<R>) -> Result<()> {
    if variant.casts != Casts::Camera && streamed {
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
    let planes = prepared.primitives.planes.len();
    let stack = prepared.bvh().map_or(0, |b| b.stack_entries());
    if variant.bvh_stack < stack || (variant.planes != 0 && usize::from(variant.planes) != planes) {
        return Err(Error::Device(format!(
            "the kernel variant (a stack of {} entries, {} planes) does not fit the prepared scene (a stack of {stack}, {planes} planes)",
            variant.bvh_stack, variant.planes
        )));
    }
    Ok(())
}

/// A part submitted: its buffers, which part, and its submission.
type InFlight<'b> = (&'b PartBuffers, Part, wgpu::SubmissionIndex);

/// Reads a submitted part back into `delivery` (handing it to `sink`, where the job streams),
/// and adds what its counters read to the totals in `stages`.
fn take_part<R: GpuReal>(
    gpu: &Gpu,
    (buffers, part, done): InFlight<'_>,
    plan: &Plan<'_>,
    stages: &mut Stages,
    delivery: &mut Delivery<R>,
    sink: Option<&mut TileSink<'_, R>>,
) -> Result<()> {
    let (kernel, copy, hook) = buffers.read_back(gpu, &done, plan, part, stages, delivery)?;
    if let (Some(total), Some(s)) = (stages.kernel_s.as_mut(), kernel) {
        *total += s;
    }
    if let Some(s) = copy {
        stages.copy_s = Some(stages.copy_s.unwrap_or(0.0) + s);
    }
    if let (Some(total), Some(n)) = (stages.hook_rays.as_mut(), hook) {
        *total += n;
    }
    delivery.deliver(part, sink)
}

/// One dispatch of a job: its first image row or list entry, and how many it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Part {
    first: u32,
    count: u32,
}

/// How a job's rays are split into dispatches ([`Plan::new`]).
struct Plan<'a> {
    rays: Rays<'a>,
    /// The image's width and height.
    resolution: [u32; 2],
    /// The width of the image a ray list's rays are rows of, when traced in packets.
    grid: Option<u32>,
    /// Rays each part's buffers hold.
    capacity: u64,
    parts: Vec<Part>,
}

impl<'a> Plan<'a> {
    /// The parts of `rays`: one, unless the job is more than one dispatch may hold (at most
    /// `max_rows` image rows and what the device's limits allow), each a whole number of bands
    /// of 8 rows where packets trace 8x8 blocks (`grid_slot` in shaders/entry.wgsl). Two parts'
    /// buffers are in use at once: where more than one part is needed, each holds at most half
    /// of what one dispatch may, so the job holds no more than one such dispatch. Smaller parts
    /// would overlap a part's readback with the next part's kernel, but on a GPU they cost more
    /// than that saves: each dispatch leaves the device part empty at its end, and the host's
    /// conversion slows (docs/performance.md#large-scenes-and-images).
    fn new<R: GpuReal>(
        gpu: &Gpu,
        prepared: &Prepared<R>,
        variant: &Variant,
        rays: Rays<'a>,
        max_rows: Option<u32>,
    ) -> Result<Plan<'a>> {
        let [nx, ny] = prepared.resolution();
        let device_rows = check_limits(gpu, [nx, ny], variant, prepared)?;
        // Entries of a list per dispatch: as many as the largest per-entry buffer allows.
        let entry_bytes = surface_bytes(R::PRECISION).max(size_of::<GpuRay<R>>() as u64);
        let list_capacity = (gpu.max_binding() / entry_bytes).min(u32::MAX as u64) as u32;
        let grid = match rays {
            Rays::List { list, .. } if variant.uses_packets() => list
                .width
                .and_then(|w| u32::try_from(w).ok())
                .filter(|&w| w <= list_capacity / 16),
            _ => None,
        };
        let (total, unit, most) = match rays {
            Rays::Camera => (ny, WORKGROUP, device_rows.min(max_rows.unwrap_or(u32::MAX))),
            _ => {
                let n = u32::try_from(rays.listed()).map_err(|_| {
                    Error::Device(format!(
                        "{} rays are more than one job casts (at most {})",
                        rays.listed(),
                        u32::MAX
                    ))
                })?;
                let unit = grid.map_or(LIST_WORKGROUP, |w| 8 * w);
                (n, unit, list_capacity)
            }
        };
        let step = part_step(total, unit, most);
        let parts: Vec<Part> = (0..total)
            .step_by(step as usize)
            .map(|first| Part {
                first,
                count: step.min(total - first),
            })
            .collect();
        let capacity = match rays {
            // An empty list dispatches nothing, but its buffers may not be empty.
            Rays::Camera => step as u64 * nx as u64,
            _ => (step as u64).clamp(1, list_capacity as u64),
        };
        Ok(Plan {
            rays,
            resolution: [nx, ny],
            grid,
            capacity,
            parts,
        })
    }

    /// How many parts' buffers are in use at once: two where there are several parts.
    fn slots(&self) -> usize {
        self.parts.len().clamp(1, 2)
    }

    /// Rays of `part`.
    fn rays_of(&self, part: Part) -> u64 {
        match self.rays {
            Rays::Camera => part.count as u64 * self.resolution[0] as u64,
            _ => part.count as u64,
        }
    }

    /// The index of `part`'s first ray among the job's (row-major for the camera).
    fn start_of(&self, part: Part) -> usize {
        match self.rays {
            Rays::Camera => part.first as usize * self.resolution[0] as usize,
            _ => part.first as usize,
        }
    }
}

/// Rows or entries a part covers: all `total` where `most` allows, else half of `most` (two
/// parts' buffers are in use at once), a multiple of `unit` where that allows.
fn part_step(total: u32, unit: u32, most: u32) -> u32 {
    let most = most.max(1);
    if total <= most {
        return total.max(1);
    }
    let half = (most / 2).max(1);
    match half >= unit {
        true => half / unit * unit,
        false => half,
    }
}

/// What one part's counters read: the kernel's and the copy's GPU seconds (where timed) and
/// the shade hook's rays (where it casts any).
type PartCounts = (Option<f64>, Option<f64>, Option<u64>);

/// The buffers one part in flight uses, bound to the kernel: its parameters, its list, its
/// outputs and their readback, its timer and hook-ray counter. A job has one or two
/// ([`Plan::slots`]); the scene's buffers are shared.
struct PartBuffers {
    params: wgpu::Buffer,
    /// The list's buffer, by the kernel's name for it.
    list: Option<(&'static str, wgpu::Buffer)>,
    outputs: OutputBuffers,
    timer: Option<PartTimer>,
    hook_rays: Option<HookRayCounter>,
    bind_group: wgpu::BindGroup,
}

impl PartBuffers {
    /// Buffers for one part of `plan`, bound with `resident`'s by the names `kernel` uses.
    fn new<R: GpuReal>(
        gpu: &Gpu,
        kernel: &Compiled,
        variant: &Variant,
        plan: &Plan<'_>,
        resident: &Resident,
        timed: bool,
    ) -> Result<PartBuffers> {
        let device = &gpu.device;
        let params = gpu.transient_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: size_of::<GpuParams<R>>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entry = match plan.rays {
            Rays::Camera => None,
            Rays::Pixels(_) => Some(("pixel_list", 4)),
            Rays::List { .. } => Some(("ray_list", size_of::<GpuRay<R>>() as u64)),
        };
        let list = entry.map(|(name, entry)| {
            let filled_by = match gpu.host_memory() {
                true => wgpu::BufferUsages::MAP_WRITE,
                false => wgpu::BufferUsages::COPY_DST,
            };
            let buffer = gpu.transient_buffer(&wgpu::BufferDescriptor {
                label: Some(name),
                size: plan.capacity * entry,
                usage: wgpu::BufferUsages::STORAGE | filled_by,
                mapped_at_creation: false,
            });
            (name, buffer)
        });
        let outputs = OutputBuffers::new(gpu, variant, plan.capacity);
        let hook_rays = variant.hook_rays.then(|| HookRayCounter::new(gpu));
        let mut buffers: Vec<(String, &wgpu::Buffer)> = resident
            .buffers
            .iter()
            .map(|(name, b)| (name.clone(), b))
            .collect();
        buffers.push(("params".into(), &params));
        buffers.extend(list.iter().map(|(name, b)| (name.to_string(), b)));
        buffers.extend(outputs.named());
        if let Some(counter) = &hook_rays {
            buffers.push(("hook_ray_count".into(), &counter.counter));
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raycast"),
            layout: &kernel.pipeline.get_bind_group_layout(0),
            entries: &kernel.entries(&buffers)?,
        });
        Ok(PartBuffers {
            params,
            list,
            outputs,
            timer: if timed { PartTimer::new(gpu) } else { None },
            hook_rays,
            bind_group,
        })
    }

    /// Writes `part`'s parameters and, for a list, its entries.
    fn write_inputs<R: GpuReal>(
        &self,
        gpu: &Gpu,
        prepared: &Prepared<R>,
        plan: &Plan<'_>,
        part: Part,
    ) -> Result<()> {
        let params = part_params(prepared, plan, part);
        (gpu.queue).write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let count = part.count as usize;
        let range = part.first as usize..(part.first + part.count) as usize;
        let Some((_, buffer)) = &self.list else {
            return Ok(());
        };
        match plan.rays {
            Rays::Camera => Ok(()),
            Rays::Pixels(list) => fill_buffer(gpu, buffer, count, 4, &|k, bytes| {
                let pixels = &list[range.start + k..];
                for (to, pixel) in bytes.chunks_exact_mut(4).zip(pixels) {
                    to.copy_from_slice(&pixel.to_ne_bytes());
                }
            }),
            Rays::List { list, .. } => {
                // The rays are checked as they are written (rays::check_rays names a bad one).
                let bad = std::sync::atomic::AtomicBool::new(false);
                fill_buffer(gpu, buffer, count, size_of::<GpuRay<R>>(), &|k, bytes| {
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
                match bad.into_inner() {
                    true => crate::rays::check_rays(list),
                    false => Ok(()),
                }
            }
        }
    }

    /// Encodes and submits `part`'s dispatch, the copies of its outputs for reading and its
    /// counters'.
    fn submit(
        &self,
        gpu: &Gpu,
        kernel: &Compiled,
        plan: &Plan<'_>,
        part: Part,
    ) -> wgpu::SubmissionIndex {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("raycast"),
                timestamp_writes: self.timer.as_ref().map(PartTimer::pass_writes),
            });
            pass.set_pipeline(&kernel.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            let [x, y] = workgroups(gpu, plan, part);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.outputs
            .copy_to_readback(&mut encoder, plan.rays_of(part));
        if let Some(timer) = &self.timer {
            timer.resolve(&mut encoder, &self.outputs);
        }
        if let Some(counter) = &self.hook_rays {
            counter.copy_and_reset(&mut encoder);
        }
        gpu.queue.submit([encoder.finish()])
    }

    /// Reads `part`'s results, submitted as `done`, into `delivery`, and its counters.
    fn read_back<R: GpuReal>(
        &self,
        gpu: &Gpu,
        done: &wgpu::SubmissionIndex,
        plan: &Plan<'_>,
        part: Part,
        stages: &mut Stages,
        delivery: &mut Delivery<R>,
    ) -> Result<PartCounts> {
        let rays = plan.rays_of(part);
        let start = plan.start_of(part);
        self.outputs.read(gpu, done, stages, rays, |view| {
            delivery.append(view, start, rays as usize)
        })?;
        let (kernel, copy) = match &self.timer {
            Some(timer) => {
                let (kernel, copy) = timer.read_seconds(gpu, done, &self.outputs)?;
                (Some(kernel), copy)
            }
            None => (None, None),
        };
        let hook = match &self.hook_rays {
            Some(counter) => Some(counter.read(gpu, done)?),
            None => None,
        };
        Ok((kernel, copy, hook))
    }

    /// Every transient buffer, for the next job ([`Gpu::keep_transient`]).
    fn into_buffers(self) -> impl Iterator<Item = wgpu::Buffer> {
        let list = self.list.map(|(_, b)| b);
        (self.outputs.into_buffers())
            .chain(list)
            .chain(std::iter::once(self.params))
    }
}

/// `part`'s parameters: the job's frame, the part's rows or entries, the scene's counts.
fn part_params<R: GpuReal>(prepared: &Prepared<R>, plan: &Plan<'_>, part: Part) -> GpuParams<R> {
    let mut frame = GpuFrame::new(&prepared.frame);
    let mut max_t = R::INFINITY;
    if let Rays::List { t_near, t_far, .. } = plan.rays {
        frame.min_t = R::from_f64(t_near);
        max_t = R::at_most(t_far);
    }
    let [nx, ny] = plan.resolution;
    let camera = matches!(plan.rays, Rays::Camera);
    GpuParams::<R> {
        frame,
        projection: projection_code(prepared.frame.projection),
        // A ray list's nx is its image width (0 when it is not an image's).
        nx: match plan.rays {
            Rays::List { .. } => plan.grid.unwrap_or(0),
            _ => nx,
        },
        ny,
        row_offset: if camera { part.first } else { 0 },
        tile_rows: part.count,
        sphere_count: prepared.primitives.spheres.len() as u32,
        plane_count: prepared.primitives.planes.len() as u32,
        triangle_count: prepared.primitives.triangles.len() as u32,
        origin: prepared.origin.cast::<R>().to_array(),
        unit: R::from_f64(prepared.unit),
        max_t,
        _pad: [R::ZERO; 3],
    }
}

/// The workgroups of `part`'s dispatch.
fn workgroups(gpu: &Gpu, plan: &Plan<'_>, part: Part) -> [u32; 2] {
    let count = part.count;
    match (plan.rays, plan.grid) {
        (Rays::Camera, _) => [
            plan.resolution[0].div_ceil(WORKGROUP),
            count.div_ceil(WORKGROUP),
        ],
        (_, Some(w)) => list_groups(gpu, w.div_ceil(8) * count.div_ceil(w).div_ceil(8)),
        (_, None) => list_groups(gpu, count.div_ceil(LIST_WORKGROUP)),
    }
}

/// Where a job's results go as its parts are read back: the images (whole, or a part's at a
/// time for a sink), or a list's hits, and the certainty flags.
struct Delivery<R> {
    outputs: Outputs,
    images: Images<R>,
    /// The images of the part read last, for a sink.
    tile: Option<Images<R>>,
    streamed: bool,
    focal_length: f64,
    hits: Option<Hits<R>>,
    certainty: Option<Vec<bool>>,
    occluded: Option<Vec<bool>>,
}

impl<R: GpuReal> Delivery<R> {
    fn new(prepared: &Prepared<R>, variant: &Variant, plan: &Plan<'_>, streamed: bool) -> Self {
        let [nx, ny] = plan.resolution;
        // Streamed, the parts go to the sink and only the part in hand is held.
        let whole = match plan.rays {
            Rays::Camera if streamed => [nx, 0],
            Rays::Camera => [nx, ny],
            Rays::Pixels(list) => [list.len() as u32, 1],
            Rays::List { .. } => [0, 0],
        };
        let color = variant.outputs.color;
        let images = empty_images(whole, prepared.focal_length, color);
        let pixels = whole[0] as usize * whole[1] as usize;
        let certainty = variant
            .certainty
            .then(|| vec![false; pixels.max(plan.rays.listed())]);
        Delivery {
            outputs: variant.outputs,
            images,
            tile: None,
            streamed,
            focal_length: prepared.focal_length,
            hits: match plan.rays {
                Rays::List { list, .. } if !variant.occluded => {
                    Some(Hits::with_capacity(list.len(), variant.count))
                }
                _ => None,
            },
            certainty,
            occluded: variant
                .occluded
                .then(|| Vec::with_capacity(plan.rays.listed())),
        }
    }

    /// Appends the `rays` results of the part from `start` in `view`.
    fn append(&mut self, view: &Mapped, start: usize, rays: usize) {
        view.copy_certainty(start, self.certainty.as_deref_mut());
        if let Some(occluded) = &mut self.occluded {
            return append_occluded(occluded, view);
        }
        if let Some(hits) = &mut self.hits {
            return append_hits(hits, view);
        }
        let images = match self.streamed {
            true => {
                let width = self.images.width;
                let rows = rays as u32 / width.max(1);
                let color = self.images.color.is_some();
                self.tile
                    .insert(empty_images([width, rows], self.focal_length, color))
            }
            false => &mut self.images,
        };
        append_pixels(images, view, self.outputs, rays);
    }

    /// Hands the part read last to `sink`, where the job streams.
    fn deliver(&mut self, part: Part, sink: Option<&mut TileSink<'_, R>>) -> Result<()> {
        match (sink, self.tile.take()) {
            (Some(sink), Some(tile)) => sink(part.first, tile),
            _ => Ok(()),
        }
    }

    fn finish(self) -> Rendered<R> {
        Rendered {
            images: self.images,
            hits: self.hits,
            certainty: self.certainty,
            occluded: self.occluded,
            stages: Stages::default(),
        }
    }
}

/// A prepared scene's buffers on one device ([`upload`]), for jobs that cast many times at
/// one scene ([`Job::resident`]), so that a cast of a few rays does not pay for uploading the
/// whole scene again.
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

/// `groups` workgroups for a list, laid out in rows of at most the device's limit per dimension.
fn list_groups(gpu: &Gpu, groups: u32) -> [u32; 2] {
    let max_groups = gpu.device.limits().max_compute_workgroups_per_dimension;
    [groups.min(max_groups), groups.div_ceil(max_groups)]
}

/// Writes consecutive entries of a list: the index of the first and their bytes (a whole
/// number of entries, so that one call's cost is shared by a run of them).
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
        map_buffers(gpu, &[part], wgpu::MapMode::Write, None)?;
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
    /// The instances' maps into their meshes (three rows each) and their words (the mesh's
    /// root node, the object).
    instance_transforms: Vec<[R; 4]>,
    instance_words: Vec<[u32; 2]>,
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
            instance_transforms: p.instances.iter().flat_map(|i| i.rows).collect(),
            instance_words: p.instances.iter().map(|i| [i.root, i.object]).collect(),
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
        if variant.instances {
            let transforms = &self.instance_transforms;
            let words = &self.instance_words;
            named.push((
                "instance_transforms".to_owned(),
                storage_buffer(gpu, "instance_transforms", transforms),
            ));
            named.push((
                "instance_words".to_owned(),
                storage_buffer(gpu, "instance_words", words),
            ));
        }
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
        // node per level at most (`with_stack_for` in `specialized`, or `check_job` for a variant
        // compiled as given; tests check it). Its loops
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
            gpu.info().adapter.name
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

/// The most image rows one dispatch can cover at `width` pixels per row under `limits`
/// (output binding size and workgroups per dimension); 0 if not even one row fits.
pub(crate) fn max_tile_rows(limits: &wgpu::Limits, width: u32, precision: Float) -> u32 {
    let binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
    let by_memory = binding / (width as u64 * surface_bytes(precision));
    let by_dispatch = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    by_memory.min(by_dispatch).min(u32::MAX as u64) as u32
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The parts of `total` rows or entries by [`part_step`], as [`Plan::new`] makes them.
    fn parts(total: u32, unit: u32, most: u32) -> Vec<u32> {
        let step = part_step(total, unit, most);
        (0..total)
            .step_by(step as usize)
            .map(|first| step.min(total - first))
            .collect()
    }

    #[test]
    fn parts_cover_the_job_in_whole_units_within_the_device_limit() {
        // A job one dispatch holds is one part: a 1920x1080 image, 2,073,600 listed rays.
        assert_eq!(parts(1080, 8, 1080), [1080]);
        assert_eq!(parts(36, 8, 36), [36]);
        assert_eq!(parts(2_073_600, 8 * 1920, u32::MAX), [2_073_600]);
        // An empty list still has a part (its buffers may not be empty).
        assert_eq!(part_step(0, 64, 1000), 1);
        // More than one dispatch holds: two parts in flight hold at most one dispatch's worth.
        for (total, most, unit) in [
            (16384, 256, 8),
            (1000, 3, 8),
            (1000, 1, 8),
            (5_000_000, 1 << 20, 64),
        ] {
            let p = parts(total, unit, most);
            assert_eq!(p.iter().map(|&n| n as u64).sum::<u64>(), total as u64);
            assert!(
                p.iter().all(|&n| n <= (most / 2).max(1)),
                "{total} {most}: {p:?}"
            );
        }
        // Every part but the last a whole number of units, where the limit allows one.
        for total in [1, 7, 8, 100, 1079, 1080, 4321] {
            for most in [16, 100, 1000] {
                let p = parts(total, 8, most);
                assert_eq!(p.iter().sum::<u32>(), total);
                assert!(
                    p[..p.len() - 1].iter().all(|&n| n % 8 == 0),
                    "{total} {most}: {p:?}"
                );
            }
        }
    }
}
