//! The bounding volume hierarchy over a scene's bounded primitives (spheres and triangles):
//! built on the host with a binned surface-area heuristic (SAH), in parallel, and flattened
//! into one array of [`BvhNode`]s that the WGSL kernel (shaders/traverse.wgsl) and the CPU reference
//! (src/cpu/traverse.rs) traverse the same way. Planes are unbounded and stay outside it.
//!
//! Correctness first: a node is skipped only when the ray certainly misses every primitive in
//! it, so the BVH finds exactly the hits brute force finds. Boxes are grown by a relative
//! margin far above the rounding error of the intersection tests and rounded outward to f32,
//! and the traversal's box test has slack of its own (`BOX_ENTRY_SHRINK`, `BOX_SLACK`), so a
//! hit that a watertight test reports right on an edge is never culled by a box test rounded
//! the other way.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::{ObjectIds, kernel_frame, kernel_origin};
use crate::algorithm::Algorithm;
use crate::math::{Vec3, length};
use crate::scene::{Object, Scene, moved_box};

mod two_level;
#[cfg(test)]
pub(crate) use two_level::top_tree_seconds;
pub(crate) use two_level::{MeshTree, Rest};

/// The deepest a leaf may lie (root at depth 0). The traversal's stack holds at most one entry
/// per level, so a stack of this many entries holds any tree's ([`Bvh::stack_entries`]).
pub(crate) const MAX_DEPTH: usize = 40;
// The packet kernels hold their stack of 40 entries in five registers (`packet_push` in
// shaders/traverse_packet.wgsl).
const _: () = assert!(MAX_DEPTH <= 40);
/// How the nearest hit is searched for among spheres and triangles ([`crate::Tuning::search`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Search {
    /// Through a BVH where it pays: from 32 spheres or 8 triangles, or a mix in between
    /// (`spheres / 32 + triangles / 8 >= 1`; [`Search::uses_bvh`] says for a scene).
    #[default]
    Auto,
    /// Always through a BVH.
    Bvh,
    /// Every primitive tested by every ray.
    BruteForce,
}

impl Search {
    /// From this many spheres a BVH is faster than brute force; below, [`Search::Auto`] builds
    /// none: the smallest count at which the BVH was faster in every run of
    /// `benches/bvh_crossover.rs`, set before packets lowered the break-even
    /// (docs/performance.md#bvh, docs/specializations.md).
    pub(crate) const SPHERE_CROSSOVER: usize = 32;
    /// The same for triangles, which cross over four times sooner: a (watertight) triangle
    /// test costs about four sphere tests. Chosen as [`Search::SPHERE_CROSSOVER`] was.
    pub(crate) const TRIANGLE_CROSSOVER: usize = 8;

    /// Whether `scene` is rendered through a BVH.
    pub fn uses_bvh(self, scene: &Scene) -> bool {
        match self {
            Search::Auto => worth_it(scene),
            Search::Bvh => true,
            Search::BruteForce => false,
        }
    }
}

impl std::str::FromStr for Search {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Search::Auto),
            "bvh" => Ok(Search::Bvh),
            "brute-force" => Ok(Search::BruteForce),
            _ => Err(format!(
                "unknown acceleration `{s}` (auto, bvh, brute-force)"
            )),
        }
    }
}

/// Whether `scene` has enough spheres and triangles for a BVH to pay: brute force costs the
/// sum of its tests, so each kind counts as a fraction of its own crossover,
/// `spheres / SPHERE_CROSSOVER + triangles / TRIANGLE_CROSSOVER >= 1`.
pub(crate) fn worth_it(scene: &Scene) -> bool {
    let [spheres, _, triangles] = scene.primitive_counts();
    let (s, t) = (Search::SPHERE_CROSSOVER, Search::TRIANGLE_CROSSOVER);
    spheres * t + triangles * s >= s * t
}

/// How many spheres and triangles `scene` has.
pub(crate) fn bounded_count(scene: &Scene) -> usize {
    scene
        .objects
        .iter()
        .map(|o| match o {
            Object::Sphere { .. } | Object::Triangle { .. } => 1,
            Object::Soup { triangles, .. } => triangles.len(),
            Object::Plane { .. } => 0,
        })
        .sum()
}

/// Set in a child's `reference` when it is a leaf (the rest is its first primitive).
pub(crate) const LEAF_BIT: u32 = 1 << 31;
/// Set, without [`LEAF_BIT`], in a child's `reference` that names an instance, the rest its
/// index in [`Instanced::instances`]: the ray moves into its mesh's coordinates and walks its
/// mesh's tree (#64; never set in a node's index, which would need 2^30 nodes).
pub(crate) const INSTANCE_BIT: u32 = 1 << 30;
/// Set in a leaf's `count` when its primitives are spheres (else triangles).
pub(crate) const SPHERE_LEAF: u32 = 1 << 31;
/// Set in a leaf's `count` when it holds more primitives than [`LEAF_COUNT`] counts (only a
/// leaf at [`MAX_DEPTH`] can): the bits below are the count, and each primitive's object is
/// looked up.
pub(crate) const MANY_LEAF: u32 = 1 << 30;
/// A leaf's `count` without [`MANY_LEAF`]: its primitives in these bits, and from
/// [`LEAF_OBJECT_SHIFT`] up the object all of them belong to, or [`MIXED_OBJECTS`]. The kernel
/// then takes a candidate's object id from the node it already holds instead of loading it
/// for every hit, lane by lane on llvmpipe (shaders/traverse.wgsl `object_of`).
pub(crate) const LEAF_COUNT: u32 = 0xF;
pub(crate) const LEAF_OBJECT_SHIFT: u32 = 4;
/// The leaf's primitives belong to several objects (or to one whose id does not fit).
pub(crate) const MIXED_OBJECTS: u32 = (1 << 26) - 1;

/// The `count` of a leaf of `len` primitives of `kind` ([`SPHERE_LEAF`] or 0), all of `object`
/// or of several ([`MIXED_OBJECTS`]).
pub(crate) fn leaf_word(kind: u32, len: usize, object: u32) -> u32 {
    let len = len as u32;
    match len > LEAF_COUNT {
        true => kind | MANY_LEAF | len,
        false => kind | (object.min(MIXED_OBJECTS) << LEAF_OBJECT_SHIFT) | len,
    }
}

/// The number of primitives of a leaf from its `count`.
pub(crate) fn leaf_len(count: u32) -> u32 {
    match count & MANY_LEAF != 0 {
        true => count & (MANY_LEAF - 1),
        false => count & LEAF_COUNT,
    }
}

