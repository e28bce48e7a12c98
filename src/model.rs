//! The traces of the GPU cost model (feature `model`, off by default; benches/gpu_model and
//! docs/gpu.md#a-cost-model): a workload's rays grouped into 32-lane subgroups as the kernel
//! dispatches them on a GPU whose subgroups are 32 lanes (one ray a lane), and each subgroup's
//! traversal, per ray or as a packet, replayed through the CPU mirror as the lockstep steps the
//! subgroup runs, with the bytes each step reads. Not part of the library's API.

use std::mem::size_of;

use crate::algorithm::Algorithm;
use crate::cpu::hit::Hit;
use crate::cpu::nearest::before_bvh;
use crate::cpu::packet::traverse_bvh_packet;
use crate::cpu::traverse::{Trail, traverse_bvh_traced};
use crate::cpu::wide::traverse_wide_traced;
use crate::kernel::frame::camera_ray;
use crate::kernel::layout::{GpuSphere, GpuTriangle};
use crate::kernel::types::{Ray as KernelRay, t_far};
use crate::math::Real;
use crate::prepare::Prepared;
use crate::prepare::bvh::{BvhNode, SPHERE_LEAF, Search, leaf_len};
use crate::prepare::wide::{WideBvh, WideNode};
use crate::rays::Ray;
use crate::scene::Scene;

/// Lanes of a subgroup on the GPUs the model describes.
const LANES: usize = 32;
/// Where each buffer starts in the model's address space (byte addresses; far apart).
const NODES_AT: u64 = 0;
const TRIANGLES_AT: u64 = 1 << 40;
const SPHERES_AT: u64 = 2 << 40;
const WIDE_NODES_AT: u64 = 3 << 40;

/// How the subgroup's rays walk the BVH: shaders/traverse_packet.wgsl or traverse_ray.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// The subgroup walks the tree as one packet (the camera kernel's default with subgroups).
    Packets,
    /// Each lane walks its own ray's path (traverse_ray.wgsl, Aila and Laine's while-while):
    /// it visits nodes until it has leaves to test and then waits, and the subgroup tests all
    /// its lanes' leaves together, so that lanes finding leaves at different depths share the
    /// leaf steps.
    PerRay,
    /// The per-ray kernel before #61: one loop visiting a node and testing its leaves, the
    /// subgroup running the lanes' loops in lockstep. Same nodes and leaves a lane as `PerRay`.
    IfIf,
    /// Per ray through the compressed 8-wide tree (#62; src/cpu/wide.rs, no WGSL yet), in
    /// two loops as `PerRay`: 80-byte nodes, eight boxes decoded and tested a visit.
    Wide,
}

/// What a step of a subgroup does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// Tests rays against a node's two child boxes.
    Node,
    /// Decodes and tests a wide node's eight child boxes.
    WideNode,
    /// Tests rays against a triangle.
    Triangle,
    /// Tests rays against a sphere.
    Sphere,
}

/// One lockstep step of a subgroup: every lane waits for its slowest one.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    pub op: Op,
    /// The lanes whose ray needed this step (per ray: the lanes still running this operation;
    /// packets: the rays that wanted the node or test the primitive).
    pub wanted: u32,
    /// Where this step's reads end in [`Trace::reads`] (they start where the previous step's end).
    pub reads_end: u32,
}

/// A subgroup's steps and the reads they make: byte addresses of whole elements (a node,
/// triangle or sphere; `bytes` of [`Workload::element_bytes`]), one a lane that reads, one for
/// the subgroup where the element is shared.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub steps: Vec<Step>,
    pub reads: Vec<u64>,
    /// The lanes of the subgroup whose ray is the workload's (the others repeat a neighbour's
    /// ray, or idle).
    pub rays: u32,
}

enum Precision {
    F32(Prepared<f32>),
    F64(Prepared<f64>),
}

enum Source {
    /// The camera's rays at its resolution.
    Camera,
    /// A caller's ray list, in the kernel's coordinates later.
    List(Vec<Ray>),
}

/// A scene prepared as the kernel's robust algorithm sees it, in f32 or f64, and its rays.
pub struct Workload {
    prepared: Precision,
    source: Source,
    /// The wide tree, collapsed from the binary one when first asked for.
    wide: std::sync::OnceLock<Option<WideBvh>>,
}

impl Workload {
    /// The camera's rays of `scene` (at `scene.camera.resolution`), or with `rays` those rays;
    /// `None` where the scene is searched without a BVH.
    pub fn new(scene: &Scene, rays: Option<Vec<Ray>>, f64: bool) -> Option<Workload> {
        let prepared = match f64 {
            false => Precision::F32(Prepared::new(scene, Algorithm::Robust, Search::Auto)),
            true => Precision::F64(Prepared::new(scene, Algorithm::Robust, Search::Auto)),
        };
        Workload::of(prepared, rays)
    }

