//! Mirror of shaders/traverse.wgsl (what the traversals share) and traverse_ray.wgsl (the
//! traversal ray by ray): the nearest hit over the spheres and triangles through the BVH built by
//! src/prepare/bvh.rs; and, for tests, of the packets' intervals (traverse_lanes.wgsl).

use super::hit::{Hit, KIND_SPHERE, KIND_TRIANGLE, NO_INSTANCE};
use super::sphere::intersect_sphere;
use super::triangle::intersect_triangle;
use crate::kernel::types::{Ray, Shear, instance_ray, no_hit, shear_of, t_far};
use crate::math::{Real, Vec3};
use crate::prepare::Primitives;
use crate::prepare::bvh::{
    BvhNode, INSTANCE_BIT, LEAF_BIT, MAX_DEPTH, MIXED_OBJECTS, SPHERE_LEAF, leaf_len, leaf_object,
    leaf_word,
};

/// The traversal stack's size (`BVH_STACK` in WGSL).
pub(crate) const BVH_STACK: usize = MAX_DEPTH;

/// Relative widening of every slab interval (2^-16): see shaders/traverse.wgsl.
pub(crate) fn box_slack<T: Real>() -> T {
    T::from_f64(1.0 / 65536.0)
}

/// Whether a direction component is zero, and the inverse of the nonzero ones.
pub(crate) struct RayInverse<T> {
    pub axis_parallel: bool,
    pub inv: Vec3<T>,
}

pub(crate) fn ray_inverse<T: Real>(ray: &Ray<T>) -> RayInverse<T> {
    let zero = direction_zero(ray);
    let d = ray.direction.to_array();
    let inv = [0, 1, 2].map(|k| T::ONE / if zero[k] { T::ONE } else { d[k] });
    RayInverse {
        axis_parallel: zero.iter().any(|&z| z),
        inv: Vec3::from_array(inv),
    }
}

/// Which of the ray's direction components are zero.
fn direction_zero<T: Real>(ray: &Ray<T>) -> [bool; 3] {
    ray.direction.to_array().map(|x| x == T::ZERO)
}

/// The smaller of a and b, as WGSL's `smaller` selects it.
fn smaller<T: Real>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The larger of a and b, as WGSL's `larger` selects it.
fn larger<T: Real>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// `BOX_ENTRY_SHRINK`: 1 - 2^-15.
fn box_entry_shrink<T: Real>() -> T {
    T::ONE - T::from_f64(2.0) * box_slack::<T>()
}

/// Where the ray enters the box (shrunk by `BOX_ENTRY_SHRINK`, at least `min_t`), or NO_HIT
/// when it misses the box, leaves it before `min_t`, or enters it beyond `t_max`.
pub(crate) fn box_entry<T: Real>(
    lo: [f32; 3],
    hi: [f32; 3],
    ray: &Ray<T>,
    ri: &RayInverse<T>,
    min_t: T,
    t_max: T,
) -> T {
    let lo_r = lo.map(|x| T::from_f64(x as f64));
    let hi_r = hi.map(|x| T::from_f64(x as f64));
    let o = ray.origin.to_array();
    let inv = ri.inv.to_array();
    let a = [0, 1, 2].map(|k| (lo_r[k] - o[k]) * inv[k]);
    let b = [0, 1, 2].map(|k| (hi_r[k] - o[k]) * inv[k]);
    if ri.axis_parallel {
        let inside = [0, 1, 2].map(|k| lo_r[k] <= o[k] && o[k] <= hi_r[k]);
        return box_entry_axis_parallel(a, b, inside, direction_zero(ray), min_t, t_max);
    }
    let enter = [0, 1, 2].map(|k| smaller(a[k], b[k]));
    let leave = [0, 1, 2].map(|k| larger(a[k], b[k]));
    let t_in = larger(larger(enter[0], enter[1]), larger(enter[2], min_t)) * box_entry_shrink();
    let t_out = smaller(smaller(leave[0], leave[1]), smaller(leave[2], t_max));
    if t_in <= t_out { t_in } else { no_hit() }
}

