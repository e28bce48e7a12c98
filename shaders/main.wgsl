// Entry point: one invocation per pixel of a tile of image rows.
#import types
#import bindings
#import camera
#import scene

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = gid.x;
    let row = gid.y;
    if (j >= params.nx || row >= params.tile_rows) {
        return;
    }
    let ray = camera_ray(params.frame, params.projection, params.nx, params.ny, params.row_offset + row, j);
    let hit = nearest_hit(ray, params.frame.min_t);
    let index = row * params.nx + j;
    if (hit.object < 0) {
        out_surface[index] = vec4<real>(0.0);
        out_id[index] = -1;
        return;
    }
    let distance = hit.t * length(ray.direction);
    out_surface[index] = vec4<real>(hit_normal(ray, hit), distance);
    out_id[index] = hit.object;
}
