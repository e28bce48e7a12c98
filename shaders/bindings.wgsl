// Resources of the ray-casting kernel. Keep the structs in sync with src/gpu/layout.rs; the
// host binds its buffers by these names (src/gpu/dispatch.rs), so binding numbers need only be
// distinct. Offsets are f32 / f64.
#import types

struct Params {
    frame: Frame,         // offset 0
    projection: u32,      // offset 64 / 128
    nx: u32,              // offset 68 / 132: image width in pixels
    ny: u32,              // offset 72 / 136: image height in pixels
    row_offset: u32,      // offset 76 / 140: first image row of this dispatch (tiles of rows)
    tile_rows: u32,       // offset 80 / 144: rows of this dispatch (PIXEL_LIST, RAY_LIST: pixels
                          //   or rays listed)
    sphere_count: u32,    // offset 84 / 148
    plane_count: u32,     // offset 88 / 152
    triangle_count: u32,  // offset 92 / 156
    origin: vec3<real>,   // offset 96 / 160: the kernel's origin in world coordinates (the eye
                          //   in the robust set, else 0); shade hooks add it back
    unit: real,           // offset 108 / 184: world units per kernel unit, a power of two (the
                          //   kernel sees the scene scaled by 1 / unit, src/prepare/mod.rs)
    max_t: real,          // offset 112 / 192: OCCLUDED: the farthest t that occludes
}                         // size 128 / 224

@group(0) @binding(0) var<uniform> params: Params;
// Only the primitive kinds a scene has are compiled in (SPHERES, PLANES, TRIANGLES).
#if SPHERES
// Spheres as vec4s (Sphere's layout: the centre in xyz, the radius in w), so that a subgroup can
// load one a component per lane (shared_sphere in traverse_packet.wgsl).
@group(0) @binding(1) var<storage, read> spheres: array<vec4<real>>;

// Sphere k.
fn sphere_at(k: u32) -> Sphere {
    let v = spheres[k];
    return Sphere(v.xyz, v.w);
}
#endif
#if PLANES
@group(0) @binding(2) var<storage, read> planes: array<Plane>;

// How many planes there are: where the kernel is compiled for their number, a constant, so
// that lavapipe unrolls the loops over them and loads each at a constant offset, one scalar
// load, instead of a loop over the lanes (Variant::planes).
fn plane_count() -> u32 {
#if CONSTANT_PLANES
    return PLANE_COUNT;
#else
    return params.plane_count;
#endif
}
#endif
#if TRIANGLES
// Triangles are stored packed, 9 reals and one of padding each (StoredTriangle's layout, 40
// bytes in f32 instead of the 48 of three padded vec3), bound as pairs of reals: a triangle
// is five pairs, and llvmpipe loads a pair per lane in one loop over the lanes where two
// reals are two loops (a subgroup loads a triangle a pair per lane: shared_triangle). Meshes
// larger than one storage binding are split in chunks of 2^CHUNK_BITS triangles (CHUNK_BITS
// from the precision module), bound as triangles, triangles_2, ... (CHUNKS_2..4).
// With WIDE_TRIANGLES (f32, Variant::wide_loads) they are bound as 16-byte elements instead,
// and a triangle's 40 bytes are read as the three elements they start in: three loops of
// loads instead of five (each buffer is padded to 16 bytes for the last one).
#if WIDE_TRIANGLES
alias TriangleElement = vec2<u64>;
#else
alias TriangleElement = vec2<real>;
#endif
@group(0) @binding(3) var<storage, read> triangles: array<TriangleElement>;
#if CHUNKS_2
@group(0) @binding(11) var<storage, read> triangles_2: array<TriangleElement>;
#endif
#if CHUNKS_3
@group(0) @binding(12) var<storage, read> triangles_3: array<TriangleElement>;
#endif
#if CHUNKS_4
@group(0) @binding(13) var<storage, read> triangles_4: array<TriangleElement>;
#endif

// Element e of triangle k's, counted from the element it starts in, from the chunk it lies in.
fn triangle_element(k: u32, e: u32) -> TriangleElement {
#if CHUNKS_2
    let i = triangle_start(k & ((1u << CHUNK_BITS) - 1u)) + e;
    switch (k >> CHUNK_BITS) {
        case 1u: {
            return triangles_2[i];
        }
#if CHUNKS_3
        case 2u: {
            return triangles_3[i];
        }
#endif
#if CHUNKS_4
        case 3u: {
            return triangles_4[i];
        }
#endif
        default: {
            return triangles[i];
        }
    }
#else
    return triangles[triangle_start(k) + e];
#endif
}

// The element triangle k (of its chunk) starts in: five pairs of reals a triangle, or with
// WIDE_TRIANGLES two and a half 16-byte elements (an odd triangle starts half-way into one).
fn triangle_start(k: u32) -> u32 {
#if WIDE_TRIANGLES
    return 5u * k / 2u;
#else
    return 5u * k;
#endif
}