/// The object every primitive of a leaf belongs to, from its `count`, or [`MIXED_OBJECTS`].
pub(crate) fn leaf_object(count: u32) -> u32 {
    match count & MANY_LEAF != 0 {
        true => MIXED_OBJECTS,
        false => (count >> LEAF_OBJECT_SHIFT) & MIXED_OBJECTS,
    }
}
/// Relative growth of every primitive's box before the build: 2^-18, about 64 f32 ulps of the
/// coordinates, far above what the f32 intersection tests can be off by.
const GROWTH: f64 = 1.0 / 262_144.0;
/// Candidate split planes per axis are the boundaries of this many bins.
const BINS: usize = 16;
/// Nodes with more primitives are always split (unless they cannot be).
const MAX_LEAF: usize = 8;
/// SAH cost of visiting a node, relative to one primitive test. At 3 rather than 1 the
/// torus's tree has far fewer nodes and builds faster, and traces as fast; at 5 leaves reach
/// `MAX_LEAF` and tracing slows, and no other cost tried traced faster
/// (docs/experiments.md#build-and-layout-choices).
const TRAVERSAL_COST: f64 = 3.0;
/// [`TRAVERSAL_COST`] for the spheres' subtree, where a primitive test is cheaper: the 100
/// spheres of `benches/peers.sh` traced faster at 1.5 than at 3 or 6, and about as fast at 0.5
/// and 1 (docs/experiments.md#build-and-layout-choices).
const SPHERE_TRAVERSAL_COST: f64 = 1.5;
/// Nodes with more primitives are built with their two halves in parallel.
const PARALLEL_ITEMS: usize = 4096;
/// Trees over at most this many primitives of a kind search every axis for each node's split;
/// larger ones only the axis the centroids spread widest on ([`Binning::candidates`]). A small
/// tree builds in milliseconds either way and traces a little faster with three axes; a large
/// one builds much faster with one, for a slightly slower trace
/// (docs/experiments.md#build-and-layout-choices).
const ALL_AXES_ITEMS: usize = 1 << 16;

/// One interior node: the boxes of its two children and where they are. 64 bytes, read in the
/// kernel as four `vec4<u32>` (per ray) or eight `vec2<u32>` (packets). Offsets in bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct BvhNode {
    pub lo0: [f32; 3],   // offset 0: child 0 box
    pub reference0: u32, // offset 12: node index, or LEAF_BIT | first primitive
    pub hi0: [f32; 3],   // offset 16
    pub count0: u32,     // offset 28: leaf primitives and their object (leaf_word), 0 for a node
    pub lo1: [f32; 3],   // offset 32: child 1 box
    pub reference1: u32, // offset 44
    pub hi1: [f32; 3],   // offset 48
    pub count1: u32,     // offset 60
} // size 64

// The kernel reads a node as four vec4<u32> or eight vec2<u32> (shaders/bindings.wgsl).
const _: () = assert!(size_of::<BvhNode>() == 64);

/// A child as its parent stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Child {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    pub reference: u32,
    pub count: u32,
}

impl BvhNode {
    pub(crate) fn new(c0: Child, c1: Child) -> BvhNode {
        BvhNode {
            lo0: c0.lo,
            reference0: c0.reference,
            hi0: c0.hi,
            count0: c0.count,
            lo1: c1.lo,
            reference1: c1.reference,
            hi1: c1.hi,
            count1: c1.count,
        }
    }

    /// Child `k` (0 or 1).
    pub(crate) fn child(&self, k: usize) -> Child {
        if k == 0 {
            Child {
                lo: self.lo0,
                hi: self.hi0,
                reference: self.reference0,
                count: self.count0,
            }
        } else {
            Child {
                lo: self.lo1,
                hi: self.hi1,
                reference: self.reference1,
                count: self.count1,
            }
        }
    }
}

/// A flattened BVH: node 0 is the root, over a subtree of each kind where the scene has both
/// (else the one kind's own root). Spheres and triangles are stored in BVH order, the
/// `*_order` lists giving each one's index in the scene's own order (ties between two
/// primitives of one object go to the lower original index, as in brute force).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub sphere_order: Vec<u32>,
    pub triangle_order: Vec<u32>,
    /// [`Bvh::depth`], found once when the tree is built: every dispatch asks for it
    /// ([`Bvh::stack_entries`]), and walking every node for it would dominate a one-ray cast.
    pub depth: usize,
    /// Where the tree names instances ([`INSTANCE_BIT`]) rather than holding their triangles:
    /// each mesh's tree and triangles once, in the mesh's coordinates.
    pub instanced: Option<Instanced>,
}

/// The instances of a tree whose references name them ([`INSTANCE_BIT`]), and its meshes.
/// `triangle_order` holds the other objects' triangles first (their indices in the scene's
/// order), then each mesh's (their indices in the mesh).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Instanced {
    /// Per instance, as references number them.
    pub instances: Vec<InstanceRoot>,
    /// Per mesh laid out: a placement of it, and its triangles' positions.
    pub meshes: Vec<MeshSpan>,
    /// The other objects' triangles, before the meshes'.
    pub rest_triangles: u32,
    /// Each object's first triangle in the scene's order: the other objects' are found by it
    /// ([`crate::prepare::SceneTriangles`]) in a scene that holds no copy of the instances'.
    pub firsts: Vec<u32>,
}

/// An instance of an [`Instanced`] tree: its placement (index in `Scene::instances`), the
/// node its mesh's tree starts at and the mesh (index in [`Instanced::meshes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct InstanceRoot {
    pub placement: u32,
    pub root: u32,
    pub mesh: u32,
}

/// A mesh of an [`Instanced`] tree: a placement of it (index in `Scene::instances`), the
/// positions `first..first + len` of its triangles, the node its tree starts at, and its box in
/// its own coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MeshSpan {
    pub placement: u32,
    pub first: u32,
    pub len: u32,
    pub root: u32,
    pub bounds: (glam::DVec3, glam::DVec3),
}

impl Instanced {
    /// Each instance's box in `scene`'s coordinates: its mesh's box moved, which holds every
    /// placed triangle.
    pub(crate) fn boxes<'a>(
        &'a self,
        scene: &'a Scene,
    ) -> impl Iterator<Item = (glam::DVec3, glam::DVec3)> + 'a {
        (self.instances.iter()).map(|i| {
            let transform = &scene.instances[i.placement as usize].transform;
            moved_box(self.meshes[i.mesh as usize].bounds, transform)
        })
    }
}

