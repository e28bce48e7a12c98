//! Runs the kernel on a device: uploads the primitives, dispatches tiles of image rows and reads
//! back the outputs its variant writes (id, distance and normal, or some of them).

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use super::Gpu;
use super::hooks::ShadeHook;
use super::layout::{
    GpuFrame, GpuParams, GpuPlane, GpuReal, GpuSphere, GpuTriangle, projection_code,
};
use super::shader::{self, Variant};
use crate::algorithm::Algorithm;
use crate::bvh::{Accel, BvhNode};
use crate::cpu;
use crate::error::{Error, Result};
use crate::images::{Images, MISS, Outputs, Pixel};
use crate::math::Precision;
use crate::scene::Scene;

/// Workgroup edge in pixels (`@workgroup_size(8, 8)` in shaders/main.wgsl).
const WORKGROUP: u32 = 8;
/// Bytes of output per pixel and unit of precision: `vec4<real>` surface.
const SURFACE_REALS: u64 = 4;
/// Bytes of output per pixel: `i32` id.
const ID_BYTES: u64 = 4;

/// A scene's primitives in the GPU's layout (from the same rounded values the CPU reference
/// uses), and the object id of each: spheres first, then planes, then triangles. With a BVH,
/// spheres and triangles are in its order, and `order` holds each one's index in the scene's.
struct Primitives<R> {
    spheres: Vec<GpuSphere<R>>,
    planes: Vec<GpuPlane<R>>,
    triangles: Vec<GpuTriangle<R>>,
    objects: Vec<u32>,
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

impl<R: GpuReal> Primitives<R> {
    /// The primitives for `variant`'s kernel (through a BVH where it uses one).
    fn new(scene: &Scene, variant: &Variant) -> Primitives<R> {
        let accel = if variant.uses_bvh() {
            Accel::Bvh
        } else {
            Accel::BruteForce
        };
        let p = cpu::types::Primitives::<R>::for_render(scene, variant.algorithm, accel);
        let (nodes, order) = match &p.bvh {
            Some(bvh) => {
                let planes = 0..p.planes.len() as u32;
                let order = [
                    &bvh.sphere_order[..],
                    &planes.collect::<Vec<_>>(),
                    &bvh.triangle_order,
                ]
                .concat();
                (bvh.nodes.clone(), order)
            }
            None => (Vec::new(), Vec::new()),
        };
        Primitives {
            spheres: p
                .spheres
                .iter()
                .map(|s| GpuSphere {
                    center: s.center.to_array(),
                    radius: s.radius,
                })
                .collect(),
            planes: p
                .planes
                .iter()
                .map(|q| GpuPlane {
                    point: q.point.to_array(),
                    _pad0: R::ZERO,
                    normal: q.normal.to_array(),
                    _pad1: R::ZERO,
                })
                .collect(),
            triangles: p
                .triangles
                .iter()
                .map(|t| GpuTriangle {
                    a: t.a.to_array(),
                    _pad0: R::ZERO,
                    b: t.b.to_array(),
                    _pad1: R::ZERO,
                    c: t.c.to_array(),
                    _pad2: R::ZERO,
                })
                .collect(),
            objects: [p.sphere_objects, p.plane_objects, p.triangle_objects].concat(),
            nodes,
            order,
        }
    }

    /// The spheres, planes, triangles and object ids as storage buffers (bindings 1 to 4),
    /// and the BVH's nodes and primitive order (bindings 9 and 10); triangles and nodes in
    /// `variant.chunks` buffers each.
    fn upload(&self, gpu: &Gpu, variant: &Variant) -> Uploaded {
        // With UNIFORM_PRIMS, bindings 1 to 3 are uniform buffers (one chunk).
        let uniform = variant
            .uses_uniform_prims()
            .then(|| shader::UniformCapacity::of(variant.precision));
        let (spheres, planes, triangles) = match uniform {
            Some(c) => (
                uniform_buffer(gpu, "spheres", &self.spheres, c.spheres),
                uniform_buffer(gpu, "planes", &self.planes, c.planes),
                vec![uniform_buffer(
                    gpu,
                    "triangles",
                    &self.triangles,
                    c.triangles,
                )],
            ),
            None => (
                storage_buffer(gpu, "spheres", &self.spheres),
                storage_buffer(gpu, "planes", &self.planes),
                chunked_upload(gpu, "triangles", &self.triangles, variant),
            ),
        };
        Uploaded {
            spheres,
            planes,
            triangles,
            objects: storage_buffer(gpu, "objects", &self.objects),
            nodes: chunked_upload(gpu, "bvh_nodes", &self.nodes, variant),
            order: storage_buffer(gpu, "prim_order", &self.order),
        }
    }
}

/// `items` in `variant.chunks` storage buffers of 2^`variant.chunk_bits` items (the last ones
/// possibly a zeroed placeholder).
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
            storage_buffer(gpu, label, &part[..part.len().min(chunk)])
        })
        .collect()
}

