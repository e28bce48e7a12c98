//! Reading a dispatch's outputs back: the buffers the kernel writes ([`OutputBuffers`]), the
//! host's wait for them ([`map_buffers`]), and their conversion into the layout they are
//! delivered in ([`append_pixels`] for images, [`append_hits`] for a ray list), each a single
//! parallel pass that writes every delivered value once. Also the per-part counters read with
//! them: the kernel's timestamps ([`PartTimer`]) and a shade hook's rays ([`HookRayCounter`]).

use wgpu::util::DeviceExt;

use super::Gpu;
use super::shader::{Casts, Variant};
use crate::error::{Error, Result};
use crate::images::{Images, MISS, Outputs, Stages};
use crate::kernel::layout::GpuReal;
use crate::math::Float;
use crate::rays::{Hits, INVALID_ID};

/// Bytes of output per pixel and unit of precision: `vec4<real>` surface.
const SURFACE_REALS: u64 = 4;
/// Bytes of output per pixel: `i32` id.
const ID_BYTES: u64 = 4;

/// Bytes of the surface output (normal and distance) of one pixel in `precision`.
pub(super) fn surface_bytes(precision: Float) -> u64 {
    SURFACE_REALS
        * match precision {
            Float::F32 => 4,
            Float::F64 => 8,
        }
}

/// A per-pixel output buffer of the kernel (shaders/bindings.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Output {
    /// `out_surface`: normal and distance, `vec4<real>`.
    Surface,
    /// `out_distance`: the distance alone, `real`.
    Distance,
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
    /// `out_occluded`: `u32` flags (OCCLUDED).
    Occluded,
}

impl Output {
    /// The kernel's name for the buffer (shaders/bindings.wgsl).
    fn name(self) -> &'static str {
        match self {
            Output::Surface => "out_surface",
            Output::Distance => "out_distance",
            Output::Id => "out_id",
            Output::Certain => "out_certain",
            Output::Color => "out_color",
            Output::Primitive => "out_primitive",
            Output::Uv => "out_uv",
            Output::Count => "out_count",
            Output::Occluded => "out_occluded",
        }
    }

    fn pixel_bytes(self, precision: Float) -> u64 {
        match self {
            Output::Surface => surface_bytes(precision),
            Output::Uv => surface_bytes(precision) / 2,
            Output::Distance => surface_bytes(precision) / 4,
            Output::Id
            | Output::Certain
            | Output::Color
            | Output::Primitive
            | Output::Count
            | Output::Occluded => ID_BYTES,
        }
    }
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

/// The output buffers a variant writes, each for `capacity` pixels, and, unless the host maps
/// them directly ([`Gpu::host_memory`]), one readback buffer holding them one after another (at
/// `capacity` pixels each).
pub(super) struct OutputBuffers {
    /// Output, buffer, and its offset in the readback buffer.
    outputs: Vec<(Output, wgpu::Buffer, u64)>,
    readback: Option<wgpu::Buffer>,
    precision: Float,
}

impl OutputBuffers {
    /// The buffers of the outputs `variant` writes: the surface when it asks for the normal,
    /// the distance alone when it asks for the distance without it, the ids when it asks for them, the certainty flags in a certainty variant, the
    /// colours with a shade hook, a ray list's primitives and barycentrics or counts.
    pub(super) fn new(gpu: &Gpu, variant: &Variant, capacity: u64) -> OutputBuffers {
        let o = variant.outputs;
        let hit_detail = variant.casts == Casts::Rays && !variant.count && !variant.occluded;
        // Reals first, so that each output starts aligned to its element in the readback
        // buffer whatever the capacity.
        let wanted = [
            (o.normal, Output::Surface),
            (hit_detail, Output::Uv),
            (o.distance && !o.normal, Output::Distance),
            (o.id, Output::Id),
            (variant.certainty, Output::Certain),
            (o.color, Output::Color),
            (hit_detail, Output::Primitive),
            (variant.count, Output::Count),
            (variant.occluded, Output::Occluded),
        ];
        let direct = gpu.host_memory();
        let mut outputs = Vec::new();
        let mut offset = 0;
        for (present, output) in wanted {
            if present {
                let size = capacity * output.pixel_bytes(variant.precision);
                outputs.push((
                    output,
                    output_buffer(gpu, output.name(), size, direct),
                    offset,
                ));
                offset += size;
            }
        }
        OutputBuffers {
            outputs,
            // A mapped buffer may not be empty.
            readback: (!direct).then(|| readback_buffer(gpu, offset.max(4))),
            precision: variant.precision,
        }
    }