/// A primitive's box while building, and its index in its kind's list.
#[derive(Clone, Copy, Debug)]
struct Item {
    /// Rounded outward to f32 once: the build then moves half the bytes, and the node boxes,
    /// unions of these, are exact in f32.
    lo: [f32; 3],
    hi: [f32; 3],
    index: u32,
}

impl Item {
    /// Twice the centre along `axis` (halving would only cost time: bins are relative).
    fn centroid(&self, axis: usize) -> f32 {
        self.lo[axis] + self.hi[axis]
    }
}

/// An axis-aligned box, empty when `lo > hi`. In f32: the primitives' boxes are f32 already, so
/// their unions are exact.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    fn grow(&mut self, lo: [f32; 3], hi: [f32; 3]) {
        for k in 0..3 {
            self.lo[k] = smaller(self.lo[k], lo[k]);
            self.hi[k] = larger(self.hi[k], hi[k]);
        }
    }

    fn union(mut self, o: Aabb) -> Aabb {
        self.grow(o.lo, o.hi);
        self
    }

    fn half_area(&self) -> f64 {
        let d = [0, 1, 2].map(|k| (self.hi[k] as f64 - self.lo[k] as f64).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// The smaller of two numbers that are not NaN (no box holds one: the scene is validated).
/// A plain comparison compiles to one `minss`, where `f32::min`'s NaN rule costs two more
/// instructions on every box grown, the build's innermost work.
fn smaller(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// The larger of two numbers that are not NaN (see [`smaller`]).
fn larger(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// The box of some items and the box of their centroids.
#[derive(Clone, Copy, Debug)]
struct Extent {
    boxes: Aabb,
    centroids: Aabb,
}

impl Extent {
    const EMPTY: Extent = Extent {
        boxes: Aabb::EMPTY,
        centroids: Aabb::EMPTY,
    };

    fn add(&mut self, i: &Item) {
        self.boxes.grow(i.lo, i.hi);
        let c = [0, 1, 2].map(|k| i.centroid(k));
        self.centroids.grow(c, c);
    }

    fn union(self, o: Extent) -> Extent {
        Extent {
            boxes: self.boxes.union(o.boxes),
            centroids: self.centroids.union(o.centroids),
        }
    }

    /// The extent of `items`, in one pass.
    fn of(items: &[Item]) -> Extent {
        if items.len() > PARALLEL_ITEMS {
            return items
                .par_chunks(PARALLEL_ITEMS)
                .map(Extent::of)
                .reduce(|| Extent::EMPTY, Extent::union);
        }
        let mut e = Extent::EMPTY;
        for i in items {
            e.add(i);
        }
        e
    }
}

/// A subtree before flattening; leaves are ranges of the item list, which the build leaves
/// partitioned in BVH order.
enum Tree {
    Leaf { start: usize, len: usize },
    Inner(Box<[(Aabb, Tree); 2]>),
}

/// Per-bin boxes and counts along one axis.
#[derive(Clone, Copy)]
struct Bins {
    boxes: [Aabb; BINS],
    counts: [usize; BINS],
}

impl Bins {
    const EMPTY: Bins = Bins {
        boxes: [Aabb::EMPTY; BINS],
        counts: [0; BINS],
    };

    fn merge(mut self, o: Bins) -> Bins {
        for b in 0..BINS {
            self.boxes[b] = self.boxes[b].union(o.boxes[b]);
            self.counts[b] += o.counts[b];
        }
        self
    }
}

/// Where the bins lie: along one axis ([`Binning::over`]), over the centroid bounds, `used`
/// equal parts: `BINS`, or one per item below that. Fewer bins offer fewer split planes, but
/// on the torus the tree barely changed and built faster
/// (docs/experiments.md#build-and-layout-choices).
#[derive(Clone, Copy)]
struct Binning {
    used: usize,
    axis: usize,
    lo: f32,
    /// Bins per unit along `axis`.
    scale: f32,
}

impl Binning {
    /// The binnings a node of `items` items whose centroids span `cb` takes its split from:
    /// along every axis they spread on where `all_axes`, else along the one they spread widest
    /// on (the first of equals); none where they do not spread. With few items a node's cost
    /// is its split search, three axes' sweeps of the bins in f64, so for a large tree every
    /// axis costs far more build than it saves trace (docs/performance.md#bvh).
    fn candidates(cb: &Aabb, items: usize, all_axes: bool) -> impl Iterator<Item = Binning> {
        let used = items.clamp(2, BINS);
        let extent = [0, 1, 2].map(|k| cb.hi[k] - cb.lo[k]);
        let widest = (0..3).fold(0, |w, k| if extent[k] > extent[w] { k } else { w });
        (0..3)
            .filter(move |&axis| (all_axes || axis == widest) && extent[axis] > 0.0)
            // A multiplication per item instead of a division; a scale that overflows only
            // piles items into the last bin, which the clamp in `bin` keeps.
            .map(move |axis| Binning {
                used,
                axis,
                lo: cb.lo[axis],
                scale: used as f32 / extent[axis],
            })
    }

    /// Which bin an item's centroid falls in.
    fn bin(&self, item: &Item) -> usize {
        // Through i32, whose saturating conversion is a few instructions fewer than usize's;
        // NaN (0 times a scale that overflowed) goes to bin 0, as it would through usize.
        let bin = ((item.centroid(self.axis) - self.lo) * self.scale) as i32;
        (bin.max(0) as usize).min(self.used - 1)
    }
}

/// The bins of `items`, in one pass.
fn fill_bins(items: &[Item], binning: &Binning) -> Bins {
    if items.len() > PARALLEL_ITEMS {
        return items
            .par_chunks(PARALLEL_ITEMS)
            .map(|c| fill_bins(c, binning))
            .reduce(|| Bins::EMPTY, Bins::merge);
    }
    let mut bins = Bins::EMPTY;
    for i in items {
        let b = binning.bin(i);
        bins.boxes[b].grow(i.lo, i.hi);
        bins.counts[b] += 1;
    }
    bins
}

/// The cheapest split of `axis`: (its sides' areas weighted by their primitives, first bin of
/// the right side). That weight is the SAH cost up to the node's own terms, which
/// [`sah_cost`] adds once for the best split, sparing a division per candidate plane in the
/// build's innermost loop.
fn best_split_of_axis(bins: &Bins, used: usize) -> Option<(f64, usize)> {
    let mut right_area = [0.0; BINS];
    let mut right_count = [0usize; BINS];
    let (mut b, mut n) = (Aabb::EMPTY, 0);
    for k in (1..used).rev() {
        b = b.union(bins.boxes[k]);
        n += bins.counts[k];
        right_area[k] = b.half_area();
        right_count[k] = n;
    }
    let (mut left, mut left_count) = (Aabb::EMPTY, 0);
    let mut best: Option<(f64, usize)> = None;
    for k in 1..used {
        left = left.union(bins.boxes[k - 1]);
        left_count += bins.counts[k - 1];
        if left_count == 0 || right_count[k] == 0 {
            continue;
        }
        let weight = left.half_area() * left_count as f64 + right_area[k] * right_count[k] as f64;
        if best.is_none_or(|(w, _)| weight < w) {
            best = Some((weight, k));
        }
    }
    best
}

/// The SAH cost of a split of weight `weight` ([`best_split_of_axis`]) of a node of half
/// area `area`, relative to one primitive test.
fn sah_cost(weight: f64, area: f64, traversal_cost: f64) -> f64 {
    traversal_cost + weight / area.max(f64::MIN_POSITIVE)
}

/// How a tree over one kind of primitive is built: what a node visit costs in primitive tests,
/// and whether each node's split is searched along every axis ([`ALL_AXES_ITEMS`]).
#[derive(Clone, Copy)]
struct Policy {
    traversal_cost: f64,
    all_axes: bool,
}

/// Builds the subtree over `items` (which start at `start` in the whole list, and span
/// `extent`) at `depth`, as `policy` says. A split passes each side its extent, found while
/// partitioning, so no node makes a pass over its items for its bounds.
fn build_tree(
    items: &mut [Item],
    start: usize,
    depth: usize,
    extent: Extent,
    policy: Policy,
) -> (Aabb, Tree) {
    let bounds = extent.boxes;
    let n = items.len();
    let leaf = Tree::Leaf { start, len: n };
    if n <= 1 || depth + 1 >= MAX_DEPTH {
        return (bounds, leaf);
    }
    let area = bounds.half_area();
    // The lightest split of any candidate axis (the first of equals).
    let split = Binning::candidates(&extent.centroids, n, policy.all_axes)
        .filter_map(|binning| {
            let best = best_split_of_axis(&fill_bins(items, &binning), binning.used);
            best.map(|(weight, bin)| (weight, binning, bin))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let (mid, sides) = match split {
        Some((weight, _, _))
            if n <= MAX_LEAF && sah_cost(weight, area, policy.traversal_cost) >= n as f64 =>
        {
            return (bounds, leaf);
        }
        Some((_, binning, bin)) => partition(items, |i| binning.bin(i) < bin),
        // Every centroid in one point: no plane separates them, so halve the list.
        None if n <= MAX_LEAF => return (bounds, leaf),
        None => {
            let (left, right) = items.split_at(n / 2);
            (n / 2, [Extent::of(left), Extent::of(right)])
        }
    };
    let (left, right) = items.split_at_mut(mid);
    let (l, r) = if n >= PARALLEL_ITEMS {
        rayon::join(
            || build_tree(left, start, depth + 1, sides[0], policy),
            || build_tree(right, start + mid, depth + 1, sides[1], policy),
        )
    } else {
        (
            build_tree(left, start, depth + 1, sides[0], policy),
            build_tree(right, start + mid, depth + 1, sides[1], policy),
        )
    };
    (bounds, Tree::Inner(Box::new([l, r])))
}

/// The tree over all `items` of one kind, if there are any.
fn build_root(items: &mut [Item], traversal_cost: f64) -> Option<(Aabb, Tree)> {
    let extent = Extent::of(items);
    let policy = Policy {
        traversal_cost,
        all_axes: items.len() <= ALL_AXES_ITEMS,
    };
    (!items.is_empty()).then(|| build_tree(items, 0, 1, extent, policy))
}

/// Moves the items for which `left` holds to the front; returns how many there are and the
/// extents of both sides. From both ends inwards, so that only misplaced items move (swapping
/// every left item in place would store each one).
fn partition(items: &mut [Item], left: impl Fn(&Item) -> bool) -> (usize, [Extent; 2]) {
    let mut sides = [Extent::EMPTY; 2];
    let (mut front, mut back) = (0, items.len());
    loop {
        while front < back && left(&items[front]) {
            sides[0].add(&items[front]);
            front += 1;
        }
        while front < back && !left(&items[back - 1]) {
            sides[1].add(&items[back - 1]);
            back -= 1;
        }
        if front == back {
            return (front, sides);
        }
        // items[front] belongs right and items[back - 1] left.
        items.swap(front, back - 1);
        sides[0].add(&items[front]);
        sides[1].add(&items[back - 1]);
        front += 1;
        back -= 1;
    }
}

/// The primitives of one kind as the build ordered them (`items`) and their objects by the
/// items' `index` (`objects`).
#[derive(Clone, Copy)]
struct Kind<'a> {
    /// `SPHERE_LEAF` or 0.
    leaf: u32,
    items: &'a [Item],
    objects: &'a [u32],
}

impl Kind<'_> {
    /// The object all the items `start..start + len` belong to, or `MIXED_OBJECTS`.
    fn object_of(&self, start: usize, len: usize) -> u32 {
        let mut objects = self.items[start..start + len]
            .iter()
            .map(|i| self.objects[i.index as usize]);
        match objects.next() {
            Some(first) if objects.all(|o| o == first) => first,
            _ => MIXED_OBJECTS,
        }
    }
}

/// Appends the interior nodes of `tree` to `nodes` (the tree's own node first) and returns the
/// child entry its parent stores.
fn flatten(bounds: Aabb, tree: &Tree, kind: Kind<'_>, nodes: &mut Vec<BvhNode>) -> Child {
    let Aabb { lo, hi } = bounds;
    match tree {
        Tree::Leaf { start, len } => {
            let object = kind.object_of(*start, *len);
            Child {
                lo,
                hi,
                reference: LEAF_BIT | *start as u32,
                count: leaf_word(kind.leaf, *len, object),
            }
        }
        Tree::Inner(children) => {
            let at = nodes.len();
            nodes.push(BvhNode::zeroed());
            let [(b0, t0), (b1, t1)] = &**children;
            let c0 = flatten(*b0, t0, kind, nodes);
            let c1 = flatten(*b1, t1, kind, nodes);
            nodes[at] = BvhNode::new(c0, c1);
            Child {
                lo,
                hi,
                reference: at as u32,
                count: 0,
            }
        }
    }
}

/// The items of one kind, each box grown by `GROWTH` relative to its size, its distance from
/// the kernel origin and the eye's, so every rounding of the tests stays inside.
fn grown(boxes: Vec<(Vec3<f64>, Vec3<f64>)>, eye: f64) -> Vec<Item> {
    boxes
        .into_par_iter()
        .enumerate()
        .map(|(index, (lo, hi))| {
            let size = (0..3)
                .map(|k| lo.get(k).abs().max(hi.get(k).abs()))
                .fold(eye, f64::max);
            let g = Vec3::splat(GROWTH * size);
            Item {
                lo: (lo - g).to_array().map(round_down),
                hi: (hi + g).to_array().map(round_up),
                index: index as u32,
            }
        })
        .collect()
}

/// The shape of a scene's BVH: which primitives each leaf holds and how the nodes nest,
/// without the boxes. It depends on the objects alone, not on the camera: it is built from
/// their boxes measured from the centre of their bounds, so every view of a scene
/// (a [`crate::Viewer`]'s) fits one topology to its camera ([`Bvh::fit`]) and a single
/// render builds the very same tree.
#[derive(Clone, Debug)]
pub(crate) struct Topology(Bvh);

impl Topology {
    /// The topology of `scene`'s BVH: where the scene places meshes (instances), their own
    /// trees under a tree over the instances ([`two_level`]); else, or where that tree would
    /// be too deep, the binned SAH build over its primitives' boxes.
    pub(crate) fn build(scene: &Scene) -> Topology {
        two_level::build(scene).unwrap_or_else(|| Topology::of_objects(&scene.objects))
    }

    /// The topology of `scene`'s BVH naming its instances rather than holding their triangles
    /// ([`two_level::instanced`]), where it places meshes and the tree is shallow enough.
    pub(crate) fn instanced(scene: &Scene) -> Option<Topology> {
        two_level::instanced(scene)
    }

    /// The instances it names, where it is [`Topology::instanced`]'s.
    pub(crate) fn named_instances(&self) -> Option<&Instanced> {
        self.0.instanced.as_ref()
    }

    /// The binned SAH build over the boxes of `objects`' spheres and triangles, measured from
    /// the centre of their bounds.
    fn of_objects<'a>(objects: impl IntoIterator<Item = &'a Object> + Clone) -> Topology {
        let (spheres, triangles) = primitive_boxes(objects.clone(), Vec3::splat(0.0));
        let centre = spheres
            .iter()
            .chain(&triangles)
            .fold(None, |b: Option<([f64; 3], [f64; 3])>, (lo, hi)| {
                let (lo, hi) = (lo.to_array(), hi.to_array());
                Some(b.map_or((lo, hi), |(l, h)| {
                    (
                        [0, 1, 2].map(|k| l[k].min(lo[k])),
                        [0, 1, 2].map(|k| h[k].max(hi[k])),
                    )
                }))
            })
            .map_or(Vec3::splat(0.0), |(lo, hi)| {
                Vec3::from_array([0, 1, 2].map(|k| 0.5 * lo[k] + 0.5 * hi[k]))
            });
        let around = |boxes: Vec<(Vec3<f64>, Vec3<f64>)>| -> Vec<Item> {
            boxes
                .into_par_iter()
                .enumerate()
                .map(|(index, (lo, hi))| Item {
                    lo: (lo - centre).to_array().map(round_down),
                    hi: (hi - centre).to_array().map(round_up),
                    index: index as u32,
                })
                .collect()
        };
        let ids = ObjectIds::of_objects(objects);
        Topology(Bvh::from_boxes(
            around(spheres),
            around(triangles),
            &ids.spheres,
            &ids.triangles,
        ))
    }
}

impl Topology {
    /// [`Topology::build`] of `scene`, or the one shared for its objects
    /// ([`super::shared::sharing`]).
    pub(crate) fn of(scene: &Scene) -> Arc<Topology> {
        super::shared::topology(scene)
    }
}

/// Fits every leaf child's box to its primitives' (`sphere` and `triangle`: the item at a
/// position of their order), in parallel. The empty child of a root over one kind keeps its
/// zero box.
fn fit_leaves<'a>(
    nodes: &mut [BvhNode],
    sphere: impl Fn(usize) -> &'a Item + Sync,
    triangle: impl Fn(usize) -> &'a Item + Sync,
) {
    nodes.par_iter_mut().for_each(|node| {
        let mut children = [node.child(0), node.child(1)];
        for c in &mut children {
            if c.reference & LEAF_BIT == 0 || leaf_len(c.count) == 0 {
                continue;
            }
            let first = (c.reference & !LEAF_BIT) as usize;
            let range = first..first + leaf_len(c.count) as usize;
            let b = match c.count & SPHERE_LEAF != 0 {
                true => union(range, &sphere),
                false => union(range, &triangle),
            };
            (c.lo, c.hi) = (b.lo, b.hi);
        }
        *node = BvhNode::new(children[0], children[1]);
    });
}

/// The box of the items at `positions`.
fn union<'a>(positions: std::ops::Range<usize>, item: impl Fn(usize) -> &'a Item) -> Aabb {
    let mut b = Aabb::EMPTY;
    for k in positions {
        let i = item(k);
        b.grow(i.lo, i.hi);
    }
    b
}

/// Fits every inner node's box to its children's, once the leaves' are fitted; a child naming
/// an instance ([`INSTANCE_BIT`]) gets `instance_box` of it. Children come after their parents
/// (`flatten`), so a backward pass meets every node's children before the node.
fn fit_nodes(nodes: &mut [BvhNode], instance_box: impl Fn(u32) -> Aabb) {
    let mut node_boxes = vec![Aabb::EMPTY; nodes.len()];
    for n in (0..nodes.len()).rev() {
        let mut children = [nodes[n].child(0), nodes[n].child(1)];
        let mut node_box = Aabb::EMPTY;
        for c in &mut children {
            if c.reference & LEAF_BIT == 0 {
                let b = match c.reference & INSTANCE_BIT != 0 {
                    true => instance_box(c.reference & !INSTANCE_BIT),
                    false => node_boxes[c.reference as usize],
                };
                (c.lo, c.hi) = (b.lo, b.hi);
            } else if leaf_len(c.count) == 0 {
                continue;
            }
            node_box.grow(c.lo, c.hi);
        }
        nodes[n] = BvhNode::new(children[0], children[1]);
        node_boxes[n] = node_box;
    }
}

/// The boxes of `objects`' spheres and triangles measured from `origin`, each kind in the
/// scene's order.
#[allow(clippy::type_complexity)]
fn primitive_boxes<'a>(
    objects: impl IntoIterator<Item = &'a Object>,
    origin: Vec3<f64>,
) -> (Vec<(Vec3<f64>, Vec3<f64>)>, Vec<(Vec3<f64>, Vec3<f64>)>) {
    let mut spheres = Vec::new();
    let mut triangles = Vec::new();
    for object in objects {
        match object {
            Object::Sphere { center, radius } => {
                let c = Vec3::from(*center) - origin;
                spheres.push((c - Vec3::splat(*radius), c + Vec3::splat(*radius)));
            }
            Object::Triangle { corners } => triangles.push(triangle_box(corners, origin)),
            Object::Soup { triangles: t, .. } => {
                triangles.par_extend(t.par_iter().map(|c| triangle_box(c, origin)))
            }
            Object::Plane { .. } => {}
        }
    }
    (spheres, triangles)
}