    /// [`Workload::new`] through the tree naming the scene's instances, each mesh held once
    /// (#64's `INSTANCES`): for the per-ray traversals only.
    pub fn instanced(scene: &Scene, rays: Option<Vec<Ray>>, f64: bool) -> Option<Workload> {
        let prepared = match f64 {
            false => Precision::F32(Prepared::instanced(scene, Algorithm::Robust)),
            true => Precision::F64(Prepared::instanced(scene, Algorithm::Robust)),
        };
        Workload::of(prepared, rays)
    }

    fn of(prepared: Precision, rays: Option<Vec<Ray>>) -> Option<Workload> {
        let bvh = match &prepared {
            Precision::F32(p) => p.bvh().is_some(),
            Precision::F64(p) => p.bvh().is_some(),
        };
        let source = rays.map_or(Source::Camera, Source::List);
        bvh.then_some(Workload {
            prepared,
            source,
            wide: std::sync::OnceLock::new(),
        })
    }

    /// The rays cast (pixels or listed rays).
    pub fn rays(&self) -> usize {
        match (&self.source, &self.prepared) {
            (Source::List(rays), _) => rays.len(),
            (Source::Camera, Precision::F32(p)) => pixels(p.resolution()),
            (Source::Camera, Precision::F64(p)) => pixels(p.resolution()),
        }
    }

    /// How many subgroups the kernel dispatches.
    pub fn subgroups(&self) -> usize {
        match (&self.source, &self.prepared) {
            (Source::List(rays), _) => rays.len().div_ceil(64) * 2,
            (Source::Camera, Precision::F32(p)) => blocks(p.resolution()) * 2,
            (Source::Camera, Precision::F64(p)) => blocks(p.resolution()) * 2,
        }
    }

    /// The bytes of a node, a triangle and a sphere in the kernel's buffers.
    pub fn element_bytes(&self, address: u64) -> u32 {
        let f64 = matches!(self.prepared, Precision::F64(_));
        match address {
            a if a >= WIDE_NODES_AT => WIDE_NODE_BYTES,
            a if a >= SPHERES_AT => sphere_bytes(f64),
            a if a >= TRIANGLES_AT => triangle_bytes(f64),
            _ => NODE_BYTES,
        }
    }

    /// The geometry's bytes a triangle on the device with `traversal`'s tree, as
    /// `raycast::Stages::bytes_per_triangle` counts them; `None` without triangles.
    pub fn bytes_per_triangle(&self, traversal: Traversal) -> Option<f64> {
        let tree = match traversal {
            Traversal::Wide => self.wide_tree()?.bytes(),
            _ => match &self.prepared {
                Precision::F32(p) => p.bvh()?.bytes(),
                Precision::F64(p) => p.bvh()?.bytes(),
            },
        };
        match &self.prepared {
            Precision::F32(p) => {
                (p.primitives).bytes_per_triangle(triangle_bytes(false) as usize, tree)
            }
            Precision::F64(p) => {
                (p.primitives).bytes_per_triangle(triangle_bytes(true) as usize, tree)
            }
        }
    }

    /// Whether the scene has a wide tree (#62): triangles only.
    pub fn has_wide_tree(&self) -> bool {
        self.wide_tree().is_some()
    }

    /// The wide tree, where the scene has one.
    fn wide_tree(&self) -> Option<&WideBvh> {
        self.wide
            .get_or_init(|| match &self.prepared {
                Precision::F32(p) => WideBvh::collapse(p.bvh()?),
                Precision::F64(p) => WideBvh::collapse(p.bvh()?),
            })
            .as_ref()
    }

    /// Replays subgroup `subgroup` (in dispatch order) with `traversal` into `out`; returns the
    /// objects its lanes' rays hit (`-1`: a miss), lane by lane.
    pub fn trace(&self, traversal: Traversal, subgroup: usize, out: &mut Trace) -> Vec<i32> {
        match &self.prepared {
            Precision::F32(p) => self.trace_in(p, traversal, subgroup, out),
            Precision::F64(p) => self.trace_in(p, traversal, subgroup, out),
        }
    }