/// `box_entry` for a ray with a zero direction component (`zero`): that slab holds the whole ray
/// (where the origin is `inside` it) or none of it. `a` and `b` are the distances to the box's
/// planes, `box_entry`'s. Each slab interval is widened by the slack; the entry is 0 if the ray
/// starts inside.
fn box_entry_axis_parallel<T: Real>(
    a: [T; 3],
    b: [T; 3],
    inside: [bool; 3],
    zero: [bool; 3],
    min_t: T,
    t_max: T,
) -> T {
    let mut t0 = [T::ZERO; 3];
    let mut t1 = [T::ZERO; 3];
    for k in 0..3 {
        let open = if inside[k] {
            -t_far::<T>()
        } else {
            t_far::<T>()
        };
        (t0[k], t1[k]) = if zero[k] {
            (open, -open)
        } else {
            (a[k].min(b[k]), a[k].max(b[k]))
        };
    }
    let mut t_in = t0[0].max(t0[1].max(t0[2]));
    let mut t_out = t1[0].min(t1[1].min(t1[2]));
    t_in = t_in - box_slack::<T>() * t_in.abs();
    t_out = t_out + box_slack::<T>() * t_out.abs();
    if t_in <= t_out && t_out >= min_t && t_in <= t_max {
        return t_in.max(T::ZERO);
    }
    no_hit()
}

/// A packet's rays as intervals, componentwise (`PacketInterval` in WGSL): every ray's origin
/// lies in `[origin_lo, origin_hi]` and its inverse direction in `[inverse_lo, inverse_hi]`, as
/// f32 bounds; `unbounded` where some ray has a zero direction component or coordinates beyond
/// `INTERVAL_LIMIT` (such a packet tests boxes per ray, not by `interval_entry`).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct PacketInterval {
    pub origin_lo: [f32; 3],
    pub origin_hi: [f32; 3],
    pub inverse_lo: [f32; 3],
    pub inverse_hi: [f32; 3],
    pub unbounded: bool,
}

/// `INTERVAL_LIMIT`: 1e30.
#[cfg(test)]
fn interval_limit<T: Real>() -> T {
    T::from_f64(1e30)
}

/// f32 bounds of a real below and above it (`f32_below`, `f32_above`): itself in f32; in f64
/// its nearest f32 moved outward by 2^-22 of itself and 1e-37 where it is beyond.
#[cfg(test)]
fn f32_below<T: Real>(x: T) -> f32 {
    let y = x.to_f64() as f32;
    if (y as f64) > x.to_f64() {
        y - y.abs() * 2.384_185_8e-7 - 1e-37
    } else {
        y
    }
}

#[cfg(test)]
fn f32_above<T: Real>(x: T) -> f32 {
    let y = x.to_f64() as f32;
    if (y as f64) < x.to_f64() {
        y + y.abs() * 2.384_185_8e-7 + 1e-37
    } else {
        y
    }
}

/// The interval of one ray (`ray_interval`).
#[cfg(test)]
pub(crate) fn ray_interval<T: Real>(ray: &Ray<T>, ri: &RayInverse<T>) -> PacketInterval {
    let o = ray.origin.to_array();
    let inv = ri.inv.to_array();
    let limit = interval_limit::<T>();
    let wild = ri.axis_parallel
        || inv.iter().any(|x| x.abs() > limit)
        || o.iter().any(|x| x.abs() > limit);
    PacketInterval {
        origin_lo: o.map(f32_below),
        origin_hi: o.map(f32_above),
        inverse_lo: inv.map(f32_below),
        inverse_hi: inv.map(f32_above),
        unbounded: wild,
    }
}

/// The smallest interval holding both (`join_intervals`).
#[cfg(test)]
pub(crate) fn join_intervals(a: &PacketInterval, b: &PacketInterval) -> PacketInterval {
    let lo = |x: [f32; 3], y: [f32; 3]| [0, 1, 2].map(|k| x[k].min(y[k]));
    let hi = |x: [f32; 3], y: [f32; 3]| [0, 1, 2].map(|k| x[k].max(y[k]));
    PacketInterval {
        origin_lo: lo(a.origin_lo, b.origin_lo),
        origin_hi: hi(a.origin_hi, b.origin_hi),
        inverse_lo: lo(a.inverse_lo, b.inverse_lo),
        inverse_hi: hi(a.inverse_hi, b.inverse_hi),
        unbounded: a.unbounded || b.unbounded,
    }
}