impl Bvh {
    /// The BVH over `scene`'s spheres and triangles in the kernel's coordinates for
    /// `algorithm` (camera-relative for the robust set), as [`super::Primitives`]
    /// lays them out. Spheres and triangles get separate subtrees, so every leaf holds one kind.
    /// Its shape is [`Topology::build`]'s, which the camera does not change; its boxes are
    /// fitted to the camera's coordinates ([`Bvh::fit`]).
    #[cfg(test)]
    pub(crate) fn build(scene: &Scene, algorithm: Algorithm) -> Bvh {
        Bvh::fit(&Topology::build(scene), scene, algorithm)
    }

    /// `topology` (built from the objects of `kernel`, in any coordinates) with every box
    /// fitted to `kernel`'s primitives in the kernel's coordinates for `algorithm`: each child's
    /// box is the union of its primitives' boxes, grown and rounded outward as a fresh build's
    /// would be.
    pub(crate) fn fit(topology: &Topology, kernel: &Scene, algorithm: Algorithm) -> Bvh {
        let origin = kernel_origin(kernel, algorithm);
        let eye = length(kernel_frame(kernel, algorithm).eye);
        let mut bvh = topology.0.clone();
        if let Some(instanced) = bvh.instanced.take() {
            bvh.fit_instanced(&instanced, kernel, origin, eye);
            bvh.instanced = Some(instanced);
            return bvh;
        }
        let (spheres, triangles) = primitive_boxes(&kernel.objects, origin);
        let (spheres, triangles) = (grown(spheres, eye), grown(triangles, eye));
        let (sphere_order, triangle_order) = (&bvh.sphere_order, &bvh.triangle_order);
        let sphere = |k: usize| &spheres[sphere_order[k] as usize];
        let triangle = |k: usize| &triangles[triangle_order[k] as usize];
        fit_leaves(&mut bvh.nodes, sphere, triangle);
        fit_nodes(&mut bvh.nodes, |_| unreachable!("no instances"));
        bvh
    }