// The triangle whose reals are the pairs p0 to p4 (the fifth's second is padding).
fn triangle_of_pairs(p0: vec2<real>, p1: vec2<real>, p2: vec2<real>, p3: vec2<real>, p4: vec2<real>) -> Triangle {
    return Triangle(vec3<real>(p0, p1.x), vec3<real>(p1.y, p2), vec3<real>(p3, p4.x));
}
#if WIDE_TRIANGLES

// The pair of f32 in a 64-bit word (the first in its low half, as stored).
fn pair_of_word(x: u64) -> vec2<real> {
    return bitcast<vec2<f32>>(vec2<u32>(u32(x), u32(x >> 32u)));
}

// Triangle k: its five pairs, from the word its element starts with (even k) or the next.
fn triangle_at(k: u32) -> Triangle {
    let a = triangle_element(k, 0u);
    let b = triangle_element(k, 1u);
    let c = triangle_element(k, 2u);
    let odd = (k & 1u) != 0u;
    return triangle_of_pairs(pair_of_word(select(a.x, a.y, odd)), pair_of_word(select(a.y, b.x, odd)), pair_of_word(select(b.x, b.y, odd)), pair_of_word(select(b.y, c.x, odd)), pair_of_word(select(c.x, c.y, odd)));
}
#else

// Pair p (0 to 4) of triangle k's reals: real w is corner w / 3, coordinate w % 3.
fn triangle_pair(k: u32, p: u32) -> vec2<real> {
    return triangle_element(k, p);
}

// Triangle k.
fn triangle_at(k: u32) -> Triangle {
    return triangle_of_pairs(triangle_pair(k, 0u), triangle_pair(k, 1u), triangle_pair(k, 2u), triangle_pair(k, 3u), triangle_pair(k, 4u));
}
#endif
#endif
// Object id of every primitive: spheres first, then planes, then triangles (bound whenever
// the scene has any primitive).
@group(0) @binding(4) var<storage, read> objects: array<u32>;
// Outputs are bound only when the variant writes them (SURFACE, DISTANCE_ALONE, ID).
#if SURFACE
// Per pixel of the tile: normal in xyz, distance in w (0 on a miss, and where not asked for).
@group(0) @binding(5) var<storage, read_write> out_surface: array<vec4<real>>;
#endif
#if DISTANCE_ALONE
// Per pixel of the tile, where the distance is asked for without the normal: the distance (0 on
// a miss), a quarter of the surface's bytes to read back.
@group(0) @binding(27) var<storage, read_write> out_distance: array<real>;
#endif
#if ID
// Per pixel of the tile: object id, -1 on a miss.
@group(0) @binding(6) var<storage, read_write> out_id: array<i32>;
#endif
#if RAY_LIST
#if !COUNT
#if !OCCLUDED
// Per ray: the hit primitive's index among the primitives of its kind in the scene's order, and
// its barycentric (u, v) (0 on a miss, and for spheres and planes).
@group(0) @binding(19) var<storage, read_write> out_primitive: array<u32>;
@group(0) @binding(20) var<storage, read_write> out_uv: array<vec2<real>>;
#endif
#endif
#if OCCLUDED
// Per ray: 1 if it hits anything with min_t <= t <= max_t, else 0 (OCCLUDED).
@group(0) @binding(26) var<storage, read_write> out_occluded: array<u32>;
#endif
#if COUNT
// Per ray: how many times it crosses a surface (COUNT).
@group(0) @binding(21) var<storage, read_write> out_count: array<u32>;
#endif
#endif
#if CERTAINTY
// Per pixel of the tile: 1 if its hit/miss and id decisions are certain, else 0.
@group(0) @binding(7) var<storage, read_write> out_certain: array<u32>;
#endif
#if RAY_LIST
// The caller's rays, in kernel coordinates (measured from params.origin and scaled by
// 1 / params.unit on the host: Prepared::kernel_ray); params.tile_rows holds how many there are,
// and hits count from params.frame.min_t (in units of each ray's direction, which the scaling
// keeps).
@group(0) @binding(18) var<storage, read> ray_list: array<StoredRay>;

// The origin of every listed ray where they share one (LIST_ORIGIN: the host checked that each
// is the first one's), read from the first ray at a constant index: one load, not one a ray,
// and one value, so that the compiler computes `p - ray.origin` once for a lane's rays and a
// packet's interval of origins is a point (traverse_bvh_lanes).
fn listed_origin() -> vec3<real> {
    return ray_list[0].origin;
}

