// Resources of the ray-casting kernel. Keep in sync with src/gpu/render.rs (bind group layout).
#import types

struct Params {
    frame: Frame,         // offset 0
    row_offset: u32,      // offset 80: first image row of this dispatch (tiles of rows)
    tile_rows: u32,       // offset 84
    sphere_count: u32,    // offset 88
    plane_count: u32,     // offset 92
    triangle_count: u32,  // offset 96
    _pad0: u32,           // offset 100
    _pad1: u32,           // offset 104
    _pad2: u32,           // offset 108
}                         // size 112

@group(0) @binding(0) var<uniform> params: Params;
// Never empty: the host uploads one unused element when a kind is absent (count stays 0).
@group(0) @binding(1) var<storage, read> spheres: array<Sphere>;
@group(0) @binding(2) var<storage, read> planes: array<Plane>;
@group(0) @binding(3) var<storage, read> triangles: array<Triangle>;
// Per pixel of the tile: normal in xyz, distance in w (0 on a miss).
@group(0) @binding(4) var<storage, read_write> out_surface: array<vec4<f32>>;
// Per pixel of the tile: object id, -1 on a miss.
@group(0) @binding(5) var<storage, read_write> out_id: array<i32>;