/// `box_entry` for a whole packet: where its rays enter the box at the earliest, or NO_HIT
/// when `box_entry` is NO_HIT for every ray whose `t_max` is at most `t_max`. The bounds are
/// exact (see shaders/traverse_lanes.wgsl): each slab distance is monotonic in the origin and the
/// inverse, so the corners of the intervals bound it.
#[cfg(test)]
pub(crate) fn interval_entry<T: Real>(
    lo: [f32; 3],
    hi: [f32; 3],
    packet: &PacketInterval,
    min_t: T,
    t_max: T,
) -> T {
    let r = |v: [f32; 3]| v.map(|x| T::from_f64(x as f64));
    let (o_lo, o_hi) = (r(packet.origin_lo), r(packet.origin_hi));
    let (i_lo, i_hi) = (r(packet.inverse_lo), r(packet.inverse_hi));
    let (lo_r, hi_r) = (r(lo), r(hi));
    let mut near = [T::ZERO; 3];
    let mut far = [T::ZERO; 3];
    for k in 0..3 {
        let (a_lo, a_hi) = (lo_r[k] - o_hi[k], lo_r[k] - o_lo[k]);
        let (b_lo, b_hi) = (hi_r[k] - o_hi[k], hi_r[k] - o_lo[k]);
        let a = [
            a_lo * i_lo[k],
            a_lo * i_hi[k],
            a_hi * i_lo[k],
            a_hi * i_hi[k],
        ];
        let b = [
            b_lo * i_lo[k],
            b_lo * i_hi[k],
            b_hi * i_lo[k],
            b_hi * i_hi[k],
        ];
        near[k] = smaller(
            smaller(smaller(a[0], a[1]), smaller(a[2], a[3])),
            smaller(smaller(b[0], b[1]), smaller(b[2], b[3])),
        );
        far[k] = larger(
            larger(larger(a[0], a[1]), larger(a[2], a[3])),
            larger(larger(b[0], b[1]), larger(b[2], b[3])),
        );
    }
    let t_in = larger(larger(near[0], near[1]), larger(near[2], min_t)) * box_entry_shrink();
    let t_out = smaller(smaller(far[0], far[1]), smaller(far[2], t_max));
    if t_in <= t_out { t_in } else { no_hit() }
}

/// `is_closer` for a primitive stored at `index` in BVH order: ties within one object go to
/// the lower index in the scene's order (`key` gives it), as in brute force.
fn is_closer_ordered<T: Real>(
    t: T,
    object: u32,
    index: u32,
    key: impl Fn(u32) -> u32,
    best: &Hit<T>,
) -> bool {
    if t == no_hit() {
        return false;
    }
    if best.object < 0 || t < best.t {
        return true;
    }
    if t != best.t {
        return false;
    }
    if object as i32 != best.object {
        return (object as i32) < best.object;
    }
    key(index) < key(best.index)
}

/// The object of primitive `index` of a kind (`objects`: the kind's object ids): the leaf's,
/// `leaf`, where all its primitives have one ([`leaf_object`]).
fn object_of(leaf: u32, index: u32, objects: &[u32]) -> u32 {
    match leaf {
        MIXED_OBJECTS => objects[index as usize],
        object => object,
    }
}

/// Keeps primitive `index` of a kind as the nearest hit if its `t` is closer (`leaf`: its
/// leaf's object, `objects` and `key` are the kind's object ids and scene-order keys).
pub(crate) fn keep_ordered<T: Real>(
    t: T,
    kind: u32,
    index: u32,
    leaf: u32,
    objects: &[u32],
    key: impl Fn(u32) -> u32,
    best: &mut Hit<T>,
) {
    if t != no_hit() {
        let object = object_of(leaf, index, objects);
        if is_closer_ordered(t, object, index, key, best) {
            *best = Hit {
                t,
                object: object as i32,
                kind,
                index,
                instance: NO_INSTANCE,
            };
        }
    }
}

/// Tests primitive `k` of a leaf whose count word is `count` (its kind and object).
pub(crate) fn intersect_primitive<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    min_t: T,
    prims: &Primitives<T>,
    k: u32,
    count: u32,
    best: &mut Hit<T>,
) {
    let leaf = leaf_object(count);
    if count & SPHERE_LEAF != 0 {
        let t = intersect_sphere::<T, ROBUST>(ray, &prims.spheres[k as usize], min_t);
        let key = |i| prims.sphere_key(i);
        keep_ordered(t, KIND_SPHERE, k, leaf, &prims.sphere_objects, key, best);
    } else {
        let tri = &prims.triangles[k as usize];
        let t = intersect_triangle::<T, ROBUST>(ray, shear, tri, min_t);
        let key = |i| prims.triangle_key(i);
        keep_ordered(
            t,
            KIND_TRIANGLE,
            k,
            leaf,
            &prims.triangle_objects,
            key,
            best,
        );
    }
}

/// The farthest a box may start and still be searched (`cull_t` in WGSL, whose certainty pass
/// searches further; the CPU has no certainty pass).
pub(crate) fn cull_t<T: Real>(best: &Hit<T>) -> T {
    best.t
}