    /// [`Bvh::fit`] of a tree naming instances: the other objects' leaves fitted to their
    /// primitives in the kernel's coordinates (from `origin`, the eye `eye` from it), the
    /// meshes' to their triangles in the mesh's own, and each instance's child to its mesh's
    /// box moved to where it is placed.
    fn fit_instanced(
        &mut self,
        instanced: &Instanced,
        kernel: &Scene,
        origin: Vec3<f64>,
        eye: f64,
    ) {
        let spheres = (kernel.objects.iter()).filter(|o| matches!(o, Object::Sphere { .. }));
        let spheres = grown(primitive_boxes(spheres, origin).0, eye);
        let scene_triangles = crate::prepare::SceneTriangles::of(kernel, &instanced.firsts);
        let order = &self.triangle_order;
        let rest = (order[..instanced.rest_triangles as usize].iter())
            .map(|&k| triangle_box(scene_triangles.get(k).0, origin))
            .collect();
        let mut triangles = grown(rest, eye);
        for m in &instanced.meshes {
            let mesh = &kernel.instances[m.placement as usize].mesh;
            let span = &order[m.first as usize..(m.first + m.len) as usize];
            let boxes = (span.iter())
                .map(|&k| triangle_box(&mesh.triangles[k as usize], Vec3::splat(0.0)))
                .collect();
            triangles.extend(grown(boxes, 0.0));
        }
        let sphere_order = &self.sphere_order;
        let sphere = |k: usize| &spheres[sphere_order[k] as usize];
        fit_leaves(&mut self.nodes, sphere, |k| &triangles[k]);
        let placed = (instanced.boxes(kernel))
            .map(|(lo, hi)| (Vec3::from(lo) - origin, Vec3::from(hi) - origin))
            .collect();
        let placed = grown(placed, eye);
        let instance_box = |i: u32| {
            let mut b = Aabb::EMPTY;
            b.grow(placed[i as usize].lo, placed[i as usize].hi);
            b
        };
        fit_nodes(&mut self.nodes, instance_box);
    }

