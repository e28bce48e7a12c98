// Entry point: one invocation per pixel of a tile of image rows, per listed pixel
// (PIXEL_LIST), or per ray of a caller's list (RAY_LIST).
#import types
#import bindings
#import frame
#import nearest
#if COUNT
#import count
#endif
#if CLOSEST
#import closest
#endif
#if USER_SHADE
#import shade
#import user
#endif

// Casts the ray of pixel (i, j) and, if `write`, writes its results to output slot `index`.
// Only the outputs the variant asks for are computed (ID, NORMAL, DISTANCE) and written (ID,
// SURFACE, DISTANCE_ALONE).
fn cast_pixel(i: u32, j: u32, index: u32, write: bool) {
    let ray = pixel_ray(i, j);
    write_pixel(ray, nearest_hit(ray, params.frame.min_t), i, j, index, write);
}

// The camera's ray through pixel (i, j).
fn pixel_ray(i: u32, j: u32) -> Ray {
    return camera_ray(params.frame, params.projection, params.nx, params.ny, i, j);
}

// Writes the results of pixel (i, j), whose ray `ray` found `hit`, to output slot `index` if
// `write`.
fn write_pixel(ray: Ray, hit: Hit, i: u32, j: u32, index: u32, write: bool) {
    if (!write) {
        return;
    }
#if ID
    out_id[index] = select(hit.object, -1, hit.object < 0);
#endif
    // Normal in xyz, distance in w, each zero unless computed; zero on a miss.
    var surface = vec4<real>(0.0);
    if (hit.object >= 0) {
#if NORMAL
        surface = vec4<real>(hit_normal(ray, hit), 0.0);
#endif
#if DISTANCE
        // Back to world units: an exact power-of-two scaling.
        surface.w = hit.t * length(ray.direction) * params.unit;
#endif
    }
#if CERTAINTY
    // A normal or distance that left f32's range (a NaN fails the test too) is no f32 answer.
    let in_range = all(abs(surface) <= vec4<real>(T_FAR));
    out_certain[index] = select(0u, 1u, is_pixel_certain(hit) && in_range);
#endif
#if SURFACE
#if ID
    // With ids the host reads a pixel's surface only where its id is a hit (each store to a
    // lane's own address is a loop of scalar stores on llvmpipe).
    if (hit.object >= 0) {
        out_surface[index] = surface;
    }
#else
    out_surface[index] = surface;
#endif
#endif
#if DISTANCE_ALONE
#if ID
    if (hit.object >= 0) {
        out_distance[index] = surface.w;
    }
#else
    out_distance[index] = surface.w;
#endif
#endif
#if USER_SHADE
    shading_pixel = vec2<u32>(j, i);
    let colour = shade(shade_hit(ray, hit, surface));
    out_color[index] = pack4x8unorm(clamp(colour, vec4<f32>(0.0), vec4<f32>(1.0)));
#if HOOK_RAYS
    count_hook_rays();
#endif
#endif
}

#if PACKETS
// Where invocation `local` of a workgroup covering 8x8 pixels (or an image's rays) falls in
// it, (column, row): each run of 8 invocations covers a 4x2 tile (the tiles two across, four
// down), so a subgroup of 8 (llvmpipe) is a compact packet.
fn packet_tile_offset(local: u32) -> vec2<u32> {
    let tile = local >> 3u;
    return vec2<u32>((tile & 1u) * 4u + (local & 3u), (tile >> 1u) * 2u + ((local >> 2u) & 1u));
}

// What a packet kernel's invocation knows of itself. With EIGHT_LANES (llvmpipe) its index in
// the workgroup is its subgroup's index and its lane: llvmpipe numbers the invocations of a
// workgroup by a counter, derives local_invocation_id from it by 24 scalar integer divisions
// by the workgroup's size per subgroup (Mesa 25.0), and local_invocation_index from that, all
// of which this spares. Subgroups of exactly 8 fill the 64 invocations 8 by 8, so the two give
// every invocation its own index.
struct Invocation {
    @builtin(workgroup_id) group: vec3<u32>,
#if EIGHT_LANES
    @builtin(subgroup_id) subgroup: u32,
#else
    @builtin(local_invocation_index) local: u32,
#endif
    @builtin(subgroup_invocation_id) lane: u32,
#if HOOK_RAYS
#if !EIGHT_LANES
    @builtin(subgroup_size) lanes: u32,
#endif
#endif
}

// The invocation's index in its workgroup, 0 to 63.
fn local_index(invocation: Invocation) -> u32 {
#if EIGHT_LANES
    return invocation.subgroup * 8u + invocation.lane;
#else
    return invocation.local;
#endif
}
#endif

