//! Render a scene file from Rust and write its images.
//!
//!     cargo run --example render_scene [SCENE.json] [OUT_DIR]
//!
//! With no arguments it renders the course's bunny into a temporary folder.

use raycast::{Encoding, Format, Gpu, RenderOptions, Scene};

fn main() -> raycast::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene_file = args.next().unwrap_or("scenes/course/bunny.json".into());
    let out = args.next().map_or_else(
        || std::env::temp_dir().join("raycast-render-scene"),
        Into::into,
    );

    // A scene is a camera and objects; `load` checks every value and names the bad one.
    let scene = Scene::load(scene_file.as_ref())?;

    // The GPU (lavapipe when there is no other). The default options render in adaptive
    // precision: the f64 reference's ids at close to f32's cost.
    let gpu = Gpu::new()?;
    let images = gpu.render(&scene, &RenderOptions::default())?;

    let [width, height] = scene.camera.resolution;
    let hits = images.id().iter().filter(|&&id| id >= 0).count();
    println!("{width}x{height} pixels, {hits} see an object");

    // PNG pictures and NumPy arrays of the ids, distances and normals, with camera.json.
    let encoding = Encoding::new(&[Format::Png, Format::Npy], None)?;
    for file in raycast_files::write_files(&out, &images.encode(&encoding, &scene.camera))? {
        println!("wrote {}", file.display());
    }
    Ok(())
}
