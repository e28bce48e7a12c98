//! A shade hook that traces shadows: examples/shadows.wgsl lights each hit by the scene's
//! lights and casts a shadow ray to each (`occluded`); the kernel calls it once per pixel.
//!
//!     cargo run --example shadows [OUT_DIR]
//!
//! Writes color.png of the course's lit bunny, and prints how many shadow rays it cast.

use raycast::{Encoding, Format, Gpu, Output, Outputs, RenderOptions, Scene, ShadeHook};

fn main() -> raycast::Result<()> {
    let out = std::env::args()
        .nth(1)
        .map_or_else(|| std::env::temp_dir().join("raycast-shadows"), Into::into);
    let mut scene = Scene::load("scenes/ray-tracing/bunny.json".as_ref())?;
    scene.camera.resolution = [480, 270];

    // Checked with naga before any GPU work: a bad hook is an error at its line and column.
    let hook = ShadeHook::load("examples/shadows.wgsl".as_ref())?;
    let options = RenderOptions {
        shade: Some(hook),
        outputs: Outputs {
            id: false,
            distance: false,
            normal: false,
            color: true,
        },
        ..Default::default()
    };
    let images = Gpu::new()?.render(&scene, &options)?;
    let rays = images.hook_rays().unwrap_or(0);
    println!("the hook cast {rays} shadow rays");
    assert!(
        rays > 0,
        "the bunny's scene has lights, so the hook casts shadow rays"
    );

    let encoding = Encoding::new(&[Format::Png], Some(&[Output::Color]))?;
    for file in raycast_files::write_files(&out, &images.encode(&encoding, &scene.camera))? {
        println!("wrote {}", file.display());
    }
    Ok(())
}