/// Binding numbers of the triangle chunks and of the node chunks (shaders/bindings.wgsl).
const TRIANGLE_BINDINGS: [u32; 4] = [3, 11, 12, 13];
const NODE_BINDINGS: [u32; 4] = [9, 14, 15, 16];

/// The scene's buffers on the device.
struct Uploaded {
    spheres: wgpu::Buffer,
    planes: wgpu::Buffer,
    triangles: Vec<wgpu::Buffer>,
    objects: wgpu::Buffer,
    nodes: Vec<wgpu::Buffer>,
    order: wgpu::Buffer,
}

impl Uploaded {
    /// The scene's bindings: (binding number, buffer).
    fn entries(&self) -> Vec<(u32, &wgpu::Buffer)> {
        let mut e = vec![
            (1, &self.spheres),
            (2, &self.planes),
            (4, &self.objects),
            (10, &self.order),
        ];
        e.extend(TRIANGLE_BINDINGS.into_iter().zip(&self.triangles));
        e.extend(NODE_BINDINGS.into_iter().zip(&self.nodes));
        e
    }
}

/// `Params.origin`: where the kernel's coordinates are measured from, in world coordinates.
fn kernel_origin<R: GpuReal>(scene: &Scene, algorithm: Algorithm) -> [R; 3] {
    cpu::types::kernel_origin(scene, algorithm)
        .cast::<R>()
        .to_array()
}

fn surface_bytes(precision: Precision) -> u64 {
    SURFACE_REALS
        * match precision {
            Precision::F32 => 4,
            Precision::F64 => 8,
        }
}

/// The most image rows one dispatch can cover at `width` pixels per row under `limits`
/// (output binding size and workgroups per dimension); 0 if not even one row fits.
pub fn max_tile_rows(limits: &wgpu::Limits, width: u32, precision: Precision) -> u32 {
    let binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
    let by_memory = binding / (width as u64 * surface_bytes(precision));
    let by_dispatch = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    by_memory.min(by_dispatch).min(u32::MAX as u64) as u32
}

fn check_limits<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: &Variant,
    prims: &Primitives<R>,
) -> Result<u32> {
    if R::PRECISION == Precision::F64 && !gpu.device.features().contains(wgpu::Features::SHADER_F64)
    {
        return Err(Error::Device(format!(
            "--precision f64: the adapter {} has no f64 shader support (SHADER_F64); use --precision f32",
            gpu.info().name
        )));
    }
    let limits = gpu.device.limits();
    let [nx, ny] = scene.camera.resolution;
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
    let capacity = shader::UniformCapacity::of(R::PRECISION);
    let counts = [
        (prims.spheres.len(), capacity.spheres),
        (prims.planes.len(), capacity.planes),
        (prims.triangles.len(), capacity.triangles),
    ];
    if variant.uses_uniform_prims() && counts.iter().any(|&(n, cap)| n > cap as usize) {
        return Err(Error::Device(format!(
            "{} spheres, {} planes and {} triangles do not fit uniform buffers of {} bytes (at most {capacity:?})",
            counts[0].0,
            counts[1].0,
            counts[2].0,
            shader::UNIFORM_BYTES
        )));
    }
    let chunk = 1u64 << variant.chunk_bits;
    let needed = (prims.triangles.len().max(prims.nodes.len()) as u64).div_ceil(chunk);
    if needed > variant.chunks as u64 {
        return Err(Error::Device(format!(
            "{} triangles ({} BVH nodes) need {needed} storage bindings of {chunk}; this kernel binds {} (at most {} triangles on this device)",
            prims.triangles.len(),
            prims.nodes.len(),
            variant.chunks,
            chunk * shader::MAX_CHUNKS as u64
        )));
    }
    Ok(rows.min(ny))
}