// A stored ray as the kernel casts it.
fn stored_ray(stored: StoredRay) -> Ray {
#if LIST_ORIGIN
    return Ray(listed_origin(), stored.direction);
#else
    return Ray(stored.origin, stored.direction);
#endif
}
#endif
#if BVH
// The BVH over spheres and triangles (src/prepare/bvh.rs): 64-byte nodes in chunks of
// 2^CHUNK_BITS nodes like the triangles, bound as NODE_ELEMENTS elements a node. A packet's lane
// l loads element l of a node it visits (visit_shared), as a vec2<u32>: one load a lane, where
// llvmpipe runs each storage load of a per-lane offset as a loop over the lanes, so two u32
// would be two loops (docs/performance.md#why-packets-share-fetches-by-hand).
// Elsewhere a vec4<u32> per lane, four loads a node, or with WIDE_LOADS (Variant::wide_loads)
// a vec4<u64>, two.
#if PACKETS
alias NodeElement = vec2<u32>;
const NODE_ELEMENTS: u32 = 8u;
#else
#if WIDE_LOADS
alias NodeElement = vec4<u64>;
const NODE_ELEMENTS: u32 = 2u;
#else
alias NodeElement = vec4<u32>;
const NODE_ELEMENTS: u32 = 4u;
#endif
#endif
@group(0) @binding(9) var<storage, read> bvh_nodes: array<NodeElement>;
#if CHUNKS_2
@group(0) @binding(14) var<storage, read> bvh_nodes_2: array<NodeElement>;
#endif
#if CHUNKS_3
@group(0) @binding(15) var<storage, read> bvh_nodes_3: array<NodeElement>;
#endif
#if CHUNKS_4
@group(0) @binding(16) var<storage, read> bvh_nodes_4: array<NodeElement>;
#endif
// Per primitive, in the order of `objects`: its index in the scene's own order (ties).
@group(0) @binding(10) var<storage, read> prim_order: array<u32>;
#if INSTANCES
// The instances the tree names (INSTANCE_BIT, src/prepare/bvh.rs; #64): three rows each of the
// map into its mesh's coordinates, and its mesh's root node and its object.
@group(0) @binding(28) var<storage, read> instance_transforms: array<vec4<real>>;
@group(0) @binding(29) var<storage, read> instance_words: array<vec2<u32>>;

fn instance_at(k: u32) -> Instance {
    let words = instance_words[k];
    return Instance(instance_transforms[3u * k], instance_transforms[3u * k + 1u], instance_transforms[3u * k + 2u], words.x, words.y);
}
#endif

// Element e (0 to NODE_ELEMENTS - 1) of node `node`, from the chunk it lies in.
fn node_element(node: u32, e: u32) -> NodeElement {
#if CHUNKS_2
    let i = NODE_ELEMENTS * (node & ((1u << CHUNK_BITS) - 1u)) + e;
    switch (node >> CHUNK_BITS) {
        case 1u: {
            return bvh_nodes_2[i];
        }
#if CHUNKS_3
        case 2u: {
            return bvh_nodes_3[i];
        }
#endif
#if CHUNKS_4
        case 3u: {
            return bvh_nodes_4[i];
        }
#endif
        default: {
            return bvh_nodes[i];
        }
    }
#else
    return bvh_nodes[NODE_ELEMENTS * node + e];
#endif
}

// A node's sixteen words as four parts: q0 and q2 hold the children's boxes' lower corners
// and their references, q1 and q3 the upper corners and leaf counts (src/prepare/bvh.rs).
struct NodeWords {
    q0: vec4<u32>,
    q1: vec4<u32>,
    q2: vec4<u32>,
    q3: vec4<u32>,
}

// Node `node`, loaded by this lane alone.
fn node_words(node: u32) -> NodeWords {
#if PACKETS
    let e = array(node_element(node, 0u), node_element(node, 1u), node_element(node, 2u), node_element(node, 3u), node_element(node, 4u), node_element(node, 5u), node_element(node, 6u), node_element(node, 7u));
    return NodeWords(vec4<u32>(e[0], e[1]), vec4<u32>(e[2], e[3]), vec4<u32>(e[4], e[5]), vec4<u32>(e[6], e[7]));
#else
#if WIDE_LOADS
    let a = node_element(node, 0u);
    let b = node_element(node, 1u);
    return NodeWords(words_of(a.xy), words_of(a.zw), words_of(b.xy), words_of(b.zw));
#else
    return NodeWords(node_element(node, 0u), node_element(node, 1u), node_element(node, 2u), node_element(node, 3u));
#endif
#endif
}
#if WIDE_LOADS

// The four words of two 64-bit ones (each's low half first, as stored).
fn words_of(x: vec2<u64>) -> vec4<u32> {
    return vec4<u32>(u32(x.x), u32(x.x >> 32u), u32(x.y), u32(x.y >> 32u));
}
#endif
#endif
#if USER_SHADE
// Per pixel of the tile: the shade hook's colour, pack4x8unorm (red in the lowest byte).
@group(0) @binding(8) var<storage, read_write> out_color: array<u32>;
#endif