    /// Every buffer, for the next job ([`Gpu::keep_transient`]).
    pub(super) fn into_buffers(self) -> impl Iterator<Item = wgpu::Buffer> {
        let outputs = self.outputs.into_iter().map(|(_, b, _)| b);
        outputs.chain(self.readback)
    }

    /// The buffers by the kernel's names.
    pub(super) fn named(&self) -> impl Iterator<Item = (String, &wgpu::Buffer)> {
        self.outputs
            .iter()
            .map(|(output, b, _)| (output.name().to_owned(), b))
    }

    /// Whether the outputs are copied to a readback buffer (not mapped themselves).
    pub(super) fn copied(&self) -> bool {
        self.readback.is_some()
    }

    /// Bytes of the first `pixels` pixels of every output.
    pub(super) fn bytes(&self, pixels: u64) -> u64 {
        let per_pixel: u64 = (self.outputs.iter())
            .map(|(output, _, _)| output.pixel_bytes(self.precision))
            .sum();
        pixels * per_pixel
    }

    /// Records the copies of the first `pixels` pixels of each output to the readback buffer
    /// (none where the host maps the outputs).
    pub(super) fn copy_to_readback(&self, encoder: &mut wgpu::CommandEncoder, pixels: u64) {
        if let Some(readback) = &self.readback {
            for (output, buffer, offset) in &self.outputs {
                let size = pixels * output.pixel_bytes(self.precision);
                encoder.copy_buffer_to_buffer(buffer, 0, readback, *offset, size);
            }
        }
    }

    /// Runs `f` on the first `pixels` pixels of each output, mapped once submission `done`
    /// has finished; adds the time waited for it and the time of `f` to `stages`.
    pub(super) fn read(
        &self,
        gpu: &Gpu,
        done: &wgpu::SubmissionIndex,
        stages: &mut Stages,
        pixels: u64,
        f: impl FnOnce(&Mapped),
    ) -> Result<()> {
        let size = |output: Output| pixels * output.pixel_bytes(self.precision);
        // What is mapped: the readback buffer whole (its outputs need not start at the mapping
        // alignment), or each output's first `pixels` pixels.
        let parts: Vec<wgpu::BufferSlice<'_>> = match &self.readback {
            Some(readback) => vec![readback.slice(..)],
            None => self
                .outputs
                .iter()
                .map(|(output, buffer, _)| buffer.slice(..size(*output).max(4)))
                .collect(),
        };
        let waiting = std::time::Instant::now();
        map_buffers(gpu, &parts, wgpu::MapMode::Read, Some(done))?;
        stages.wait_s += waiting.elapsed().as_secs_f64();
        let converting = std::time::Instant::now();
        {
            let views = parts
                .iter()
                .map(|part| part.get_mapped_range())
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(|e| Error::Device(format!("GPU readback failed: {e}")))?;
            // Each output's bytes: in which view, where.
            let at = self
                .outputs
                .iter()
                .enumerate()
                .map(|(k, (output, _, offset))| match &self.readback {
                    Some(_) => (
                        *output,
                        0,
                        *offset as usize..(offset + size(*output)) as usize,
                    ),
                    None => (*output, k, 0..size(*output) as usize),
                })
                .collect();
            f(&Mapped { views, at });
        }
        parts.iter().for_each(|part| part.buffer().unmap());
        stages.convert_s += converting.elapsed().as_secs_f64();
        stages.readback_bytes += self.bytes(pixels);
        Ok(())
    }
}

/// The outputs of one dispatch as the host reads them ([`OutputBuffers::read`]).
pub(super) struct Mapped {
    views: Vec<wgpu::BufferView>,
    /// Per output the variant writes: the view holding it and its bytes there.
    at: Vec<(Output, usize, std::ops::Range<usize>)>,
}

impl Mapped {
    /// The bytes of `output`, if the variant writes it.
    fn bytes(&self, output: Output) -> Option<&[u8]> {
        let (_, view, range) = self.at.iter().find(|(s, _, _)| *s == output)?;
        Some(&self.views[*view][range.clone()])
    }