/// The bind group entries `variant` declares (binding numbers of shaders/bindings.wgsl): the
/// primitive buffers only for the kinds compiled in, the object ids when there is any.
fn bind_entries<'a>(
    variant: &Variant,
    buffers: &[(u32, &'a wgpu::Buffer)],
) -> Vec<wgpu::BindGroupEntry<'a>> {
    let k = variant.kinds;
    buffers
        .iter()
        .filter(|(binding, _)| match binding {
            1 => k.spheres,
            2 => k.planes,
            3 => k.triangles,
            4 => k.any(),
            9 | 10 => variant.uses_bvh(),
            11..=13 => k.triangles && *binding - 9 <= variant.chunks as u32,
            14..=16 => variant.uses_bvh() && *binding - 12 <= variant.chunks as u32,
            _ => true,
        })
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect()
}

/// A buffer the kernel writes and the host copies out of.
fn output_buffer(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// A buffer the host maps to read results.
fn readback_buffer(gpu: &Gpu, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A storage buffer holding `items`, or one zeroed element when there are none
/// (WGSL bindings may not be empty; the count in `Params` stays 0).
fn storage_buffer<T: Pod>(gpu: &Gpu, label: &str, items: &[T]) -> wgpu::Buffer {
    let placeholder = [T::zeroed()];
    let items = if items.is_empty() {
        &placeholder
    } else {
        items
    };
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(items),
            usage: wgpu::BufferUsages::STORAGE,
        })
}

/// A uniform buffer holding `items` zero-padded to `capacity` items: the size of the
/// fixed-size array the kernel declares (UNIFORM_PRIMS), which wgpu requires it to have.
fn uniform_buffer<T: Pod>(gpu: &Gpu, label: &str, items: &[T], capacity: u32) -> wgpu::Buffer {
    let mut bytes = vec![0u8; capacity as usize * size_of::<T>()];
    let data: &[u8] = bytemuck::cast_slice(items);
    bytes[..data.len()].copy_from_slice(data);
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        })
}

/// The kernel pipeline for `variant`, compiled once per [`Gpu`].
fn pipeline(gpu: &Gpu, variant: Variant) -> Result<wgpu::ComputePipeline> {
    let mut cache = gpu.pipelines.lock().expect("pipeline cache lock");
    if let Some(p) = cache.get(&variant) {
        return Ok(p.clone());
    }
    let p = create_pipeline(gpu, &variant)?;
    cache.insert(variant, p.clone());
    Ok(p)
}

fn create_pipeline(gpu: &Gpu, variant: &Variant) -> Result<wgpu::ComputePipeline> {
    let source = shader::kernel_source(variant)?;
    // Validate with naga first so a shader error reads as WGSL line and column.
    shader::validate(&source, "kernel")?;
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("raycast kernel"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    let pipeline = gpu
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("raycast kernel"),
            layout: None,
            module: &module,
            entry_point: Some(shader::ENTRY_POINT),
            compilation_options: Default::default(),
            cache: None,
        });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Device(format!(
            "cannot create the kernel pipeline: {e}"
        )));
    }
    Ok(pipeline)
}

/// Renders `scene` at `scene.camera.resolution` on `gpu` with `algorithm`, in precision `R`
/// (`f32`, or `f64` where the adapter has `SHADER_F64`).
pub fn render<R: GpuReal>(gpu: &Gpu, scene: &Scene, algorithm: Algorithm) -> Result<Images<R>> {
    let variant = gpu.scene_variant(scene, R::PRECISION, algorithm);
    Ok(render_variant::<R>(gpu, scene, variant, false)?.images)
}

/// [`render`] computing and reading back only `outputs`; the others keep their miss values
/// (see [`Outputs`]). `outputs.color` is the colour of the `shade` hook, called for every
/// pixel ([`Images::color`]), and is ignored without one.
pub fn render_outputs<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
    outputs: Outputs,
    shade: Option<&ShadeHook>,
) -> Result<Images<R>> {
    let variant = gpu.request_variant(scene, R::PRECISION, algorithm, outputs, shade);
    Ok(render_variant::<R>(gpu, scene, variant, false)?.images)
}

/// Renders with an explicit kernel `variant` (for example the general kernel with every kind
/// compiled in, to check a specialised one against it).
pub fn render_with_variant<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
) -> Result<Images<R>> {
    Ok(render_variant::<R>(gpu, scene, variant, false)?.images)
}