/// A node as the traversal sees it: where the ray enters each child's box (NO_HIT when it
/// misses) and where the children are.
pub(crate) struct Visit<T> {
    pub t0: T,
    pub t1: T,
    pub reference0: u32,
    pub count0: u32,
    pub reference1: u32,
    pub count1: u32,
}

/// Reads node `node` and tests the ray against both boxes.
pub(crate) fn visit<T: Real>(
    nodes: &[BvhNode],
    node: u32,
    ray: &Ray<T>,
    ri: &RayInverse<T>,
    min_t: T,
    t_max: T,
) -> Visit<T> {
    let n = &nodes[node as usize];
    Visit {
        t0: box_entry(n.lo0, n.hi0, ray, ri, min_t, t_max),
        t1: box_entry(n.lo1, n.hi1, ray, ri, min_t, t_max),
        reference0: n.reference0,
        count0: n.count0,
        reference1: n.reference1,
        count1: n.count1,
    }
}

/// Ordered traversal: of two children hit, leaves are tested and the nearer inner node is
/// visited first, the farther one waiting on a short stack with its entry distance, skipped
/// when popped if a hit nearer than that entry has been found. Two loops as in WGSL (nodes
/// until one has a leaf the ray enters, then its leaves): the same nodes and primitives, in
/// the same order, as one loop doing both.
pub(crate) fn traverse_bvh<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    nodes: &[BvhNode],
    best: &mut Hit<T>,
) {
    traverse_bvh_traced::<T, ROBUST>(ray, min_t, prims, nodes, best, &mut ());
}

/// What a traversal did, step by step, for the GPU cost model (feature `model`): the nodes it
/// visited and the leaves whose primitives it tested, with how many lanes (rays) wanted each.
/// `()` records nothing, so the traversal without a trail compiles to the same code.
pub(crate) trait Trail {
    /// Node `node` visited, wanted by `lanes` rays.
    fn node(&mut self, _node: u32, _lanes: u32) {}
    /// The `n` primitives from `first` of child `child`'s leaf (count word `count`) tested,
    /// wanted by `lanes` rays.
    fn leaf(&mut self, _child: usize, _first: u32, _count: u32, _lanes: u32) {}
}

impl Trail for () {}

/// [`traverse_bvh`], telling `trail` each node visited and each leaf tested.
pub(crate) fn traverse_bvh_traced<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    nodes: &[BvhNode],
    best: &mut Hit<T>,
    trail: &mut impl Trail,
) {
    let world = ray;
    let mut ray = *world;
    let mut ri = ray_inverse(&ray);
    let mut shear = shear_of(ray.direction);
    let mut stack = Stack {
        node: [0u32; BVH_STACK],
        t: [T::ZERO; BVH_STACK],
        sp: 0,
    };
    let mut node = 0u32;
    let mut inside = Inside::default();
    loop {
        let (n, run) = loop {
            // Back in the world where a node waiting from before the instance is popped; into an
            // instance's mesh where a reference names one (INSTANCE_BIT).
            if inside.instance != NO_INSTANCE && stack.sp < inside.sp {
                (ray, inside.instance) = (*world, NO_INSTANCE);
                (ri, shear) = (ray_inverse(&ray), shear_of(ray.direction));
            }
            if node & INSTANCE_BIT != 0 {
                let k = node & !INSTANCE_BIT;
                let instance = &prims.instances[k as usize];
                ray = instance_ray(world, instance);
                (ri, shear) = (ray_inverse(&ray), shear_of(ray.direction));
                inside = Inside {
                    instance: k,
                    object: instance.object,
                    sp: stack.sp,
                };
                node = instance.root;
            }
            trail.node(node, 1);
            let n = visit(nodes, node, &ray, &ri, min_t, cull_t(best));
            let run = leaf_run(
                &n,
                n.t0 != no_hit() && is_leaf(n.reference0),
                n.t1 != no_hit() && is_leaf(n.reference1),
            );
            if run.length != 0 || !next_node(&n, best, &mut stack, &mut node) {
                break (n, run);
            }
        };
        if run.length == 0 {
            break;
        }
        if run.length0 != 0 {
            trail.leaf(0, run.from0, n.count0, 1);
        }
        if run.length != run.length0 {
            trail.leaf(1, n.reference1 & !LEAF_BIT, n.count1, 1);
        }
        for i in 0..run.length {
            let count = if in_leaf1(&run, i) {
                n.count1
            } else {
                n.count0
            };
            intersect_primitive::<T, ROBUST>(
                &ray,
                &shear,
                min_t,
                prims,
                run_primitive(&run, i),
                inside.count(count),
                best,
            );
        }
        // Each instance is one object: a nearest hit of its object is in its mesh.
        if inside.instance != NO_INSTANCE && best.object == inside.object as i32 {
            best.instance = inside.instance;
        }
        if !next_node(&n, best, &mut stack, &mut node) {
            break;
        }
    }
}

