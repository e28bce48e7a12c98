//! The devices the model knows, from published specifications and public microbenchmarks
//! (docs/gpu.md#a-cost-model lists the sources). Nothing here is fitted to a measured render.

/// What the model needs of a GPU.
#[derive(Clone, Debug)]
pub struct Device {
    pub name: &'static str,
    /// Streaming multiprocessors.
    pub sms: u32,
    /// Boost clock, GHz.
    pub clock_ghz: f64,
    /// Warp instructions issued per SM per cycle (four schedulers).
    pub issue_per_sm: f64,
    /// FP32 over FP64 throughput (an f64 kernel's arithmetic costs this many issue slots).
    pub fp64_cost: f64,
    /// Warps resident on an SM at once (occupancy: the kernel's registers allow about this many).
    pub warps_per_sm: u32,
    /// L1 data cache per SM, bytes (the kernel uses no shared memory, so the largest carve-out).
    pub l1_bytes: u64,
    pub l2_bytes: u64,
    /// Load-to-use latency, cycles: an L1 hit, an L2 hit, a DRAM access.
    pub l1_cycles: f64,
    pub l2_cycles: f64,
    pub dram_cycles: f64,
    /// Bandwidth, GB/s.
    pub l2_gbs: f64,
    pub dram_gbs: f64,
}

pub const H200: Device = Device {
    name: "h200",
    sms: 132,
    clock_ghz: 1.98,
    issue_per_sm: 4.0,
    fp64_cost: 2.0,
    warps_per_sm: 32,
    l1_bytes: 224 << 10,
    l2_bytes: 50 << 20,
    l1_cycles: 40.0,
    l2_cycles: 262.0,
    dram_cycles: 480.0,
    l2_gbs: 7000.0,
    dram_gbs: 4800.0,
};

pub const RTX4090: Device = Device {
    name: "rtx4090",
    sms: 128,
    clock_ghz: 2.52,
    issue_per_sm: 4.0,
    fp64_cost: 64.0,
    warps_per_sm: 32,
    l1_bytes: 128 << 10,
    l2_bytes: 72 << 20,
    l1_cycles: 33.0,
    l2_cycles: 273.0,
    dram_cycles: 560.0,
    l2_gbs: 5000.0,
    dram_gbs: 1008.0,
};

pub fn by_name(name: &str) -> Option<Device> {
    [H200, RTX4090].into_iter().find(|d| d.name == name)
}