/// [`render`], also returning the kernel's GPU time in seconds: the sum over tiles of the time
/// between the timestamps written at the beginning and the end of each compute pass (readback
/// and upload not included). `None` when the device lacks `TIMESTAMP_QUERY`.
pub fn render_timed<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
) -> Result<(Images<R>, Option<f64>)> {
    let variant = gpu.scene_variant(scene, R::PRECISION, algorithm);
    let r = render_variant::<R>(gpu, scene, variant, true)?;
    Ok((r.images, r.kernel_s))
}

/// Renders only the listed pixels (row-major indices), in list order: one invocation per
/// listed pixel, so the cost follows the length of the list.
pub fn render_pixels<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
    pixels: &[usize],
) -> Result<Vec<Pixel<R>>> {
    Ok(pixels_inner::<R>(gpu, scene, algorithm, pixels, false)?.0)
}

/// [`render_pixels`], also returning the kernel's GPU time in seconds (summed over the
/// dispatches; see [`render_timed`]); `None` without `TIMESTAMP_QUERY`, `Some(0.0)` for an
/// empty list.
pub fn render_pixels_timed<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
    pixels: &[usize],
) -> Result<(Vec<Pixel<R>>, Option<f64>)> {
    pixels_inner::<R>(gpu, scene, algorithm, pixels, true)
}

fn pixels_inner<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
    pixels: &[usize],
    timed: bool,
) -> Result<(Vec<Pixel<R>>, Option<f64>)> {
    let timer = if timed { PassTimer::new(gpu) } else { None };
    let mut kernel_s = timer.as_ref().map(|_| 0.0);
    if pixels.is_empty() {
        return Ok((Vec::new(), kernel_s));
    }
    let variant = Variant {
        pixel_list: true,
        ..gpu.scene_variant(scene, R::PRECISION, algorithm)
    };
    let prims = Primitives::<R>::new(scene, &variant);
    check_limits(gpu, scene, &variant, &prims)?;
    let limits = gpu.device.limits();
    let max_binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let chunk = (max_binding / surface_bytes(R::PRECISION)) as usize;
    let mut out = Vec::with_capacity(pixels.len());
    for part in pixels.chunks(chunk) {
        out.extend(render_pixel_chunk::<R>(
            gpu,
            scene,
            variant,
            &prims,
            part,
            timer.as_ref(),
        )?);
        if let (Some(timer), Some(total)) = (&timer, &mut kernel_s) {
            *total += timer.read_seconds(gpu)?;
        }
    }
    Ok((out, kernel_s))
}

fn render_pixel_chunk<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    prims: &Primitives<R>,
    pixels: &[usize],
    timer: Option<&PassTimer>,
) -> Result<Vec<Pixel<R>>> {
    let algorithm = variant.algorithm;
    let pipeline = pipeline(gpu, variant)?;
    let device = &gpu.device;
    let [nx, ny] = scene.camera.resolution;
    let frame = cpu::types::kernel_frame(scene, algorithm);
    let n = pixels.len() as u64;
    let params = GpuParams::<R> {
        frame: GpuFrame::new(&frame),
        projection: projection_code(frame.projection),
        nx,
        ny,
        row_offset: 0,
        tile_rows: pixels.len() as u32,
        sphere_count: prims.spheres.len() as u32,
        plane_count: prims.planes.len() as u32,
        triangle_count: prims.triangles.len() as u32,
        origin: kernel_origin::<R>(scene, algorithm),
        _pad0: R::ZERO,
    };
    let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let list: Vec<u32> = pixels.iter().map(|&k| k as u32).collect();
    let list = storage_buffer(gpu, "pixel_list", &list);
    let outputs = OutputBuffers::new(gpu, &variant, n);
    let uploaded = prims.upload(gpu, &variant);
    let mut buffers = vec![(0, &params_buffer), (7, &list)];
    buffers.extend(uploaded.entries());
    buffers.extend(outputs.entries());
    let entries = bind_entries(&variant, &buffers);
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("raycast pixel list"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    // 64 invocations a workgroup, the workgroups laid out in rows of at most the limit.
    let groups = pixels.len().div_ceil(64) as u32;
    let max_groups = device.limits().max_compute_workgroups_per_dimension;
    let (gx, gy) = (groups.min(max_groups), groups.div_ceil(max_groups));
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("raycast pixel list"),
            timestamp_writes: timer.map(PassTimer::pass_writes),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }
    if let Some(timer) = timer {
        timer.resolve(&mut encoder);
    }
    outputs.copy_to_readback(&mut encoder, n);
    gpu.queue.submit([encoder.finish()]);
    // Read back as a one-row image of the listed pixels.
    let mut row = Images::<R>::new_miss(pixels.len() as u32, 1, scene.camera.focal_length);
    read_tile(gpu, &outputs, &variant, pixels.len(), 0, &mut row, None)?;
    Ok((0..pixels.len()).map(|k| row.pixel(k)).collect())
}