/// The instance a traversal is in (`instance`, [`NO_INSTANCE`] in the world), its object, and
/// the stack's depth when it entered: nodes waiting below it are the world's.
struct Inside {
    instance: u32,
    object: u32,
    sp: usize,
}

impl Default for Inside {
    fn default() -> Inside {
        Inside {
            instance: NO_INSTANCE,
            object: 0,
            sp: 0,
        }
    }
}

impl Inside {
    /// A leaf's `count` as the traversal takes it: in an instance, its primitives the
    /// instance's object (a mesh's leaves name object 0, whichever instance places them; no
    /// tree names instances of a mesh with a [`MANY_LEAF`](crate::prepare::bvh::MANY_LEAF)).
    fn count(&self, count: u32) -> u32 {
        match self.instance {
            NO_INSTANCE => count,
            _ => leaf_word(count & SPHERE_LEAF, leaf_len(count) as usize, self.object),
        }
    }
}

/// The traversal's stack of waiting nodes and their entry distances (`stack_node`, `stack_t`
/// and `sp` in WGSL).
struct Stack<T> {
    node: [u32; BVH_STACK],
    t: [T; BVH_STACK],
    sp: usize,
}

/// Where a ray goes after visiting `n` and testing its leaves (`next_node` in WGSL): to the
/// inner child it enters before `best`, the nearer where both (the other pushed), else to the
/// next waiting node it may still reach. Sets `node`; false when no node is left.
fn next_node<T: Real>(n: &Visit<T>, best: &Hit<T>, stack: &mut Stack<T>, node: &mut u32) -> bool {
    let go0 = n.t0 != no_hit() && !is_leaf(n.reference0) && n.t0 <= cull_t(best);
    let go1 = n.t1 != no_hit() && !is_leaf(n.reference1) && n.t1 <= cull_t(best);
    if go0 && go1 {
        let first0 = n.t0 <= n.t1;
        stack.node[stack.sp] = if first0 { n.reference1 } else { n.reference0 };
        stack.t[stack.sp] = if first0 { n.t1 } else { n.t0 };
        stack.sp += 1;
        *node = if first0 { n.reference0 } else { n.reference1 };
        return true;
    }
    if go0 || go1 {
        *node = if go0 { n.reference0 } else { n.reference1 };
        return true;
    }
    while stack.sp > 0 {
        stack.sp -= 1;
        if stack.t[stack.sp] <= cull_t(best) {
            *node = stack.node[stack.sp];
            return true;
        }
    }
    false
}

/// Whether a child reference is a leaf's rather than a node's (`is_leaf`).
pub(crate) fn is_leaf(reference: u32) -> bool {
    reference & LEAF_BIT != 0
}

/// The primitives of the leaf children tested after a visit, leaf 0's then leaf 1's, as one
/// run (`LeafRun` in WGSL).
pub(crate) struct LeafRun {
    pub length0: u32,
    pub length: u32,
    pub from0: u32,
    pub from1: u32,
}

/// Whether primitive `i` of `run` is leaf 1's (`in_leaf1`).
pub(crate) fn in_leaf1(run: &LeafRun, i: u32) -> bool {
    i >= run.length0
}

/// The index of primitive `i` of `run` (`run_primitive`).
pub(crate) fn run_primitive(run: &LeafRun, i: u32) -> u32 {
    (if in_leaf1(run, i) {
        run.from1
    } else {
        run.from0
    })
    .wrapping_add(i)
}

/// The run of the leaves `take0` and `take1` of `n` (`leaf_run`).
pub(crate) fn leaf_run<T>(n: &Visit<T>, take0: bool, take1: bool) -> LeafRun {
    let length0 = if take0 { leaf_len(n.count0) } else { 0 };
    let length1 = if take1 { leaf_len(n.count1) } else { 0 };
    LeafRun {
        length0,
        length: length0 + length1,
        from0: n.reference0 & !LEAF_BIT,
        from1: (n.reference1 & !LEAF_BIT).wrapping_sub(length0),
    }
}
