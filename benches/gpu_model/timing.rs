//! The subgroups' steps through the caches, and the time they take on a device.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use raycast::model::{Op, Trace};

use crate::cache::{Cache, SECTOR};
use crate::device::Device;

/// Warp instructions of each step, counted from the kernel's WGSL (box tests of a node's two
/// children; the robust triangle test; the sphere test), and what packets add: the node's
/// eight broadcasts and the votes, a triangle's five broadcasts.
const NODE_INSTRUCTIONS: f64 = 48.0;
/// A wide node's visit (#62, src/cpu/wide.rs): eight box tests as a binary node's, each box
/// decoded first (six multiply-adds), and the slots' order and the pushes.
const WIDE_NODE_INSTRUCTIONS: f64 = 8.0 * (24.0 + 6.0) + 32.0;
const TRIANGLE_INSTRUCTIONS: f64 = 60.0;
const SPHERE_INSTRUCTIONS: f64 = 30.0;
const PACKET_NODE_EXTRA: f64 = 16.0;
const PACKET_PRIMITIVE_EXTRA: f64 = 6.0;
/// The share of a step's instructions that are arithmetic in the kernel's precision.
const ARITHMETIC_SHARE: f64 = 0.7;
/// Cycles a warp waits on its own instructions between loads (dependent arithmetic at four
/// cycles, two independent chains), and on a subgroup operation.
const CYCLES_PER_INSTRUCTION: f64 = 2.0;
const SHUFFLE_CYCLES: f64 = 24.0;
/// A dispatch's fixed cost, ms.
const LAUNCH_MS: f64 = 0.005;

/// What a workload's traces add up to on a device.
#[derive(Default, Clone, Debug)]
pub struct Totals {
    pub rays: u64,
    pub subgroups: u64,
    /// Steps a subgroup ran, summed over its valid lanes.
    pub lane_steps: u64,
    pub steps: u64,
    pub wanted: u64,
    pub l1_sectors: u64,
    pub l2_sectors: u64,
    pub dram_sectors: u64,
    /// Of the lane steps and L2 sectors, the nodes' (the rest are the primitives').
    pub node_lane_steps: u64,
    pub node_l2_sectors: u64,
    pub issue_cycles: f64,
    /// Each subgroup's own latency, cycles, in dispatch order.
    pub latency: Vec<f64>,
}

/// The caches of a device as the subgroups run through them in dispatch order: workgroup g
/// (two subgroups) on SM g mod SMs.
pub struct Machine {
    device: Device,
    f64: bool,
    packets: bool,
    l1: Vec<Cache>,
    l2: Cache,
    sectors: Vec<u64>,
}

impl Machine {
    pub fn new(device: &Device, f64: bool, packets: bool) -> Machine {
        Machine {
            device: device.clone(),
            f64,
            packets,
            l1: (0..device.sms)
                .map(|_| Cache::new(device.l1_bytes))
                .collect(),
            l2: Cache::new(device.l2_bytes),
            sectors: Vec::new(),
        }
    }

    /// Runs subgroup `subgroup`'s trace, reads of `bytes(address)` each.
    pub fn run(
        &mut self,
        subgroup: usize,
        trace: &Trace,
        bytes: impl Fn(u64) -> u32,
        totals: &mut Totals,
    ) {
        let d = &self.device;
        let sm = (subgroup / 2) % d.sms as usize;
        let mut latency = 0.0;
        let mut start = 0;
        for step in &trace.steps {
            let end = step.reads_end as usize;
            self.sectors.clear();
            for &a in &trace.reads[start..end] {
                let first = a / SECTOR;
                let last = (a + bytes(a) as u64 - 1) / SECTOR;
                self.sectors.extend(first..=last);
            }
            start = end;
            // The coalescer asks for each sector once a step.
            self.sectors.sort_unstable();
            self.sectors.dedup();
            let mut wait = 0.0f64;
            let l2_before = totals.l2_sectors;
            for &s in &self.sectors {
                totals.l1_sectors += 1;
                let cycles = if self.l1[sm].access(s) {
                    d.l1_cycles
                } else if self.l2.access(s) {
                    totals.l2_sectors += 1;
                    d.l2_cycles
                } else {
                    totals.l2_sectors += 1;
                    totals.dram_sectors += 1;
                    d.dram_cycles
                };
                wait = wait.max(cycles);
            }
            if matches!(step.op, Op::Node | Op::WideNode) {
                totals.node_lane_steps += trace.rays as u64;
                totals.node_l2_sectors += totals.l2_sectors - l2_before;
            }
            let (instructions, extra) = match (step.op, self.packets) {
                (Op::Node, false) => (NODE_INSTRUCTIONS, 0.0),
                (Op::Node, true) => (NODE_INSTRUCTIONS, PACKET_NODE_EXTRA),
                (Op::WideNode, _) => (WIDE_NODE_INSTRUCTIONS, 0.0),
                (Op::Triangle, p) => (
                    TRIANGLE_INSTRUCTIONS,
                    if p { PACKET_PRIMITIVE_EXTRA } else { 0.0 },
                ),
                (Op::Sphere, p) => (
                    SPHERE_INSTRUCTIONS,
                    if p { PACKET_PRIMITIVE_EXTRA } else { 0.0 },
                ),
            };
            let precision = if self.f64 { d.fp64_cost } else { 1.0 };
            let issue =
                instructions * (1.0 - ARITHMETIC_SHARE + ARITHMETIC_SHARE * precision) + extra;
            totals.issue_cycles += issue;
            let shuffles = if extra > 0.0 { SHUFFLE_CYCLES } else { 0.0 };
            latency += wait + issue * CYCLES_PER_INSTRUCTION + shuffles;
            totals.wanted += step.wanted as u64;
        }
        totals.rays += trace.rays as u64;
        totals.subgroups += 1;
        totals.steps += trace.steps.len() as u64;
        totals.lane_steps += trace.steps.len() as u64 * trace.rays as u64;
        totals.latency.push(latency);
    }
}

/// The predicted kernel time, ms, and what bounds it.
pub fn predict(device: &Device, totals: &Totals) -> (f64, &'static str) {
    let hz = device.clock_ghz * 1e9;
    // The subgroups in dispatch order onto the device's resident warp slots, each slot taking
    // the next subgroup when its last one ends.
    let slots = (device.sms * device.warps_per_sm) as usize;
    let mut free: BinaryHeap<Reverse<u64>> = (0..slots).map(|_| Reverse(0)).collect();
    let mut end = 0u64;
    for &l in &totals.latency {
        let Reverse(at) = free.pop().unwrap();
        let done = at + l as u64;
        end = end.max(done);
        free.push(Reverse(done));
    }
    let bounds = [
        (end as f64 / hz, "latency"),
        (
            totals.issue_cycles / (device.sms as f64 * device.issue_per_sm) / hz,
            "issue",
        ),
        (
            (totals.l2_sectors * SECTOR) as f64 / (device.l2_gbs * 1e9),
            "l2",
        ),
        (
            (totals.dram_sectors * SECTOR) as f64 / (device.dram_gbs * 1e9),
            "dram",
        ),
    ];
    let (s, bound) = bounds
        .into_iter()
        .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
    (s * 1e3 + LAUNCH_MS, bound)
}