    /// The BVH over the boxes of each kind, whose objects (by the items' `index`) are
    /// `sphere_objects` and `triangle_objects`.
    fn from_boxes(
        mut spheres: Vec<Item>,
        mut triangles: Vec<Item>,
        sphere_objects: &[u32],
        triangle_objects: &[u32],
    ) -> Bvh {
        let (sphere_tree, triangle_tree) = rayon::join(
            || build_root(&mut spheres, SPHERE_TRAVERSAL_COST),
            || build_root(&mut triangles, TRAVERSAL_COST),
        );
        let sphere_kind = Kind {
            leaf: SPHERE_LEAF,
            items: &spheres,
            objects: sphere_objects,
        };
        let triangle_kind = Kind {
            leaf: 0,
            items: &triangles,
            objects: triangle_objects,
        };
        let mut nodes = Vec::new();
        match (sphere_tree, triangle_tree) {
            // One kind, in more than a leaf: its root is the tree's, flattened first. Under a
            // root of the two kinds every packet would first visit a node whose other child
            // is empty: a visit for nothing (docs/performance.md#bvh).
            (Some((b, t @ Tree::Inner(_))), None) => {
                flatten(b, &t, sphere_kind, &mut nodes);
            }
            (None, Some((b, t @ Tree::Inner(_)))) => {
                flatten(b, &t, triangle_kind, &mut nodes);
            }
            (sphere_tree, triangle_tree) => {
                nodes.push(BvhNode::zeroed());
                let mut child = |tree: Option<(Aabb, Tree)>, kind| match tree {
                    Some((b, t)) => flatten(b, &t, kind, &mut nodes),
                    None => Child {
                        lo: [0.0; 3],
                        hi: [0.0; 3],
                        reference: LEAF_BIT,
                        count: 0,
                    },
                };
                let c0 = child(sphere_tree, sphere_kind);
                let c1 = child(triangle_tree, triangle_kind);
                nodes[0] = BvhNode::new(c0, c1);
            }
        }
        Bvh {
            depth: depth_of(&nodes, 0),
            nodes,
            sphere_order: spheres.iter().map(|i| i.index).collect(),
            triangle_order: triangles.iter().map(|i| i.index).collect(),
            instanced: None,
        }
    }