    fn trace_in<T: Real>(
        &self,
        prepared: &Prepared<T>,
        traversal: Traversal,
        subgroup: usize,
        out: &mut Trace,
    ) -> Vec<i32> {
        let lanes = self.lane_rays(prepared, traversal, subgroup);
        out.steps.clear();
        out.reads.clear();
        out.rays = lanes.iter().filter(|l| l.1).count() as u32;
        let min_t = match self.source {
            Source::Camera => prepared.frame.min_t,
            Source::List(_) => T::ZERO,
        };
        let prims = &prepared.primitives;
        let nodes = &prepared.bvh().expect("a workload has a BVH").nodes;
        let rays: Vec<KernelRay<T>> = lanes.iter().filter_map(|l| l.0).collect();
        let mut best: Vec<Hit<T>> = rays
            .iter()
            .map(|r| before_bvh::<T, true>(r, min_t, t_far(), prims))
            .collect();
        match traversal {
            Traversal::Packets => {
                let mut steps = PacketSteps {
                    out,
                    f64: size_of::<T>() == 8,
                };
                traverse_bvh_packet::<T, true>(&rays, min_t, prims, nodes, &mut best, &mut steps);
            }
            Traversal::PerRay | Traversal::IfIf | Traversal::Wide => {
                let wide = traversal == Traversal::Wide;
                let path = Path {
                    f64: size_of::<T>() == 8,
                    wide,
                    ..Path::default()
                };
                let mut paths = vec![path; rays.len()];
                for ((ray, best), path) in rays.iter().zip(&mut best).zip(&mut paths) {
                    match wide {
                        true => {
                            let tree = self.wide_tree().expect("a wide tree for this scene");
                            traverse_wide_traced::<T, true>(ray, min_t, prims, tree, best, path)
                        }
                        false => {
                            traverse_bvh_traced::<T, true>(ray, min_t, prims, nodes, best, path)
                        }
                    }
                }
                match traversal {
                    Traversal::IfIf => lockstep(&paths, out),
                    _ => while_while(&paths, out),
                }
            }
        }
        best.iter().map(|h| h.object).collect()
    }

    /// The rays of a subgroup's lanes in the kernel's coordinates (`None`: the lane idles),
    /// each with whether its result is written (the packet kernel casts a neighbour's ray in
    /// a lane beyond the image or list, the per-ray kernel returns).
    fn lane_rays<T: Real>(
        &self,
        prepared: &Prepared<T>,
        traversal: Traversal,
        subgroup: usize,
    ) -> Vec<(Option<KernelRay<T>>, bool)> {
        let packets = traversal == Traversal::Packets;
        let (group, half) = (subgroup / 2, subgroup % 2);
        (half * LANES..(half + 1) * LANES)
            .map(|local| match &self.source {
                Source::List(rays) => {
                    let k = group * 64 + local;
                    let inside = k < rays.len();
                    let ray = (inside || packets)
                        .then(|| prepared.kernel_ray(&rays[k.min(rays.len() - 1)]));
                    (ray, inside)
                }
                Source::Camera => {
                    let [nx, ny] = prepared.resolution();
                    let across = (nx as usize).div_ceil(8);
                    // packet_tile_offset in shaders/entry.wgsl; the per-ray kernel's 8x8
                    // workgroup numbers its invocations row by row.
                    let (x, y) = match packets {
                        true => {
                            let tile = local >> 3;
                            (
                                (tile & 1) * 4 + (local & 3),
                                (tile >> 1) * 2 + ((local >> 2) & 1),
                            )
                        }
                        false => (local % 8, local / 8),
                    };
                    let j = ((group % across) * 8 + x) as u32;
                    let i = ((group / across) * 8 + y) as u32;
                    let inside = j < nx && i < ny;
                    let ray = (inside || packets)
                        .then(|| camera_ray(&prepared.frame, i.min(ny - 1), j.min(nx - 1)));
                    (ray, inside)
                }
            })
            .collect()
    }
}

fn pixels([nx, ny]: [u32; 2]) -> usize {
    nx as usize * ny as usize
}

/// The 8x8 workgroups over an image.
fn blocks([nx, ny]: [u32; 2]) -> usize {
    (nx as usize).div_ceil(8) * (ny as usize).div_ceil(8)
}

const NODE_BYTES: u32 = size_of::<BvhNode>() as u32;
const WIDE_NODE_BYTES: u32 = size_of::<WideNode>() as u32;

fn sphere_bytes(f64: bool) -> u32 {
    match f64 {
        false => size_of::<GpuSphere<f32>>() as u32,
        true => size_of::<GpuSphere<f64>>() as u32,
    }
}

fn triangle_bytes(f64: bool) -> u32 {
    match f64 {
        false => size_of::<GpuTriangle<f32>>() as u32,
        true => size_of::<GpuTriangle<f64>>() as u32,
    }
}