/// The first pass of adaptive precision: a robust f32 render that also says, per pixel,
/// whether its hit/miss and id are certain (the bounds of `src/cpu/margin.rs`).
pub fn render_with_certainty(gpu: &Gpu, scene: &Scene) -> Result<(Images<f32>, Vec<bool>)> {
    let (images, certain, _) = certainty_inner(gpu, scene, false)?;
    Ok((images, certain))
}

/// [`render_with_certainty`], also returning the kernel's GPU time in seconds (see
/// [`render_timed`]); `None` without `TIMESTAMP_QUERY`.
pub fn render_with_certainty_timed(
    gpu: &Gpu,
    scene: &Scene,
) -> Result<(Images<f32>, Vec<bool>, Option<f64>)> {
    certainty_inner(gpu, scene, true)
}

fn certainty_inner(
    gpu: &Gpu,
    scene: &Scene,
    timed: bool,
) -> Result<(Images<f32>, Vec<bool>, Option<f64>)> {
    let variant = Variant {
        certainty: true,
        ..gpu.scene_variant(scene, Precision::F32, Algorithm::Robust)
    };
    let r = render_variant::<f32>(gpu, scene, variant, timed)?;
    let certain = r.certainty.expect("a certainty variant reports certainty");
    Ok((r.images, certain, r.kernel_s))
}

/// What [`render_variant`] returns.
struct Rendered<R> {
    images: Images<R>,
    /// Per-pixel certainty flags, in a certainty variant.
    certainty: Option<Vec<bool>>,
    /// Kernel GPU time in seconds, when timed on a device with timestamp queries.
    kernel_s: Option<f64>,
    stages: Stages,
}

/// Wall-clock seconds of the stages of one render, and the kernel's GPU time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stages {
    /// Primitives rounded and laid out for the GPU, the BVH built (when the kernel uses one).
    pub build_s: f64,
    /// The kernel pipeline made (0 when it was cached).
    pub compile_s: f64,
    /// The scene's buffers created and filled on the device.
    pub upload_s: f64,
    /// Every tile dispatched and read back.
    pub trace_s: f64,
    /// The kernel's GPU time summed over tiles (timestamp queries), where the device has them.
    pub kernel_s: Option<f64>,
}

/// Renders with the kernel `variant`, timing each stage (see [`Stages`]).
pub fn render_stages<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
) -> Result<(Images<R>, Stages)> {
    let r = render_variant::<R>(gpu, scene, variant, true)?;
    Ok((r.images, r.stages))
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
        map_for_reading(gpu, &self.readback)?;
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

/// Maps `buffer` for reading and waits until the GPU has finished what was submitted.
fn map_for_reading(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Device(format!("GPU did not finish: {e}")))?;
    rx.recv()
        .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?
        .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))
}

/// Renders with the kernel `variant`; with `variant.certainty` also returns the per-pixel
/// certainty flags, and with `timed` the kernel time (where the device has timestamp queries).
fn render_variant<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    timed: bool,
) -> Result<Rendered<R>> {
    render_tiles(gpu, scene, variant, timed, None, None)
}

/// What receives the tiles of a streamed render: the first image row of the tile and its
/// images (`tile.height` rows).
pub type TileSink<'a, R> = &'a mut dyn FnMut(u32, Images<R>) -> Result<()>;

/// Renders with the kernel `variant`, handing each tile of at most `max_rows` rows (fewer
/// where the device's limits require) to `sink` as soon as it is read back, in order from the
/// top: the whole image is never held, so huge images need only one tile's memory. Returns
/// the stages' times.
pub fn render_streamed<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    max_rows: u32,
    sink: TileSink<'_, R>,
) -> Result<Stages> {
    let r = render_tiles(gpu, scene, variant, true, Some(max_rows.max(1)), Some(sink))?;
    Ok(r.stages)
}