    /// Bytes the BVH adds on the device: its nodes and one order entry per primitive.
    pub(crate) fn bytes(&self) -> usize {
        size_of_val(&self.nodes[..]) + 4 * (self.sphere_order.len() + self.triangle_order.len())
    }

    /// Entries a traversal stack needs for this tree (`BVH_STACK` in the kernel): its depth, at
    /// least, since at most one node per level above the one visited is waiting; rounded up to
    /// a multiple of 8, so that few kernels are compiled, and at most `MAX_DEPTH`.
    pub(crate) fn stack_entries(&self) -> u8 {
        stack_for_depth(self.depth())
    }

    /// The deepest leaf (root at depth 0); at most `MAX_DEPTH`.
    pub(crate) fn depth(&self) -> usize {
        self.depth
    }
}

/// How deep below `node` the deepest leaf lies (a leaf child: 1).
fn depth_of(nodes: &[BvhNode], node: usize) -> usize {
    (0..2)
        .map(|k| nodes[node].child(k))
        .map(|c| {
            if c.reference & LEAF_BIT != 0 {
                1
            } else {
                1 + depth_of(nodes, c.reference as usize)
            }
        })
        .max()
        .unwrap_or(0)
}

/// [`Bvh::stack_entries`] of a tree `depth` deep.
fn stack_for_depth(depth: usize) -> u8 {
    (depth.max(1).div_ceil(8) * 8).min(MAX_DEPTH) as u8
}

