//! A scene seen from one camera after another, as an interactive viewer sees it: what the
//! camera does not change (the BVH's shape, the objects' extent) is made at the first render and
//! kept.

use crate::prepare::shared::{Shared, sharing};
use crate::scene::{Camera, Scene};

/// A scene rendered from camera after camera. Each render equals a render of the scene with
/// that camera; what depends on the objects alone (the BVH's shape) is made once.
///
/// ```no_run
/// use raycast::{Gpu, RenderOptions, Scene, Viewer};
/// let gpu = Gpu::new()?;
/// let mut viewer = Viewer::new(Scene::load("scenes/course/bunny.json".as_ref())?);
/// let mut camera = viewer.scene().camera.clone();
/// for step in 0..10 {
///     camera.eye.x += 0.1 * step as f64;
///     let images = viewer.render(camera.clone(), |scene| gpu.render(scene, &RenderOptions::default()))?;
/// }
/// # Ok::<(), raycast::Error>(())
/// ```
pub struct Viewer {
    scene: Scene,
    shared: Shared,
}

impl Viewer {
    /// A viewer of `scene`.
    pub fn new(scene: Scene) -> Viewer {
        Viewer {
            scene,
            shared: Shared::default(),
        }
    }

    /// The scene, with its own camera.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Runs `render` (a [`crate::Gpu::render`] or [`crate::Cpu::render`] call, say) on the
    /// scene seen by `camera`, on this thread, with what depends on the objects alone made once
    /// for all renders.
    pub fn render<R>(&mut self, camera: Camera, render: impl FnOnce(&Scene) -> R) -> R {
        let own = std::mem::replace(&mut self.scene.camera, camera);
        let scene = &self.scene;
        let result = sharing(scene, &mut self.shared, || render(scene));
        self.scene.camera = own;
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Cpu, RenderOptions};

    /// Each view is the render of the scene with that camera, whatever was seen before.
    #[test]
    fn each_view_is_the_render_of_its_camera() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/course/bunny.json");
        let mut scene = Scene::load(&path).unwrap();
        scene.camera.resolution = [48, 27];
        let options = RenderOptions::default();
        let mut viewer = Viewer::new(scene.clone());
        for step in [0.0, 0.4, -0.3] {
            let mut camera = scene.camera.clone();
            camera.eye.x += step;
            camera.eye.y += step / 2.0;
            let seen = viewer.render(camera.clone(), |s| Cpu.render(s, &options));
            let alone = Cpu.render(
                &Scene {
                    camera,
                    ..scene.clone()
                },
                &options,
            );
            assert_eq!(seen.unwrap(), alone.unwrap(), "eye moved by {step}");
        }
        assert!(
            viewer.shared.topology().is_some(),
            "the shape is kept for the next view"
        );
    }
}