/// The address of node `node`.
fn node_at(node: u32) -> u64 {
    NODES_AT + u64::from(node) * u64::from(NODE_BYTES)
}

/// The address of wide node `node`.
fn wide_node_at(node: u32) -> u64 {
    WIDE_NODES_AT + u64::from(node) * u64::from(WIDE_NODE_BYTES)
}

/// The address of primitive `k` of a leaf with count word `count`.
fn primitive_at(k: u32, count: u32, f64: bool) -> (Op, u64) {
    match count & SPHERE_LEAF != 0 {
        true => (
            Op::Sphere,
            SPHERES_AT + u64::from(k) * u64::from(sphere_bytes(f64)),
        ),
        false => (
            Op::Triangle,
            TRIANGLES_AT + u64::from(k) * u64::from(triangle_bytes(f64)),
        ),
    }
}

impl Trace {
    /// Ends a step of `op` that `wanted` lanes needed, after the reads pushed since the last.
    fn end_step(&mut self, op: Op, wanted: u32) {
        let reads_end = self.reads.len() as u32;
        self.steps.push(Step {
            op,
            wanted,
            reads_end,
        });
    }

    /// The leaf steps of lanes testing `runs` (each lane's primitives, its leaves one after
    /// the other) together: step i tests primitive i of every lane that has one.
    fn leaf_steps(&mut self, runs: &[Vec<Leaf>], f64: bool) {
        let primitives = |l: &[Leaf]| l.iter().map(|&(_, c)| leaf_len(c)).sum::<u32>();
        let widest = runs.iter().map(|l| primitives(l)).max().unwrap_or(0);
        for i in 0..widest {
            let mut op = Op::Triangle;
            let mut wanted = 0;
            for (first, count) in runs.iter().filter_map(|run| nth_primitive(run, i)) {
                let address;
                (op, address) = primitive_at(first, count, f64);
                self.reads.push(address);
                wanted += 1;
            }
            self.end_step(op, wanted);
        }
    }
}

/// The packet's steps as it walks: a node for the whole subgroup, then each primitive of the
/// leaves it enters, each fetched once.
struct PacketSteps<'a> {
    out: &'a mut Trace,
    f64: bool,
}

impl PacketSteps<'_> {
    fn push(&mut self, op: Op, wanted: u32, address: u64) {
        self.out.reads.push(address);
        self.out.end_step(op, wanted);
    }
}

impl Trail for PacketSteps<'_> {
    fn node(&mut self, node: u32, lanes: u32) {
        self.push(Op::Node, lanes, node_at(node));
    }

    fn leaf(&mut self, _child: usize, first: u32, count: u32, lanes: u32) {
        for k in first..first + leaf_len(count) {
            let (op, address) = primitive_at(k, count, self.f64);
            self.push(op, lanes, address);
        }
    }
}

/// A leaf tested: its first primitive and count word.
type Leaf = (u32, u32);

/// One ray's path: each node it visited (its address) and the leaves it tested there (the
/// child, and its first primitive and count word; in the order tested).
#[derive(Clone, Default)]
struct Path {
    iterations: Vec<(u64, Vec<(usize, Leaf)>)>,
    f64: bool,
    /// Through the wide tree: its nodes.
    wide: bool,
}

impl Path {
    fn node_op(paths: &[Path]) -> Op {
        match paths.iter().any(|p| p.wide) {
            true => Op::WideNode,
            false => Op::Node,
        }
    }
}

impl Trail for Path {
    fn node(&mut self, node: u32, _lanes: u32) {
        let address = match self.wide {
            true => wide_node_at(node),
            false => node_at(node),
        };
        self.iterations.push((address, Vec::new()));
    }

    fn leaf(&mut self, child: usize, first: u32, count: u32, _lanes: u32) {
        if let Some(last) = self.iterations.last_mut() {
            last.1.push((child, (first, count)));
        }
    }
}

/// The subgroup's lockstep steps for its lanes' `paths`: iteration k of every lane's loop runs
/// together, its node visit, then child 0's leaf loop as long as the longest, then child 1's
/// (and so on for a wide node's).
fn lockstep(paths: &[Path], out: &mut Trace) {
    let f64 = paths.iter().any(|p| p.f64);
    let longest = paths.iter().map(|p| p.iterations.len()).max().unwrap_or(0);
    for k in 0..longest {
        let running = || paths.iter().filter_map(|p| p.iterations.get(k));
        for (node, _) in running() {
            out.reads.push(*node);
        }
        out.end_step(Path::node_op(paths), running().count() as u32);
        let children = running()
            .flat_map(|(_, l)| l.iter().map(|&(c, _)| c + 1))
            .max();
        for child in 0..children.unwrap_or(0) {
            let runs: Vec<Vec<Leaf>> = running()
                .map(|(_, l)| {
                    (l.iter())
                        .filter(|&&(c, _)| c == child)
                        .map(|&(_, leaf)| leaf)
                        .collect()
                })
                .collect();
            out.leaf_steps(&runs, f64);
        }
    }
}