fn triangle_box(c: &crate::scene::Triangle, origin: Vec3<f64>) -> (Vec3<f64>, Vec3<f64>) {
    let [a, b, c] = c.map(|p| Vec3::from(p) - origin);
    let lo = Vec3::from_array([0, 1, 2].map(|k| a.get(k).min(b.get(k)).min(c.get(k))));
    let hi = Vec3::from_array([0, 1, 2].map(|k| a.get(k).max(b.get(k)).max(c.get(k))));
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::super::shared::{Shared, sharing};
    use super::*;

    fn items(n: usize) -> Vec<Item> {
        (0..n)
            .map(|k| {
                let x = (k as f64 * 0.618_033_988_7).fract() * 10.0;
                let y = (k as f64 * 0.414_213_562_4).fract() * 10.0;
                let lo = [x as f32, y as f32, 0.0];
                Item {
                    lo,
                    hi: lo.map(|c| c + 0.1),
                    index: k as u32,
                }
            })
            .collect()
    }

    /// Every primitive sits in exactly one leaf, inside every box on its path from the root
    /// (each child's box inside the box its parent was reached by, the primitive inside its
    /// leaf's), and a leaf names an object exactly when all its primitives are of it
    /// (`objects`: the triangles' objects by index).
    pub(super) fn check(bvh: &Bvh, boxes: &[Item], objects: &[u32]) {
        let inside = |lo: [f32; 3], hi: [f32; 3], outer: &Child| {
            (0..3).all(|a| outer.lo[a] <= lo[a] && hi[a] <= outer.hi[a])
        };
        let mut seen = vec![false; boxes.len()];
        let mut stack = vec![(0usize, 0usize, None::<Child>)];
        while let Some((node, depth, reached_by)) = stack.pop() {
            for k in 0..2 {
                let c = bvh.nodes[node].child(k);
                let empty = c.reference & LEAF_BIT != 0 && leaf_len(c.count) == 0;
                if let Some(parent) = &reached_by
                    && !empty
                {
                    assert!(inside(c.lo, c.hi, parent), "child box outside its parent's");
                }
                if c.reference & LEAF_BIT == 0 {
                    stack.push((c.reference as usize, depth + 1, Some(c)));
                    continue;
                }
                if c.count & SPHERE_LEAF != 0 || leaf_len(c.count) == 0 {
                    continue;
                }
                assert!(depth < MAX_DEPTH);
                let first = (c.reference & !LEAF_BIT) as usize;
                let range = first..first + leaf_len(c.count) as usize;
                let of = |p: usize| objects[bvh.triangle_order[p] as usize];
                match leaf_object(c.count) {
                    MIXED_OBJECTS => assert!(range.clone().any(|p| of(p) != of(first))),
                    object => assert!(range.clone().all(|p| of(p) == object)),
                }
                for p in range {
                    let original = bvh.triangle_order[p] as usize;
                    assert!(!seen[original]);
                    seen[original] = true;
                    let b = &boxes[original];
                    assert!(inside(b.lo, b.hi, &c));
                }
            }
        }
        assert!(seen.iter().all(|s| *s));
    }

    #[test]
    fn every_primitive_is_in_one_leaf_inside_its_boxes() {
        for n in [1, 2, 7, 100, 10_000] {
            let boxes = items(n);
            // Objects of 50 consecutive items: some leaves hold one object, some several.
            let objects: Vec<u32> = (0..n as u32).map(|k| k / 50).collect();
            let bvh = Bvh::from_boxes(Vec::new(), boxes.clone(), &[], &objects);
            check(&bvh, &boxes, &objects);
            assert_eq!(bvh.sphere_order.len(), 0);
        }
    }

    #[test]
    fn a_leaf_count_word_keeps_its_length_and_object() {
        for (kind, len, object) in [(0, 1, 0), (SPHERE_LEAF, 8, 12), (0, 15, MIXED_OBJECTS - 1)] {
            let word = leaf_word(kind, len, object);
            assert_eq!(
                (word & SPHERE_LEAF, leaf_len(word), leaf_object(word)),
                (kind, len as u32, object)
            );
        }
        // An id beyond the field, or more primitives than LEAF_COUNT (a leaf at MAX_DEPTH):
        // the objects are looked up.
        let word = leaf_word(0, 3, MIXED_OBJECTS + 5);
        assert_eq!((leaf_len(word), leaf_object(word)), (3, MIXED_OBJECTS));
        let word = leaf_word(SPHERE_LEAF, 5000, 2);
        assert_eq!(
            (word & SPHERE_LEAF, leaf_len(word), leaf_object(word)),
            (SPHERE_LEAF, 5000, MIXED_OBJECTS)
        );
    }

    #[test]
    fn every_depth_gets_a_stack_that_holds_it() {
        for depth in 0..=MAX_DEPTH {
            let stack = stack_for_depth(depth) as usize;
            assert!(
                stack >= depth && stack <= MAX_DEPTH && stack.is_multiple_of(8),
                "{depth}: {stack}"
            );
        }
    }

    #[test]
    fn identical_boxes_still_build_within_the_depth_limit() {
        let same: Vec<Item> = (0..5000)
            .map(|k| Item {
                lo: [1.0; 3],
                hi: [2.0; 3],
                index: k,
            })
            .collect();
        let objects = vec![7; same.len()];
        let bvh = Bvh::from_boxes(Vec::new(), same.clone(), &[], &objects);
        check(&bvh, &same, &objects);
        assert!(bvh.depth() <= MAX_DEPTH);
        assert!(bvh.stack_entries() as usize >= bvh.depth());
    }

    /// A scene of `spheres` spheres and a soup of `triangles` triangles.
    fn scene_of(spheres: usize, triangles: usize) -> Scene {
        let mut objects: Vec<String> = (0..spheres)
            .map(|k| format!(r#"{{"type": "sphere", "center": [{k}, 0, -5], "radius": 0.4}}"#))
            .collect();
        objects.push(r#"{"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}"#.into());
        if triangles > 0 {
            objects.push(r#"{"type": "soup", "obj": "m.obj"}"#.into());
        }
        let json = format!(
            r#"{{"camera": {{"eye": [0, 0, 1], "look": [0, 0, -1], "up": [0, 1, 0],
                "focal_length": 1, "width": 1.6, "height": 0.9}}, "objects": [{}]}}"#,
            objects.join(",")
        );
        let mesh: Vec<_> = (0..triangles)
            .map(|k| {
                let x = k as f64;
                [
                    glam::DVec3::new(x, 0.0, -6.0),
                    glam::DVec3::new(x + 0.5, 0.0, -6.0),
                    glam::DVec3::new(x, 0.5, -6.0),
                ]
            })
            .collect();
        Scene::from_json(&json, std::path::Path::new("s.json"), &mut |_, _| {
            Ok(crate::scene::MeshPart::whole(mesh.clone()))
        })
        .unwrap()
    }

    /// One topology fitted to cameras far apart: every child's box is exactly the union of its
    /// primitives' boxes as that camera's build grows them (so every primitive lies inside
    /// every box on its path), and the shape is the same at every camera.
    #[test]
    fn a_topology_fits_every_camera_exactly() {
        let mut scene = scene_of(40, 300);
        let topology = Topology::build(&scene);
        for eye in [[0.0, 0.0, 1.0], [120.0, -3.0, 7.5], [-1e6, 2e5, 3.0]] {
            scene.camera.eye = glam::DVec3::from_array(eye);
            let origin = kernel_origin(&scene, Algorithm::Robust);
            let far = length(kernel_frame(&scene, Algorithm::Robust).eye);
            let (spheres, triangles) = primitive_boxes(&scene.objects, origin);
            let (spheres, triangles) = (grown(spheres, far), grown(triangles, far));
            let bvh = Bvh::fit(&topology, &scene, Algorithm::Robust);
            assert_eq!(bvh.nodes.len(), topology.0.nodes.len());
            assert_eq!(bvh.triangle_order, topology.0.triangle_order);
            let objects = ObjectIds::of(&scene).triangles;
            check(&bvh, &triangles, &objects);
            // Tight: each child's box is the union of what lies below it.
            fn below(bvh: &Bvh, c: Child, items: [&[Item]; 2]) -> Aabb {
                if c.reference & LEAF_BIT == 0 {
                    let node = &bvh.nodes[c.reference as usize];
                    return below(bvh, node.child(0), items).union(below(
                        bvh,
                        node.child(1),
                        items,
                    ));
                }
                let first = (c.reference & !LEAF_BIT) as usize;
                let sphere = c.count & SPHERE_LEAF != 0;
                let order = if sphere {
                    &bvh.sphere_order
                } else {
                    &bvh.triangle_order
                };
                let mut b = Aabb::EMPTY;
                for &k in &order[first..first + leaf_len(c.count) as usize] {
                    let i = &items[sphere as usize][k as usize];
                    b.grow(i.lo, i.hi);
                }
                b
            }
            for node in &bvh.nodes {
                for k in 0..2 {
                    let c = node.child(k);
                    let b = below(&bvh, c, [&triangles, &spheres]);
                    assert_eq!((b.lo, b.hi), (c.lo, c.hi), "eye {eye:?}");
                }
            }
        }
    }

    /// Renders that share a topology build it once, and only for the objects it was shared
    /// for.
    #[test]
    fn shared_topologies_are_built_once_per_scene() {
        let scene = scene_of(40, 30);
        let other = scene_of(40, 30);
        let mut shared = Shared::default();
        let (a, b, c) = sharing(&scene, &mut shared, || {
            (
                Topology::of(&scene),
                Topology::of(&scene),
                Topology::of(&other),
            )
        });
        assert!(Arc::ptr_eq(&a, &b) && !Arc::ptr_eq(&a, &c));
        assert!(Arc::ptr_eq(shared.topology().unwrap(), &a));
        let again = sharing(&scene, &mut shared, || Topology::of(&scene));
        assert!(Arc::ptr_eq(&again, &a));
        assert!(!Arc::ptr_eq(&Topology::of(&scene), &a));
    }

    /// Each kind counts as a fraction of its own crossover; planes do not count.
    #[test]
    fn a_bvh_pays_from_each_kinds_crossover() {
        for (spheres, triangles, expected) in [
            (Search::SPHERE_CROSSOVER - 1, 0, false),
            (Search::SPHERE_CROSSOVER, 0, true),
            (0, Search::TRIANGLE_CROSSOVER - 1, false),
            (0, Search::TRIANGLE_CROSSOVER, true),
            (
                Search::SPHERE_CROSSOVER / 2,
                Search::TRIANGLE_CROSSOVER / 2,
                true,
            ),
            (
                Search::SPHERE_CROSSOVER / 2,
                Search::TRIANGLE_CROSSOVER / 2 - 1,
                false,
            ),
        ] {
            let scene = scene_of(spheres, triangles);
            assert_eq!(
                worth_it(&scene),
                expected,
                "{spheres} spheres, {triangles} triangles"
            );
            assert_eq!(Search::Auto.uses_bvh(&scene), expected);
        }
    }

    #[test]
    fn outward_rounding_contains_the_f64_value() {
        for x in [0.1, -0.1, 1e-30, -3.3e7, 1.0 / 3.0] {
            assert!((round_down(x) as f64) <= x && x <= round_up(x) as f64);
            assert!(round_up(x).next_down() as f64 <= x);
        }
    }
}