    /// Copies the certainty flags into `certainty` from `start`, where the variant writes them.
    pub(super) fn copy_certainty(&self, start: usize, certainty: Option<&mut [bool]>) {
        if let (Some(certainty), Some(flags)) = (certainty, self.bytes(Output::Certain)) {
            let flags: &[u32] = bytemuck::cast_slice(flags);
            for (k, flag) in flags.iter().enumerate() {
                certainty[start + k] = *flag != 0;
            }
        }
    }
}

/// Images of `width * height` pixels with room for their outputs and none filled in:
/// [`append_pixels`] fills them, part after part, in row-major order.
pub(super) fn empty_images<R: GpuReal>(
    [width, height]: [u32; 2],
    focal_length: f64,
    color: bool,
) -> Images<R> {
    let n = width as usize * height as usize;
    let mut images = Images::new_miss(0, 0, focal_length);
    images.width = width;
    images.height = height;
    images.id = Vec::with_capacity(n);
    images.distance = Vec::with_capacity(n);
    images.normal = Vec::with_capacity(n);
    images.color = color.then(|| Vec::with_capacity(n));
    crate::rays::huge_pages(&images.id);
    crate::rays::huge_pages(&images.distance);
    crate::rays::huge_pages(&images.normal);
    images
}

/// Appends one dispatch's `pixels` pixels to `images` (row-major, after those appended before)
/// in one parallel pass per output: only the outputs `o` asks for come from the kernel, the
/// others are their miss values. A pixel is a hit where its id says so, or, without ids, where
/// its surface is not zero (every hit has a distance of at least `min_t |dir| > 0` and a unit
/// normal); the kernel writes a pixel's surface only where it is a hit.
pub(super) fn append_pixels<R: GpuReal>(
    images: &mut Images<R>,
    view: &Mapped,
    o: Outputs,
    pixels: usize,
) {
    use rayon::prelude::*;
    let geometry = Geometry {
        ids: view.bytes(Output::Id).map(bytemuck::cast_slice),
        surface: view.bytes(Output::Surface).map(bytemuck::cast_slice),
        alone: view.bytes(Output::Distance).map(bytemuck::cast_slice),
    };
    match (geometry.ids, geometry.surface) {
        (Some(ids), Some(s)) if o.normal && o.distance => {
            append_surfaces(images, &ids[..pixels], &s[..pixels])
        }
        _ => append_each(images, o, pixels, geometry),
    }
    if let Some(colors) = &mut images.color {
        match view.bytes(Output::Color) {
            // pack4x8unorm puts red in the lowest byte.
            Some(bytes) => colors.par_extend(
                bytemuck::cast_slice::<u8, u32>(bytes)
                    .par_iter()
                    .map(|c| c.to_le_bytes()),
            ),
            None => colors.resize(colors.len() + pixels, [0; 4]),
        }
    }
}

/// Appends one dispatch's occlusion flags for a ray list to `occluded`.
pub(super) fn append_occluded(occluded: &mut Vec<bool>, view: &Mapped) {
    use rayon::prelude::*;
    if let Some(flags) = view.bytes(Output::Occluded) {
        let flags: &[u32] = bytemuck::cast_slice(flags);
        occluded.par_extend(flags.par_iter().map(|&f| f != 0));
    }
}

/// The geometric outputs of a part, those the variant writes: ids, surfaces (normal and
/// distance), distances alone.
#[derive(Clone, Copy)]
struct Geometry<'a, R> {
    ids: Option<&'a [i32]>,
    surface: Option<&'a [[R; 4]]>,
    alone: Option<&'a [R]>,
}

/// [`append_pixels`] of the ids, normals and distances, a parallel pass each.
fn append_each<R: GpuReal>(images: &mut Images<R>, o: Outputs, pixels: usize, g: Geometry<'_, R>) {
    use rayon::prelude::*;
    let Geometry {
        ids,
        surface,
        alone,
    } = g;
    let hit = |k: usize| match (ids, surface, alone) {
        (Some(ids), _, _) => ids[k] != MISS,
        (None, Some(s), _) => s[k] != [R::ZERO; 4],
        (None, None, Some(d)) => d[k] != R::ZERO,
        (None, None, None) => false,
    };
    match ids {
        Some(ids) => images.id.par_extend(ids[..pixels].par_iter().copied()),
        None => images.id.resize(images.id.len() + pixels, MISS),
    }
    match surface.filter(|_| o.normal) {
        Some(s) => images
            .normal
            .par_extend((0..pixels).into_par_iter().map(|k| match hit(k) {
                true => [s[k][0], s[k][1], s[k][2]],
                false => [R::ZERO; 3],
            })),
        None => (images.normal).resize(images.normal.len() + pixels, [R::ZERO; 3]),
    }
    let distance = |k: usize| match (surface, alone) {
        (Some(s), _) => s[k][3],
        (None, Some(d)) => d[k],
        (None, None) => R::INFINITY,
    };
    match o.distance && (surface.is_some() || alone.is_some()) {
        true => (images.distance).par_extend((0..pixels).into_par_iter().map(|k| match hit(k) {
            true => distance(k),
            false => R::INFINITY,
        })),
        false => (images.distance).resize(images.distance.len() + pixels, R::INFINITY),
    }
}