/// The subgroup's steps for its lanes' `paths` as a while-while kernel runs them: in each
/// round every lane visits nodes up to the next one with leaves to test (the round's node
/// steps last as long as the lane with most), then every lane tests those leaves together
/// (as long as the lane with most primitives).
fn while_while(paths: &[Path], out: &mut Trace) {
    let f64 = paths.iter().any(|p| p.f64);
    let mut at = vec![0usize; paths.len()];
    while at.iter().zip(paths).any(|(&k, p)| k < p.iterations.len()) {
        // Each lane's nodes this round: to its next iteration with a leaf, inclusive.
        let ends: Vec<usize> = (at.iter().zip(paths))
            .map(|(&k, p)| {
                let rest = &p.iterations[k.min(p.iterations.len())..];
                let leaf = rest.iter().position(|(_, l)| !l.is_empty());
                k + leaf.map_or(rest.len(), |i| i + 1)
            })
            .collect();
        let longest = (ends.iter().zip(&at))
            .map(|(e, k)| e - k)
            .max()
            .unwrap_or(0);
        for step in 0..longest {
            let mut wanted = 0;
            for ((&k, &end), p) in at.iter().zip(&ends).zip(paths) {
                if k + step < end {
                    out.reads.push(p.iterations[k + step].0);
                    wanted += 1;
                }
            }
            out.end_step(Path::node_op(paths), wanted);
        }
        // The leaves each lane found at the end of its round, child 0's then child 1's.
        let runs: Vec<Vec<Leaf>> = (ends.iter().zip(&at).zip(paths))
            .map(|((&end, &k), p)| match end > k {
                true => p.iterations[end - 1]
                    .1
                    .iter()
                    .map(|&(_, leaf)| leaf)
                    .collect(),
                false => Vec::new(),
            })
            .collect();
        out.leaf_steps(&runs, f64);
        at = ends;
    }
}

/// Primitive `i` of the run of `leaves` (one after the other): its index and count word.
fn nth_primitive(leaves: &[Leaf], mut i: u32) -> Option<(u32, u32)> {
    for &(first, count) in leaves {
        if i < leaf_len(count) {
            return Some((first + i, count));
        }
        i -= leaf_len(count);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A while-while subgroup (the per-ray kernel's) does an if-if subgroup's work, grouped otherwise: the same reads,
    /// the same lane-steps wanted and the same answers, in fewer steps somewhere. (Built with
    /// the feature only:
    /// `cargo test -p raycast --features model --lib model`.)
    #[test]
    fn while_while_regroups_the_if_if_work() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/course/bunny.json");
        let mut scene = Scene::load(&path).unwrap();
        scene.camera.resolution = [64, 32];
        let workload = Workload::new(&scene, None, false).unwrap();
        let (mut if_if, mut while_while) = (Trace::default(), Trace::default());
        let wanted = |t: &Trace| t.steps.iter().map(|s| s.wanted as u64).sum::<u64>();
        let mut fewer = 0;
        for g in 0..workload.subgroups() {
            let a = workload.trace(Traversal::IfIf, g, &mut if_if);
            let b = workload.trace(Traversal::PerRay, g, &mut while_while);
            assert_eq!(a, b, "subgroup {g}: answers");
            let mut reads = (if_if.reads.clone(), while_while.reads.clone());
            reads.0.sort_unstable();
            reads.1.sort_unstable();
            assert_eq!(reads.0, reads.1, "subgroup {g}: reads");
            assert_eq!(wanted(&if_if), wanted(&while_while), "subgroup {g}");
            fewer += usize::from(while_while.steps.len() < if_if.steps.len());
        }
        assert!(fewer > 0, "while-while never saved a step");
    }

    #[test]
    fn nth_primitive_walks_the_leaves_in_turn() {
        let leaves = [(10, 2), (40, 3)];
        let found: Vec<_> = (0..6).map(|i| nth_primitive(&leaves, i)).collect();
        let expected = [
            Some((10, 2)),
            Some((11, 2)),
            Some((40, 3)),
            Some((41, 3)),
            Some((42, 3)),
            None,
        ];
        assert_eq!(found, expected);
    }
}
