//! Runs the kernel on a device: uploads the primitives, dispatches tiles of image rows and reads
//! the id, distance and normal images back.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use super::Gpu;
use super::layout::{GpuFrame, GpuParams, GpuPlane, GpuSphere, GpuTriangle, f32x3};
use super::shader;
use crate::camera::Frame;
use crate::error::{Error, Result};
use crate::images::{Images, MISS};
use crate::scene::{Object, Scene};

/// Workgroup edge in pixels (`@workgroup_size(8, 8)` in shaders/main.wgsl).
const WORKGROUP: u32 = 8;
/// Bytes of output per pixel: `vec4<f32>` surface + `i32` id.
const SURFACE_BYTES: u64 = 16;
const ID_BYTES: u64 = 4;

/// The primitives of a scene in the GPU's layout, each tagged with its object id.
#[derive(Default)]
struct Primitives {
    spheres: Vec<GpuSphere>,
    planes: Vec<GpuPlane>,
    triangles: Vec<GpuTriangle>,
}

impl Primitives {
    fn new(scene: &Scene) -> Primitives {
        let mut p = Primitives::default();
        for id in 0..scene.objects.len() {
            let object = id as u32;
            let push_triangle = |p: &mut Primitives, t: &crate::scene::Triangle| {
                p.triangles.push(GpuTriangle {
                    a: f32x3(t[0]),
                    object,
                    b: f32x3(t[1]),
                    _pad0: 0,
                    c: f32x3(t[2]),
                    _pad1: 0,
                })
            };
            match &scene.objects[id] {
                Object::Sphere { center, radius } => p.spheres.push(GpuSphere {
                    center: f32x3(*center),
                    radius: *radius as f32,
                    object,
                    _pad: [0; 3],
                }),
                Object::Plane { point, normal } => p.planes.push(GpuPlane {
                    point: f32x3(*point),
                    object,
                    normal: f32x3(*normal),
                    _pad: 0,
                }),
                Object::Triangle { corners } => push_triangle(&mut p, corners),
                Object::Soup { triangles, .. } => {
                    triangles.iter().for_each(|t| push_triangle(&mut p, t))
                }
            }
        }
        p
    }
}

/// The most image rows one dispatch can cover at `width` pixels per row under `limits`
/// (output binding size and workgroups per dimension); 0 if not even one row fits.
pub fn max_tile_rows(limits: &wgpu::Limits, width: u32) -> u32 {
    let binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
    let by_memory = binding / (width as u64 * SURFACE_BYTES);
    let by_dispatch = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    by_memory.min(by_dispatch).min(u32::MAX as u64) as u32
}

fn check_limits(gpu: &Gpu, scene: &Scene, prims: &Primitives) -> Result<u32> {
    let limits = gpu.device.limits();
    let [nx, ny] = scene.camera.resolution;
    let max_width = limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
    let rows = max_tile_rows(&limits, nx);
    if nx as u64 > max_width || rows == 0 {
        return Err(Error::Argument {
            option: "resolution".into(),
            message: format!(
                "{nx}x{ny} is wider than this device can dispatch (at most {} pixels per row)",
                max_width.min(limits.max_storage_buffer_binding_size / SURFACE_BYTES)
            ),
        });
    }
    let binding = limits.max_storage_buffer_binding_size;
    let bytes = (prims.triangles.len() * size_of::<GpuTriangle>()) as u64;
    if bytes > binding {
        return Err(Error::Device(format!(
            "{} triangles need {bytes} bytes, more than this device's largest storage binding ({binding} bytes)",
            prims.triangles.len()
        )));
    }
    Ok(rows.min(ny))
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

fn create_pipeline(gpu: &Gpu) -> Result<wgpu::ComputePipeline> {
    let source = shader::kernel_source()?;
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

/// Renders `scene` at `scene.camera.resolution` on `gpu`, in f32.
pub fn render(gpu: &Gpu, scene: &Scene) -> Result<Images<f32>> {
    let prims = Primitives::new(scene);
    let tile_rows = check_limits(gpu, scene, &prims)?;
    let [nx, ny] = scene.camera.resolution;
    let frame = Frame::new(&scene.camera, [nx, ny]);
    let pipeline = create_pipeline(gpu)?;
    let device = &gpu.device;

    let spheres = storage_buffer(gpu, "spheres", &prims.spheres);
    let planes = storage_buffer(gpu, "planes", &prims.planes);
    let triangles = storage_buffer(gpu, "triangles", &prims.triangles);
    let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: size_of::<GpuParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let tile_pixels = tile_rows as u64 * nx as u64;
    let surface_size = tile_pixels * SURFACE_BYTES;
    let id_size = tile_pixels * ID_BYTES;
    let output = |label, size| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    };
    let surface = output("out_surface", surface_size);
    let ids = output("out_id", id_size);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: surface_size + id_size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("raycast"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            (0, &params_buffer),
            (1, &spheres),
            (2, &planes),
            (3, &triangles),
            (4, &surface),
            (5, &ids),
        ]
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        }),
    });

    let mut images = Images::new_miss(nx, ny, scene.camera.focal_length);
    let mut row = 0;
    while row < ny {
        let rows = tile_rows.min(ny - row);
        let params = GpuParams {
            frame: GpuFrame::new(&frame),
            row_offset: row,
            tile_rows: rows,
            sphere_count: prims.spheres.len() as u32,
            plane_count: prims.planes.len() as u32,
            triangle_count: prims.triangles.len() as u32,
            _pad: [0; 3],
        };
        gpu.queue
            .write_buffer(&params_buffer, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(nx.div_ceil(WORKGROUP), rows.div_ceil(WORKGROUP), 1);
        }
        let pixels = rows as u64 * nx as u64;
        encoder.copy_buffer_to_buffer(&surface, 0, &readback, 0, pixels * SURFACE_BYTES);
        encoder.copy_buffer_to_buffer(&ids, 0, &readback, surface_size, pixels * ID_BYTES);
        gpu.queue.submit([encoder.finish()]);
        read_tile(
            gpu,
            &readback,
            surface_size,
            pixels as usize,
            row,
            &mut images,
        )?;
        row += rows;
    }
    Ok(images)
}

/// Copies one tile's results out of the mapped readback buffer into `images`.
fn read_tile(
    gpu: &Gpu,
    readback: &wgpu::Buffer,
    id_offset: u64,
    pixels: usize,
    row: u32,
    images: &mut Images<f32>,
) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    readback.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Device(format!("GPU did not finish: {e}")))?;
    rx.recv()
        .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?
        .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?;
    {
        let view = readback
            .get_mapped_range(..)
            .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?;
        let surface: &[[f32; 4]] = bytemuck::cast_slice(&view[..pixels * SURFACE_BYTES as usize]);
        let id_start = id_offset as usize;
        let ids: &[i32] =
            bytemuck::cast_slice(&view[id_start..id_start + pixels * ID_BYTES as usize]);
        let start = images.index(row, 0);
        for k in 0..pixels {
            let id = ids[k];
            let px = start + k;
            images.id[px] = id;
            if id != MISS {
                let s = surface[k];
                images.normal[px] = [s[0], s[1], s[2]];
                images.distance[px] = s[3];
            }
        }
    }
    readback.unmap();
    Ok(())
}