/// [`append_pixels`] of the ids, normals and distances together, in one parallel pass over
/// the kernel's outputs (a pass per output reads the ids again), into the vectors' spare room.
fn append_surfaces<R: GpuReal>(images: &mut Images<R>, ids: &[i32], surface: &[[R; 4]]) {
    use rayon::prelude::*;
    const RUN: usize = 1 << 14;
    let n = ids.len();
    images.id.reserve(n);
    images.normal.reserve(n);
    images.distance.reserve(n);
    let runs = (
        images.id.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        images.normal.spare_capacity_mut()[..n].par_chunks_mut(RUN),
        images.distance.spare_capacity_mut()[..n].par_chunks_mut(RUN),
    );
    runs.into_par_iter()
        .enumerate()
        .for_each(|(r, (id, normal, distance))| {
            for j in 0..id.len() {
                let k = r * RUN + j;
                let hit = ids[k] != MISS;
                let [x, y, z, w] = surface[k];
                id[j].write(ids[k]);
                normal[j].write(if hit { [x, y, z] } else { [R::ZERO; 3] });
                distance[j].write(if hit { w } else { R::INFINITY });
            }
        });
    // SAFETY: the pass above wrote the first `n` spare elements of each vector (the runs of
    // each cover `..n` alike), and `reserve` made room for them.
    unsafe {
        images.id.set_len(images.id.len() + n);
        images.normal.set_len(images.normal.len() + n);
        images.distance.set_len(images.distance.len() + n);
    }
}

/// Appends one dispatch's results for a ray list (after those read before) to `hits`: t, id,
/// normal, primitive and barycentrics in one parallel pass ([`append_hit_values`]), or counts.
pub(super) fn append_hits<R: GpuReal>(hits: &mut Hits<R>, view: &Mapped) {
    use rayon::prelude::*;
    let bytes = |output| view.bytes(output);
    if let Some(counts) = bytes(Output::Count) {
        let counts: &[u32] = bytemuck::cast_slice(counts);
        hits.count.par_extend(counts.par_iter().copied());
    }
    if let (Some(ids), Some(surface), Some(primitives), Some(uvs)) = (
        bytes(Output::Id),
        bytes(Output::Surface),
        bytes(Output::Primitive),
        bytes(Output::Uv),
    ) {
        let ids: &[i32] = bytemuck::cast_slice(ids);
        let surface: &[[R; 4]] = bytemuck::cast_slice(surface);
        let primitives: &[u32] = bytemuck::cast_slice(primitives);
        let uvs: &[[R; 2]] = bytemuck::cast_slice(uvs);
        append_hit_values(hits, ids, surface, primitives, uvs);
    }
}

