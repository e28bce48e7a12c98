//! The GPU side: getting a device ([`Gpu::new`]) is separate from running on one ([`run`]), so
//! tests and library users can bring their own `wgpu::Device`.
//!
//! - [`shader`] assembles the kernel's WGSL for a [`shader::Variant`] from `shaders/`;
//! - `source` keeps the user's sources, validates WGSL with located errors and reflects a
//!   kernel's bindings; [`hooks`] and [`kernel`] check shade hooks and kernel files;
//! - [`layout`](crate::kernel::layout) is the byte layout of the kernel's structs;
//! - [`dispatch`] runs a [`Job`] on a prepared scene: the one way every render reaches the GPU.

pub(crate) mod dispatch;
pub(crate) mod hooks;
pub(crate) mod kernel;
pub(crate) mod readback;
pub(crate) mod shader;
pub(crate) mod source;

pub(crate) use dispatch::{Job, Rendered, Resident, prepare, run, upload};

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use crate::error::{Error, Result};
use shader::Variant;

/// The package that provides a software Vulkan driver on Debian and Ubuntu.
pub(crate) const DRIVER_HINT: &str = "install a Vulkan driver: on Debian/Ubuntu `apt-get install mesa-vulkan-drivers libvulkan1` \
     (Mesa's lavapipe runs on any CPU)";

/// Features used when the adapter offers them (never required).
pub(crate) const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::SHADER_F64
    .union(wgpu::Features::SUBGROUP)
    .union(wgpu::Features::TIMESTAMP_QUERY)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::SHADER_INT64);

/// Invocations that share one node fetch in the packet traversal.
pub(crate) const PACKET_LANES: u32 = 8;

/// Rays a sphere or triangle from which a cast on a CPU adapter goes in packets by default
/// ([`GpuInfo::packet_rays_per_primitive`]): where fewer rays meet the primitives they see, a
/// packet visits the union of its rays' paths, which costs more than the fetches it shares.
/// The crossover measured on lavapipe (docs/performance.md#packets-or-per-ray) on the tori of
/// 518,400 and 4,999,696 triangles, which fill the same share of the image.
pub(crate) const PACKET_RAYS_PER_PRIMITIVE: f64 = 0.15;

/// An adapter with an open device and queue, and the kernels compiled on it so far.
pub struct Gpu {
    /// The adapter the device was opened on.
    pub adapter: wgpu::Adapter,
    /// The open device, for a caller's own buffers and pipelines too.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    pipelines: Mutex<HashMap<Variant, dispatch::Compiled>>,
    /// Why the device was lost, once it has been (set by wgpu's device-lost callback).
    lost: Arc<Mutex<Option<String>>>,
    /// This device's identity: buffers uploaded for it ([`dispatch::Resident`]) hold a clone,
    /// so no other device can be taken for it.
    identity: Arc<()>,
    /// The last job's list, output and readback buffers, for the next job of the same sizes
    /// ([`Gpu::transient_buffer`]).
    spare: Mutex<Vec<wgpu::Buffer>>,
}

impl Gpu {
    /// The kernel variant for `scene`: only its primitive kinds compiled in, a BVH where it
    /// pays (`crate::prepare::bvh::worth_it`), packets where they pay for its camera's pixels
    /// ([`Gpu::packets_pay`]).
    pub(crate) fn scene_variant(
        &self,
        scene: &crate::scene::Scene,
        precision: crate::math::Float,
        algorithm: crate::Algorithm,
    ) -> Variant {
        let general = self.variant(precision, algorithm);
        Variant {
            // Camera-relative (robust) perspective rays all start at the eye; the dispatch
            // leaves it off for a caller's rays.
            rays_from_origin: algorithm == crate::Algorithm::Robust
                && scene.camera.projection == crate::scene::Projection::Perspective,
            bvh: crate::prepare::bvh::worth_it(scene),
            packets: general.packets
                && self.packets_pay(
                    scene.camera.pixel_count(),
                    crate::prepare::bvh::bounded_count(scene),
                ),
            chunks: shader::chunks_for(scene, general.chunk_bits),
            ..general.with_kinds(shader::Kinds::of_scene(scene))
        }
    }

    /// The general kernel variant (every primitive kind) for `precision` and `algorithm`.
    pub(crate) fn variant(
        &self,
        precision: crate::math::Float,
        algorithm: crate::Algorithm,
    ) -> Variant {
        let packets = self.has_packet_subgroups();
        Variant {
            precision,
            algorithm,
            f64_available: self.has_f64(),
            int64_available: self.has_int64(),
            certainty: false,
            casts: shader::Casts::Camera,
            count: false,
            closest: false,
            occluded: false,
            rays_from_origin: false,
            list_origin: false,
            kinds: shader::Kinds::ALL,
            bvh: false,
            instances: false,
            packets,
            eight_lanes: packets && self.adapter.get_info().subgroup_max_size == PACKET_LANES,
            lane_rays_limit: shader::MAX_LANE_RAYS,
            chunks: 1,
            chunk_bits: shader::chunk_bits_for(self.max_binding(), precision),
            bvh_stack: crate::prepare::bvh::MAX_DEPTH as u8,
            planes: 0,
            outputs: crate::images::Outputs::GEOMETRY,
            shade: None,
            hook_rays: false,
            kernel: None,
            as_given: false,
        }
    }