/// Renders with the kernel `variant` in tiles of at most `max_rows` image rows (fewer when the
/// device's limits require it), to check that tiling changes nothing.
pub fn render_in_tiles<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    max_rows: u32,
) -> Result<Images<R>> {
    Ok(render_tiles(gpu, scene, variant, false, Some(max_rows.max(1)), None)?.images)
}

fn render_tiles<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    timed: bool,
    max_rows: Option<u32>,
    mut sink: Option<TileSink<'_, R>>,
) -> Result<Rendered<R>> {
    let algorithm = variant.algorithm;
    let mut stages = Stages::default();
    let clock = std::time::Instant::now();
    let prims = Primitives::<R>::new(scene, &variant);
    stages.build_s = clock.elapsed().as_secs_f64();
    let tile_rows = check_limits(gpu, scene, &variant, &prims)?.min(max_rows.unwrap_or(u32::MAX));
    let [nx, ny] = scene.camera.resolution;
    let frame = cpu::types::kernel_frame(scene, algorithm);
    let clock = std::time::Instant::now();
    let pipeline = pipeline(gpu, variant)?;
    stages.compile_s = clock.elapsed().as_secs_f64();
    let device = &gpu.device;

    let clock = std::time::Instant::now();
    let uploaded = prims.upload(gpu, &variant);
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Device(format!("GPU upload did not finish: {e}")))?;
    stages.upload_s = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: size_of::<GpuParams<R>>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let outputs = OutputBuffers::new(gpu, &variant, tile_rows as u64 * nx as u64);
    let mut entries = vec![(0, &params_buffer)];
    entries.extend(uploaded.entries());
    entries.extend(outputs.entries());
    let entries = bind_entries(&variant, &entries);
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("raycast"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });

    // Streamed, the tiles go to the sink and only the tile in hand is held.
    let whole_rows = if sink.is_some() { 0 } else { ny };
    let new_images = |rows: u32| {
        let mut images = Images::new_miss(nx, rows, scene.camera.focal_length);
        images.color = variant.outputs.color.then(|| vec![[0; 4]; images.len()]);
        images
    };
    let mut images = new_images(whole_rows);
    let mut certainty = variant.certainty.then(|| vec![false; images.len()]);
    let timer = if timed { PassTimer::new(gpu) } else { None };
    let mut kernel_s = timer.as_ref().map(|_| 0.0);
    let mut row = 0;
    while row < ny {
        let rows = tile_rows.min(ny - row);
        let params = GpuParams::<R> {
            frame: GpuFrame::new(&frame),
            projection: projection_code(frame.projection),
            nx,
            ny,
            row_offset: row,
            tile_rows: rows,
            sphere_count: prims.spheres.len() as u32,
            plane_count: prims.planes.len() as u32,
            triangle_count: prims.triangles.len() as u32,
            origin: kernel_origin::<R>(scene, algorithm),
            _pad0: R::ZERO,
        };
        gpu.queue
            .write_buffer(&params_buffer, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("raycast"),
                timestamp_writes: timer.as_ref().map(PassTimer::pass_writes),
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(nx.div_ceil(WORKGROUP), rows.div_ceil(WORKGROUP), 1);
        }
        if let Some(timer) = &timer {
            timer.resolve(&mut encoder);
        }
        let pixels = rows as u64 * nx as u64;
        outputs.copy_to_readback(&mut encoder, pixels);
        gpu.queue.submit([encoder.finish()]);
        if let Some(sink) = sink.as_mut() {
            let mut tile = new_images(rows);
            read_tile(gpu, &outputs, &variant, pixels as usize, 0, &mut tile, None)?;
            sink(row, tile)?;
        } else {
            read_tile(
                gpu,
                &outputs,
                &variant,
                pixels as usize,
                row,
                &mut images,
                certainty.as_deref_mut(),
            )?;
        }
        if let (Some(timer), Some(total)) = (&timer, &mut kernel_s) {
            *total += timer.read_seconds(gpu)?;
        }
        row += rows;
    }
    stages.trace_s = clock.elapsed().as_secs_f64();
    stages.kernel_s = kernel_s;
    Ok(Rendered {
        images,
        certainty,
        kernel_s,
        stages,
    })
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
}

impl Slot {
    fn binding(self) -> u32 {
        match self {
            Slot::Surface => 5,
            Slot::Id => 6,
            Slot::Certain => 7,
            Slot::Color => 8,
        }
    }

