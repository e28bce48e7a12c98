//! The `raycast` command's parts that are more than parsing options: comparing two renders, the
//! studies (accuracy, tradeoff, specializations, bench, self-test, workloads), their pictures
//! and progress bars. A client of the `raycast` library; `main.rs` is the `clap` front end.

pub mod compare;
pub mod progress;
pub mod render;
pub mod study;
pub mod text;

/// The option of this command line that sets what the library calls `name` (an argument of
/// its API: `RenderOptions::samples_per_pixel`, say), with the value it implies where the name
/// is a choice (`Gpu`).
pub fn flag(name: &str) -> Option<String> {
    let flag = match name {
        "precision" => "--precision",
        "device" => "--device",
        "Gpu" => "--device gpu",
        "lit" | "ShadeHook::raytrace" => "--lit",
        "shade" | "shader" => "--shader",
        "kernel" => "--kernel",
        "samples_per_pixel" => "--spp",
        "formats" => "--format",
        "outputs" => "--outputs",
        "background" => "--background",
        "band_rows" => "--band-rows",
        "emit_shader" => "--emit-shader",
        "eye" => "--eye",
        "look_at" => "--look-at",
        "up" => "--up",
        "fov" => "--fov",
        "orbit" => "--orbit",
        "views" => "--views",
        "shard" => "--shard",
        _ => return None,
    };
    Some(flag.to_string())
}
