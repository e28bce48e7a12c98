//! What `raycast info` says about the adapter ([`describe`]), and the probe it and the
//! self-test run: what the shader compiler does to `a*b - c*d` on this device
//! ([`fusion_probe`]), evaluated unfused (two roundings of products, one of the difference) or
//! contracted into a fused multiply-add. The robust triangle test is built to be right either
//! way; this tells which way a driver goes.

use wgpu::util::DeviceExt;

use raycast::{Error, Gpu, Result};

const PROBE_WGSL: &str = "
@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> outputs: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= arrayLength(&outputs)) {
        return;
    }
    let q = inputs[k];
    outputs[k] = q.x * q.y - q.z * q.w;
}
";

/// How a device evaluated `a*b - c*d` over inputs chosen so that fused and unfused results
/// differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FusionReport {
    /// Inputs evaluated.
    pub samples: usize,
    /// Results equal to the unfused evaluation `(a*b) - (c*d)`.
    pub unfused: usize,
    /// Results equal to `fma(a, b, -(c*d))` or `fma(-c, d, a*b)` (and not to the unfused one).
    pub fused: usize,
}

impl FusionReport {
    /// The verdict and the counts, in one line.
    pub fn describe(&self) -> String {
        let verdict = if self.unfused == self.samples {
            "not fused"
        } else if self.fused + self.unfused == self.samples {
            "fused (multiply-add contraction)"
        } else {
            "neither fused nor unfused f32 rounding"
        };
        format!(
            "{verdict} ({} of {} samples unfused, {} fused)",
            self.unfused, self.samples, self.fused
        )
    }
}

/// Inputs where a*b and c*d nearly cancel, so the rounding of the products shows.
fn probe_inputs(samples: usize) -> Vec<[f32; 4]> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        1.0 + (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..samples)
        .map(|_| {
            let (a, b, c) = (next(), next(), next());
            // d chosen so c*d is within a few ulps of a*b.
            let d = (a as f64 * b as f64 / c as f64) as f32;
            [a, b, c, d]
        })
        .filter(|[a, b, c, d]| {
            let unfused = a * b - c * d;
            unfused != a.mul_add(*b, -(c * d)) && unfused != (-c).mul_add(*d, a * b)
        })
        .collect()
}

/// Whether `gpu` fuses `a*b - c*d` into a multiply-add (hardware drivers may; lavapipe never
/// does), which decides how closely its f32 renders can match the CPU reference's: it runs a
/// small probe kernel.
pub fn fusion_probe(gpu: &Gpu) -> Result<FusionReport> {
    let inputs = probe_inputs(4096);
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("fusion probe"),
        source: wgpu::ShaderSource::Wgsl(PROBE_WGSL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("fusion probe"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("probe inputs"),
        contents: bytemuck::cast_slice(&inputs),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (inputs.len() * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe outputs"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((inputs.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
    gpu.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    readback.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    let failed = |e: &dyn std::fmt::Display| Error::Device(format!("fusion probe failed: {e}"));
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| failed(&e))?;
    rx.recv().map_err(|e| failed(&e))?.map_err(|e| failed(&e))?;
    let view = readback.get_mapped_range(..).map_err(|e| failed(&e))?;
    let results: &[f32] = bytemuck::cast_slice(&view);
    let mut report = FusionReport {
        samples: inputs.len(),
        unfused: 0,
        fused: 0,
    };
    for ([a, b, c, d], r) in inputs.iter().zip(results) {
        if *r == a * b - c * d {
            report.unfused += 1;
        } else if *r == a.mul_add(*b, -(c * d)) || *r == (-c).mul_add(*d, a * b) {
            report.fused += 1;
        }
    }
    Ok(report)
}

/// What `raycast info` prints: the adapter, and the features and limits the renderer uses.
pub fn describe(gpu: &Gpu) -> String {
    let info = gpu.info().adapter;
    let features = gpu.device.features();
    let limits = gpu.device.limits();
    let has = |f: wgpu::Features| if features.contains(f) { "yes" } else { "no" };
    let mut s = String::new();
    s += &format!("adapter:      {}\n", info.name);
    s += &format!("backend:      {:?}\n", info.backend);
    s += &format!("device type:  {:?}\n", info.device_type);
    s += &format!("driver:       {}\n", info.driver);
    s += &format!("driver info:  {}\n", info.driver_info);
    s += &format!("shader f64:   {}\n", has(wgpu::Features::SHADER_F64));
    s += &format!("timestamps:   {}\n", has(wgpu::Features::TIMESTAMP_QUERY));
    s += &format!(
        "host-mapped buffers: {}\n",
        has(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS)
    );
    // What the adapter offers, not what raycast asks for: no kernel uses ray queries yet (#65).
    let adapter_has = |f| match gpu.adapter.features().contains(f) {
        true => "yes",
        false => "no",
    };
    s += &format!(
        "ray queries:  {} (the adapter's; raycast traverses on its own)\n",
        adapter_has(wgpu::Features::EXPERIMENTAL_RAY_QUERY)
    );
    // Whether `raycast bench --traversal packets` can run here (gpu-check reads `yes`), and
    // whether casts take it by default.
    let packets = match (
        gpu.info().packet_subgroups,
        gpu.info().packet_rays_per_primitive,
    ) {
        (false, _) => "no".to_owned(),
        (true, None) => "yes, when asked (casts go ray by ray here)".to_owned(),
        (true, Some(r)) => format!("yes, by default from {r} rays a sphere or triangle"),
    };
    s += &format!(
        "subgroups:    {} to {} invocations; packet traversal: {packets}\n",
        info.subgroup_min_size, info.subgroup_max_size,
    );
    s += &format!(
        "max storage buffer binding: {} bytes\n",
        limits.max_storage_buffer_binding_size
    );
    s += &format!("max buffer size: {} bytes\n", limits.max_buffer_size);
    s += &format!(
        "max workgroups per dimension: {}\n",
        limits.max_compute_workgroups_per_dimension
    );
    s += &format!(
        "max invocations per workgroup: {}\n",
        limits.max_compute_invocations_per_workgroup
    );
    let fusion = fusion_probe(gpu).map_or_else(|e| e.to_string(), |r| r.describe());
    s += &format!("f32 a*b - c*d: {fusion}\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_inputs_separate_fused_from_unfused() {
        let inputs = probe_inputs(4096);
        // Most near-cancelling pairs show the difference; enough remain to decide.
        assert!(inputs.len() > 1000, "{}", inputs.len());
    }
}