    fn label(self) -> &'static str {
        match self {
            Slot::Surface => "out_surface",
            Slot::Id => "out_id",
            Slot::Certain => "out_certain",
            Slot::Color => "out_color",
        }
    }

    fn pixel_bytes(self, precision: Precision) -> u64 {
        match self {
            Slot::Surface => surface_bytes(precision),
            Slot::Id | Slot::Certain | Slot::Color => ID_BYTES,
        }
    }
}

/// The output buffers a variant writes, each for `capacity` pixels, and one readback buffer
/// holding them one after another (at `capacity` pixels each).
struct OutputBuffers {
    /// Slot, buffer, and its offset in the readback buffer.
    slots: Vec<(Slot, wgpu::Buffer, u64)>,
    readback: wgpu::Buffer,
    precision: Precision,
}

impl OutputBuffers {
    /// The buffers of the outputs `variant` writes: the surface when it asks for distance or
    /// normal, the ids when it asks for them, the certainty flags in a certainty variant, the
    /// colours with a shade hook.
    fn new(gpu: &Gpu, variant: &Variant, capacity: u64) -> OutputBuffers {
        let o = variant.outputs;
        let wanted = [
            (o.distance || o.normal, Slot::Surface),
            (o.id, Slot::Id),
            (variant.certainty, Slot::Certain),
            (o.color, Slot::Color),
        ];
        let mut slots = Vec::new();
        let mut offset = 0;
        for (present, slot) in wanted {
            if present {
                let size = capacity * slot.pixel_bytes(variant.precision);
                slots.push((slot, output_buffer(gpu, slot.label(), size), offset));
                offset += size;
            }
        }
        OutputBuffers {
            slots,
            // A mapped buffer may not be empty.
            readback: readback_buffer(gpu, offset.max(4)),
            precision: variant.precision,
        }
    }

    /// Bind group entries: (binding, buffer).
    fn entries(&self) -> impl Iterator<Item = (u32, &wgpu::Buffer)> {
        self.slots.iter().map(|(slot, b, _)| (slot.binding(), b))
    }

    /// Records the copies of the first `pixels` pixels of each output to the readback buffer.
    fn copy_to_readback(&self, encoder: &mut wgpu::CommandEncoder, pixels: u64) {
        for (slot, buffer, offset) in &self.slots {
            let size = pixels * slot.pixel_bytes(self.precision);
            encoder.copy_buffer_to_buffer(buffer, 0, &self.readback, *offset, size);
        }
    }

    /// The bytes of `slot` for `pixels` pixels in the mapped readback `view`.
    fn bytes<'v>(&self, view: &'v [u8], slot: Slot, pixels: usize) -> Option<&'v [u8]> {
        let (_, _, offset) = self.slots.iter().find(|(s, _, _)| *s == slot)?;
        let at = *offset as usize;
        Some(&view[at..at + pixels * slot.pixel_bytes(self.precision) as usize])
    }
}

/// Copies one tile's results out of the readback buffer into `images`: only the outputs
/// `variant` asks for; the others keep their miss values. A pixel is a hit where its id says
/// so, or, without ids, where its surface is not zero (every hit has a distance of at least
/// `min_t |dir| > 0` and a unit normal).
fn read_tile<R: GpuReal>(
    gpu: &Gpu,
    outputs: &OutputBuffers,
    variant: &Variant,
    pixels: usize,
    row: u32,
    images: &mut Images<R>,
    certainty: Option<&mut [bool]>,
) -> Result<()> {
    let readback = &outputs.readback;
    map_for_reading(gpu, readback)?;
    {
        let view = readback
            .get_mapped_range(..)
            .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?;
        let surface: Option<&[[R; 4]]> = outputs
            .bytes(&view, Slot::Surface, pixels)
            .map(bytemuck::cast_slice);
        let ids: Option<&[i32]> = outputs
            .bytes(&view, Slot::Id, pixels)
            .map(bytemuck::cast_slice);
        let start = images.index(row, 0);
        if let (Some(certainty), Some(flags)) =
            (certainty, outputs.bytes(&view, Slot::Certain, pixels))
        {
            let flags: &[u32] = bytemuck::cast_slice(flags);
            for (k, flag) in flags.iter().enumerate() {
                certainty[start + k] = *flag != 0;
            }
        }
        if let (Some(colors), Some(bytes)) =
            (&mut images.color, outputs.bytes(&view, Slot::Color, pixels))
        {
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
    }
    readback.unmap();
    Ok(())
}