    /// [`GpuInfo::f64`].
    pub(crate) fn has_f64(&self) -> bool {
        self.device.features().contains(wgpu::Features::SHADER_F64)
    }

    /// Whether kernels may use 64-bit integers here (`SHADER_INT64`): a kernel that loads
    /// nodes and triangles ray by ray loads them as 64-bit words ([`Variant::wide_loads`]).
    pub(crate) fn has_int64(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::SHADER_INT64)
    }

    /// [`GpuInfo::packet_subgroups`].
    pub(crate) fn has_packet_subgroups(&self) -> bool {
        self.device.features().contains(wgpu::Features::SUBGROUP)
            && self.adapter.get_info().subgroup_min_size >= PACKET_LANES
    }

    /// Whether the kernel's list and output buffers are mapped by the host directly rather
    /// than copied through staging buffers: on a CPU adapter (lavapipe), whose device memory is
    /// the host's, where copying a list in and its hits out costs a large share of tracing
    /// them. (On a discrete GPU it would make the kernel read host memory.)
    pub(crate) fn host_memory(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS)
    }

    /// The largest storage binding this device allows, in bytes.
    pub(crate) fn max_binding(&self) -> u64 {
        let limits = self.device.limits();
        limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
    }

    /// Opens the best adapter, honouring `WGPU_BACKEND` (e.g. `vulkan`, `gl`) and
    /// `WGPU_ADAPTER_NAME` (a case-insensitive substring of the adapter name, e.g. `llvmpipe`).
    /// Without `WGPU_BACKEND` only the primary backends (Vulkan, Metal, DX12) are tried.
    /// `RAYCAST_MAX_BINDING` (bytes) caps the size of one storage binding below the adapter's
    /// own limit: less device memory per buffer, on a shared GPU for instance.
    ///
    /// ```no_run
    /// let gpu = raycast::Gpu::new()?;
    /// println!("{} (f64 shaders: {})", gpu.info().adapter.name, gpu.info().f64);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn new() -> Result<Gpu> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<Gpu> {
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let adapters = instance.enumerate_adapters(backends).await;
        let adapter = choose_adapter(adapters, std::env::var("WGPU_ADAPTER_NAME").ok())?;
        // The adapter's own limits: lavapipe allows larger storage bindings than the WebGPU
        // defaults.
        let mut limits = adapter.limits();
        if let Some(cap) = max_binding_from_env()? {
            limits.max_storage_buffer_binding_size =
                limits.max_storage_buffer_binding_size.min(cap);
        }
        let mut features = adapter.features() & OPTIONAL_FEATURES;
        if adapter.get_info().device_type == wgpu::DeviceType::Cpu {
            features |= adapter.features() & wgpu::Features::MAPPABLE_PRIMARY_BUFFERS;
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("raycast"),
                required_features: features,
                required_limits: limits,
                ..Default::default()
            })
            .await
            .map_err(|e| Error::Device(format!("cannot open the GPU device: {e}")))?;
        Ok(Gpu::from_parts(adapter, device, queue))
    }

    /// Wraps a device the caller opened itself.
    pub fn from_parts(adapter: wgpu::Adapter, device: wgpu::Device, queue: wgpu::Queue) -> Gpu {
        let lost = Arc::new(Mutex::new(None));
        let record = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            // One line: a driver's message may have several.
            let first = message.lines().next().unwrap_or_default();
            let why = match first.is_empty() {
                true => format!("{reason:?}"),
                false => format!("{reason:?}: {first}"),
            };
            *record.lock().unwrap_or_else(PoisonError::into_inner) = Some(why);
        });
        Gpu {
            adapter,
            device,
            queue,
            pipelines: Mutex::default(),
            lost,
            identity: Arc::new(()),
            spare: Mutex::default(),
        }
    }

    /// A buffer as `desc` describes (never mapped at creation), one the last job left if one
    /// is of its size and usage: on lavapipe the first touches of a fresh buffer's memory slow
    /// repeated casts (docs/performance.md#ray-lists). Its contents are whatever that job left.
    pub(crate) fn transient_buffer(&self, desc: &wgpu::BufferDescriptor<'_>) -> wgpu::Buffer {
        let mut spare = self.spare.lock().unwrap_or_else(PoisonError::into_inner);
        let fits = |b: &wgpu::Buffer| b.size() == desc.size && b.usage() == desc.usage;
        match spare.iter().position(fits) {
            Some(k) => spare.swap_remove(k),
            None => {
                drop(spare);
                self.device.create_buffer(desc)
            }
        }
    }

    /// Keeps a finished job's transient buffers for the next (those of the job before are
    /// freed).
    pub(crate) fn keep_transient(&self, buffers: Vec<wgpu::Buffer>) {
        *self.spare.lock().unwrap_or_else(PoisonError::into_inner) = buffers;
    }

    /// This device's identity ([`dispatch::Resident`]).
    pub(crate) fn identity(&self) -> &Arc<()> {
        &self.identity
    }

    /// An error if the device has been lost (a driver reset, a destroyed device): wgpu panics
    /// on some calls to a lost device, so every render checks first.
    pub(crate) fn check_alive(&self) -> Result<()> {
        // Polling runs the callbacks due, the device-lost one among them.
        if let Err(e) = self.device.poll(wgpu::PollType::Poll) {
            return Err(Error::Device(format!("the GPU device failed: {e}")));
        }
        match &*self.lost.lock().unwrap_or_else(PoisonError::into_inner) {
            Some(why) => Err(Error::Device(format!("the GPU device was lost ({why})"))),
            None => Ok(()),
        }
    }

    /// What this GPU is, and what the kernels can use of it.
    pub fn info(&self) -> GpuInfo {
        GpuInfo {
            adapter: self.adapter.get_info(),
            f64: self.has_f64(),
            packet_subgroups: self.has_packet_subgroups(),
            packet_rays_per_primitive: self.packet_rays_per_primitive(),
        }
    }

    /// [`GpuInfo::packet_rays_per_primitive`]: on a CPU adapter, whose per-lane loads are
    /// loops over the lanes, packets sharing fetches pay once rays are many for the primitives
    /// they see; a hardware GPU traces ray by ray, which the cost model predicts faster on
    /// every workload it replays (docs/gpu.md#a-cost-model) until a GPU's measurements say
    /// where packets pay there.
    fn packet_rays_per_primitive(&self) -> Option<f64> {
        let cpu = self.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        (cpu && self.has_packet_subgroups()).then_some(PACKET_RAYS_PER_PRIMITIVE)
    }

    /// Whether a cast of `rays` rays through a BVH over `primitives` spheres and triangles
    /// goes in packets by default here (the tuning's `packets` overrides it).
    pub(crate) fn packets_pay(&self, rays: u64, primitives: usize) -> bool {
        self.packet_rays_per_primitive()
            .is_some_and(|r| rays as f64 >= r * primitives as f64)
    }
}