// The entry of list `slot` (a listed pixel or ray), in workgroups of 64 invocations laid out in
// rows of at most the device's limit of workgroups per dimension.
fn list_slot(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

#if RAY_LIST
// Casts `ray` and, if `write`, writes its results to slot `index`: the hit's object, normal,
// t, primitive and barycentrics, (COUNT) how many surfaces it crosses, or (CLOSEST) the
// primitive nearest its origin.
fn cast_ray(ray: Ray, index: u32, write: bool) {
#if CLOSEST
    write_closest(ray.origin, closest_to(ray.origin), index, write);
#else
#if COUNT
    let count = count_crossings(ray, params.frame.min_t);
    if (write) {
        out_count[index] = count;
    }
#else
    write_listed(ray, nearest_hit(ray, params.frame.min_t), index, write);
#endif
#endif
}

#if !COUNT
// Writes what the list asks of its ray `ray`, whose nearest hit is `hit`, to slot `index` if
// `write`: whether it is occluded (OCCLUDED), or the hit.
fn write_listed(ray: Ray, hit: Hit, index: u32, write: bool) {
#if OCCLUDED
    if (write) {
        out_occluded[index] = select(0u, 1u, hit.object >= 0 && hit_t(ray, hit) <= params.max_t);
    }
#else
    write_ray(ray, hit, index, write);
#endif
}
#endif

#if CLOSEST
// Writes the primitive nearest query point `p`, `hit`, to slot `index` if `write`: the closest
// point in xyz and its distance in w (kernel units), the primitive and its barycentrics.
fn write_closest(p: vec3<real>, hit: Hit, index: u32, write: bool) {
    if (!write) {
        return;
    }
    if (hit.object >= 0) {
        let c = closest_details(p, hit);
        out_surface[index] = vec4<real>(c.point, sqrt(hit.t));
        out_primitive[index] = primitive_key(hit);
        out_uv[index] = c.uv;
    }
    out_id[index] = select(hit.object, -1, hit.object < 0);
}
#endif

#if !COUNT
#if !OCCLUDED
// Writes the results of a listed ray `ray`, which found `hit`, to slot `index` if `write`.
fn write_ray(ray: Ray, hit: Hit, index: u32, write: bool) {
    if (!write) {
        return;
    }
    // Normal in xyz, t in w. A miss writes its id only (the host knows what a miss reads as):
    // each store to a lane's own address is a loop of scalar stores on llvmpipe, so a miss
    // spares seven of them (docs/performance.md#specialization).
    var surface = vec4<real>(0.0);
    if (hit.object >= 0) {
        let details = hit_details(ray, hit);
        surface = vec4<real>(details.normal, details.t);
        out_surface[index] = surface;
        out_primitive[index] = primitive_key(hit);
        out_uv[index] = details.uv;
    }
    out_id[index] = select(hit.object, -1, hit.object < 0);
#if CERTAINTY
    let in_range = all(abs(surface) <= vec4<real>(T_FAR));
    out_certain[index] = select(0u, 1u, is_pixel_certain(hit) && in_range);
#endif
}
#endif
#endif

#if PACKETS
// An invocation's entry of the list, and whether it exists.
struct ListEntry {
    slot: u32,
    exists: bool,
}

// The entry of invocation `local` of (flat) workgroup `group` in an image's list (rows of
// params.nx rays): each workgroup covers 8x8 rays in 4x2 tiles, as the camera's packets do
// (closer rays than a row's 8, so fewer nodes to visit). An invocation beyond the image's
// right edge is given the last ray of its row.
fn grid_entry(group: u32, local: u32) -> ListEntry {
    let blocks = (params.nx + 7u) / 8u;
    let offset = packet_tile_offset(local);
    let j = (group % blocks) * 8u + offset.x;
    let row = (group / blocks) * 8u + offset.y;
    let slot = row * params.nx + min(j, params.nx - 1u);
    return ListEntry(slot, j < params.nx && slot < params.tile_rows);
}

// Coherent rays (the host's judgement, RayScene): each subgroup's rays walk the BVH as a
// packet, 8 consecutive ones, or with params.nx a tile of an image's. Every invocation runs to
// the end, since its subgroup fetches nodes together: one beyond the list casts the last ray
// and writes nothing.
@compute @workgroup_size(64)
fn main(invocation: Invocation, @builtin(num_workgroups) groups: vec3<u32>) {
    lane = invocation.lane;
#if LANES
    // Several rays a lane, as the camera's packets (main below): one subgroup in LANE_RAYS
    // casts its own entries and the next ones'.
    if ((invocation.subgroup & (LANE_RAYS - 1u)) != 0u) {
        return;
    }
    var rays: LaneRays;
#each_ray
    rays.r$r = listed_ray(list_entry(invocation, groups, local_index(invocation) + 8u * $ru));
#end_each
    let hits = nearest_hit_lanes(rays, params.frame.min_t);
    // One copy of the output code, as for the camera's rays (main below); each ray taken from
    // `rays` rather than loaded again, another loop of loads over the lanes.
    for (var r = 0u; r < LANE_RAYS; r++) {
        let entry = list_entry(invocation, groups, local_index(invocation) + 8u * r);
        write_listed(lane_ray(rays, r), lane_hit(hits, r), entry.slot, entry.exists);
        swap_rays();
    }
#else
    let entry = list_entry(invocation, groups, local_index(invocation));
    cast_ray(listed_ray(entry), entry.slot, entry.exists);
#endif
}

// The entry of invocation `local` (0 to 63) of the workgroup of `invocation`.
fn list_entry(invocation: Invocation, groups: vec3<u32>, local: u32) -> ListEntry {
    // As list_slot numbers them.
    let flat_group = invocation.group.x + invocation.group.y * groups.x;
    if (params.nx != 0u) {
        return grid_entry(flat_group, local);
    }
    let slot = flat_group * 64u + local;
    return ListEntry(slot, slot < params.tile_rows);
}

// The listed ray of `entry` (the last one for an entry beyond the list).
fn listed_ray(entry: ListEntry) -> Ray {
    return stored_ray(ray_list[min(entry.slot, params.tile_rows - 1u)]);
}
#else
@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let slot = list_slot(gid, groups);
    if (slot >= params.tile_rows) {
        return;
    }
    cast_ray(stored_ray(ray_list[slot]), slot, true);
}
#endif
#else
#if PIXEL_LIST
// The pixels to cast, as row-major indices; params.tile_rows holds how many there are.
@group(0) @binding(17) var<storage, read> pixel_list: array<u32>;

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let slot = list_slot(gid, groups);
    if (slot >= params.tile_rows) {
        return;
    }
    let pixel = pixel_list[slot];
    cast_pixel(pixel / params.nx, pixel % params.nx, slot, true);
}
#else
#if PACKETS
// One workgroup per 8x8 pixels, as below, numbered in one dimension: subgroups are then
// consecutive invocations, which Vulkan does not promise for 2-D workgroups. Its 4x2 tiles
// (packet_tile_offset) hold closer rays than a row of 8 pixels, so fewer nodes to visit. Every
// invocation runs to the end, since its subgroup fetches nodes together: one beyond the image
// casts the nearest pixel inside it and writes nothing.
@compute @workgroup_size(64)
fn main(invocation: Invocation) {
    lane = invocation.lane;
#if HOOK_RAYS
#if !EIGHT_LANES
    subgroup_lanes = invocation.lanes;
#endif
#endif
#if LANES
    // Packets of 8 LANE_RAYS rays, LANE_RAYS a lane (traverse_bvh_lanes): one subgroup in
    // LANE_RAYS casts its own 4x2 tile and the next ones' (with eight rays a lane all 8x8
    // pixels of the workgroup, packet_tile_offset; with two, tiles 0 and 1, 2 and 3, ...), and
    // the others have nothing to do.
    if ((invocation.subgroup & (LANE_RAYS - 1u)) != 0u) {
        return;
    }
    var rays: LaneRays;
#each_ray
    let pixel$r = packet_pixel(invocation, local_index(invocation) + 8u * $ru);
    rays.r$r = pixel_ray(pixel$r.i, pixel$r.j);
#end_each
    let hits = nearest_hit_lanes(rays, params.frame.min_t);
    // The outputs of the lane's rays in a loop, so that the kernel holds one copy of their
    // code (normals, shading hooks) rather than one per ray: eight copies take LLVM far longer
    // to compile and run no faster (docs/experiments.md#eight-rays-a-lane).
    for (var r = 0u; r < LANE_RAYS; r++) {
        let pixel = packet_pixel(invocation, local_index(invocation) + 8u * r);
        write_pixel(pixel_ray(pixel.i, pixel.j), lane_hit(hits, r), pixel.i, pixel.j, pixel.index, pixel.inside);
        swap_rays();
    }
#else
    let p = packet_pixel(invocation, local_index(invocation));
    cast_pixel(p.i, p.j, p.index, p.inside);
#endif
}

// A pixel of a packet kernel's 8x8 block and its output slot; a pixel beyond the image is
// the nearest one inside it, and not `inside`.
struct PacketPixel {
    i: u32,
    j: u32,
    index: u32,
    inside: bool,
}

// The pixel of invocation `local` (0 to 63) of the workgroup of `invocation`.
fn packet_pixel(invocation: Invocation, local: u32) -> PacketPixel {
    let offset = packet_tile_offset(local);
    let j = invocation.group.x * 8u + offset.x;
    let row = invocation.group.y * 8u + offset.y;
    let jc = min(j, params.nx - 1u);
    let rc = min(row, params.tile_rows - 1u);
    return PacketPixel(params.row_offset + rc, jc, rc * params.nx + jc, j < params.nx && row < params.tile_rows);
}
#else
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = gid.x;
    let row = gid.y;
    if (j >= params.nx || row >= params.tile_rows) {
        return;
    }
    cast_pixel(params.row_offset + row, j, row * params.nx + j, true);
}
#endif
#endif
#endif