/// Appends the hits of one dispatch to `hits` in one parallel pass over the kernel's outputs
/// (a pass per result reads each hit's memory again). The kernel writes a miss's id only: the
/// rest is the miss's values here.
fn append_hit_values<R: GpuReal>(
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

/// Maps `parts` in `mode` once the GPU has finished submission `done`, the last that uses
/// them (without one: once no submitted work uses them, which a buffer idle since its last
/// read needs no wait for).
pub(super) fn map_buffers(
    gpu: &Gpu,
    parts: &[wgpu::BufferSlice<'_>],
    mode: wgpu::MapMode,
    done: Option<&wgpu::SubmissionIndex>,
) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    for part in parts {
        let tx = tx.clone();
        part.map_async(mode, move |r| {
            let _ = tx.send(r);
        });
    }
    let poll = |how| {
        (gpu.device.poll(how))
            .map(|_| ())
            .map_err(|e| Error::Device(format!("GPU did not finish: {e}")))
    };
    poll(match done {
        Some(done) => wgpu::PollType::Wait {
            submission_index: Some(done.clone()),
            timeout: None,
        },
        None => wgpu::PollType::Poll,
    })?;
    let failed =
        |e: &dyn std::fmt::Display| Error::Device(format!("GPU buffer mapping failed: {e}"));
    for _ in parts {
        let mapped = match rx.try_recv() {
            Ok(mapped) => mapped,
            // Not mapped yet: in use by work submitted since.
            Err(_) => {
                poll(wgpu::PollType::wait_indefinitely())?;
                rx.recv().map_err(|e| failed(&e))?
            }
        };
        mapped.map_err(|e| failed(&e))?;
    }
    Ok(())
}

/// GPU time of one part's compute pass, and of the copy of its outputs after it, from
/// timestamp queries: written at the beginning and the end of the pass and, where the device
/// has timestamps inside encoders, after the copy; resolved and copied to a mappable buffer.
pub(super) struct PartTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Whether the copy is timed (timestamps inside encoders).
    copy: bool,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

impl PartTimer {
    const QUERIES: u32 = 3;
    const BYTES: u64 = Self::QUERIES as u64 * wgpu::QUERY_SIZE as u64;

    /// A timer, or `None` when the device has no `TIMESTAMP_QUERY`.
    pub(super) fn new(gpu: &Gpu) -> Option<PartTimer> {
        let features = gpu.device.features();
        if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
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
            count: Self::QUERIES,
        });
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: Self::BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PartTimer {
            query_set,
            resolve: buffer(
                "timestamp resolve",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "timestamp readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            copy: features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS),
            period_ns,
        })
    }

    /// The pass's timestamp writes: index 0 at its beginning, 1 at its end.
    pub(super) fn pass_writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records the timestamp after the copies of `outputs` (where they are copied and the
    /// device can), the resolve and the copy to the readback buffer.
    pub(super) fn resolve(&self, encoder: &mut wgpu::CommandEncoder, outputs: &OutputBuffers) {
        let copy = self.copy && outputs.copied();
        if copy {
            encoder.write_timestamp(&self.query_set, 2);
        }
        let queries = if copy { 3 } else { 2 };
        encoder.resolve_query_set(&self.query_set, 0..queries, &self.resolve, 0);
        let bytes = queries as u64 * wgpu::QUERY_SIZE as u64;
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, bytes);
    }

    /// Seconds of the pass, and of the copy after it where it was timed, of submission `done`.
    pub(super) fn read_seconds(
        &self,
        gpu: &Gpu,
        done: &wgpu::SubmissionIndex,
        outputs: &OutputBuffers,
    ) -> Result<(f64, Option<f64>)> {
        map_buffers(
            gpu,
            &[self.readback.slice(..)],
            wgpu::MapMode::Read,
            Some(done),
        )?;
        let ticks = {
            let view = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| Error::Device(format!("GPU timestamp readback failed: {e}")))?;
            let t: &[u64] = bytemuck::cast_slice(&view[..]);
            let copy = (self.copy && outputs.copied()).then(|| t[2].saturating_sub(t[1]));
            (t[1].saturating_sub(t[0]), copy)
        };
        self.readback.unmap();
        let seconds = |ticks: u64| ticks as f64 * self.period_ns * 1e-9;
        Ok((seconds(ticks.0), ticks.1.map(seconds)))
    }
}

/// The counter of the rays a shade hook casts (`hook_ray_count`, shaders/shade.wgsl), read
/// back and zeroed after every dispatch, so that its 32 bits need hold one dispatch's rays.
pub(super) struct HookRayCounter {
    pub(super) counter: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl HookRayCounter {
    pub(super) fn new(gpu: &Gpu) -> HookRayCounter {
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
        }
    }

    /// Copies the dispatch's count for reading and zeroes the counter for the next.
    pub(super) fn copy_and_reset(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_buffer_to_buffer(&self.counter, 0, &self.readback, 0, 4);
        encoder.clear_buffer(&self.counter, 0, None);
    }

    /// The count copied by [`HookRayCounter::copy_and_reset`] in submission `done`.
    pub(super) fn read(&self, gpu: &Gpu, done: &wgpu::SubmissionIndex) -> Result<u64> {
        let slice = self.readback.slice(..);
        map_buffers(gpu, &[slice], wgpu::MapMode::Read, Some(done))?;
        let count = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| Error::Device(format!("GPU ray count readback failed: {e}")))?;
            u32::from_ne_bytes(view[..4].try_into().expect("4 bytes"))
        };
        self.readback.unmap();
        Ok(count as u64)
    }
}
