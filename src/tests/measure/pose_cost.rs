//! What a new pose of a scene's instances costs (#64, docs/scene-format.md): the host's work
//! for a frame (the moved instances placed, the BVH's shape joined from the meshes' trees)
//! (and the tree over the instances alone, all a frame would build if rays moved into the
//! meshes' coordinates) against building the flattened scene's tree, when a poses file's frame moves its instances
//! and when every instance moves; the whole preparation of a tree naming the instances (rays
//! moved into the meshes: top tree, boxes, triangles rounded, maps); and the kernel's GPU time
//! through the joined tree against the flattened scene's own tree, and ray by ray through the
//! tree naming the instances. Frames interleaved.
//!
//!     RAYCAST_MEASURE="SCENE POSES [--frames N]" \
//!         cargo test --release -p raycast --lib pose_cost -- --ignored --nocapture

use std::time::Instant;

use glam::DAffine3;

use crate::prepare::bvh::Topology;
use crate::{Gpu, Precision, RenderOptions, Scene, Viewer};

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib pose_cost -- --ignored --nocapture"]
fn pose_cost() -> Result<(), Box<dyn std::error::Error>> {
    let args = super::args();
    let [scene_path, poses_path] = [0, 1].map(|k| args.get(k).cloned().unwrap_or_default());
    let frames: usize = match args.iter().position(|a| a == "--frames") {
        Some(i) => args[i + 1].parse()?,
        None => 10,
    };
    let scene = Scene::load(scene_path.as_ref())?;
    let text = std::fs::read_to_string(&poses_path)?;
    let poses = crate::parse_poses(&text, poses_path.as_ref())?;
    let gpu = Gpu::new()?;
    let options = RenderOptions {
        precision: Some(Precision::F32),
        timed: true,
        ..RenderOptions::default()
    };
    let per_ray = RenderOptions {
        tuning: crate::Tuning {
            packets: Some(false),
            ..crate::Tuning::default()
        },
        ..options.clone()
    };
    let triangles: usize = scene.primitive_counts()[2];
    println!(
        "adapter: {}; {scene_path}: {} instances, {triangles} triangles; {frames} frames of {poses_path}",
        gpu.info().adapter.name,
        scene.instances.len(),
    );
    // Every instance turned a little further each frame.
    let all_moved = |frame: usize| -> Vec<(usize, DAffine3)> {
        (scene.instances.iter())
            .map(|p| {
                let turn = DAffine3::from_rotation_y(0.01 * (frame + 1) as f64);
                (p.object, p.transform * turn)
            })
            .collect()
    };
    let mut viewer = Viewer::from(scene.clone());
    viewer.render(scene.camera.clone(), Topology::of);
    println!(
        "| frame | moved | place: ms | join: ms | top tree alone: ms | instanced preparation: ms | flattened build: ms | kernel joined: ms | kernel flattened: ms | kernel instanced, per ray: ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for what in ["pose", "all"] {
        for frame in 0..frames {
            let transforms = match what {
                "pose" => poses[(frame + 1) % poses.len()].transforms.clone(),
                _ => all_moved(frame),
            };
            let clock = Instant::now();
            viewer.pose(&transforms)?;
            let place = clock.elapsed().as_secs_f64();
            let camera = scene.camera.clone();
            let join = viewer.render(camera.clone(), |s| {
                let clock = Instant::now();
                Topology::of(s);
                clock.elapsed().as_secs_f64()
            });
            let top = crate::prepare::bvh::top_tree_seconds(viewer.as_ref());
            let instanced = viewer.render(camera.clone(), |s| {
                let clock = Instant::now();
                crate::prepare::Prepared::<f32>::instanced(s, crate::Algorithm::Robust);
                clock.elapsed().as_secs_f64()
            });
            let flattened = Scene {
                instances: Vec::new(),
                ..viewer.as_ref().clone()
            };
            let clock = Instant::now();
            Topology::build(&flattened);
            let build = clock.elapsed().as_secs_f64();
            let joined_kernel = viewer
                .render(camera.clone(), |s| gpu.render(s, &options))?
                .kernel_s();
            let instanced_kernel = viewer
                .render(camera, |s| gpu.render(s, &per_ray))?
                .kernel_s();
            let flat_kernel = gpu.render(&flattened, &options)?.kernel_s();
            let ms = |s: Option<f64>| s.map_or("-".into(), |s| format!("{:.2}", 1e3 * s));
            println!(
                "| {frame} | {what} ({}) | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {} | {} | {} |",
                transforms.len(),
                1e3 * place,
                1e3 * join,
                1e3 * top,
                1e3 * instanced,
                1e3 * build,
                ms(joined_kernel),
                ms(flat_kernel),
                ms(instanced_kernel),
            );
        }
    }
    Ok(())
}