/// What a GPU is ([`Gpu::info`]), and what the kernels can use of it.
#[derive(Clone, Debug)]
pub struct GpuInfo {
    /// The adapter's name, backend, driver, device type and subgroup sizes.
    pub adapter: wgpu::AdapterInfo,
    /// Whether kernels in f64 run here (`SHADER_F64`): f64 and adaptive precision's re-casts
    /// on the GPU, and the f64 rechecks of robust f32.
    pub f64: bool,
    /// Whether the BVH can be traversed by packets here ([`crate::Tuning::packets`]):
    /// subgroups of at least the 8 invocations a packet shares each node fetch among.
    pub packet_subgroups: bool,
    /// Rays a sphere or triangle from which a cast goes in packets by default (a render's
    /// pixels, a list's rays, over the scene's spheres and triangles); `None`: each ray walks
    /// the BVH alone unless packets are asked for, as on hardware GPUs.
    pub packet_rays_per_primitive: Option<f64>,
}

/// `RAYCAST_MAX_BINDING`, bytes of one storage binding at most (at least 1 MiB), if set.
fn max_binding_from_env() -> Result<Option<u64>> {
    let Ok(text) = std::env::var("RAYCAST_MAX_BINDING") else {
        return Ok(None);
    };
    match text.trim().parse::<u64>() {
        Ok(bytes) if bytes >= 1 << 20 => Ok(Some(bytes)),
        _ => Err(Error::Device(format!(
            "RAYCAST_MAX_BINDING must be a number of bytes of at least 1048576, got `{}`",
            text.escape_debug()
        ))),
    }
}

fn choose_adapter(adapters: Vec<wgpu::Adapter>, wanted: Option<String>) -> Result<wgpu::Adapter> {
    if adapters.is_empty() {
        return Err(Error::Device(format!(
            "no GPU adapter found; {DRIVER_HINT}"
        )));
    }
    if let Some(wanted) = wanted {
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        let lower = wanted.to_lowercase();
        return adapters
            .into_iter()
            .find(|a| a.get_info().name.to_lowercase().contains(&lower))
            .ok_or_else(|| {
                Error::Device(format!(
                    "WGPU_ADAPTER_NAME={wanted:?} matches no adapter (found: {})",
                    names.join(", ")
                ))
            });
    }
    // Prefer real GPUs; a software adapter (lavapipe) is the fallback.
    let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    Ok(adapters.into_iter().min_by_key(rank).expect("non-empty"))
}
