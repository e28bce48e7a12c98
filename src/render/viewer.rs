//! A scene seen from one camera after another, as an interactive viewer sees it: what the
//! camera does not change (the BVH's shape, the objects' extent) is made at the first render and
//! kept; and its instances moved from pose to pose, which builds again only the tree over them
//! (the meshes' own trees are kept).

use glam::DAffine3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::prepare::shared::{Shared, sharing};
use crate::scene::{Camera, Object, Scene};

/// A scene rendered from camera after camera, and pose after pose ([`Viewer::pose`]). Each
/// render equals a render of the scene with that camera and those placements; what depends on
/// the objects alone (the BVH's shape) is made once for each pose, and the meshes' own trees
/// once.
///
/// ```no_run
/// use raycast::{Gpu, RenderOptions, Scene, Viewer};
/// let gpu = Gpu::new()?;
/// let mut viewer = Viewer::from(Scene::load("scenes/course/bunny.json".as_ref())?);
/// let mut camera = viewer.as_ref().camera.clone();
/// for step in 0..10 {
///     camera.eye.x += 0.1 * step as f64;
///     let images = viewer.render(camera.clone(), |scene| gpu.render(scene, &RenderOptions::default()))?;
/// }
/// # Ok::<(), raycast::Error>(())
/// ```
pub struct Viewer {
    scene: Scene,
    shared: Shared,
    /// Each instance's transform as the scene places it, which a pose that does not move it
    /// keeps.
    own: Vec<DAffine3>,
}

impl From<Scene> for Viewer {
    /// A viewer of `scene`, its instances where it places them.
    fn from(scene: Scene) -> Viewer {
        Viewer {
            own: scene.instances.iter().map(|p| p.transform).collect(),
            scene,
            shared: Shared::default(),
        }
    }
}

impl AsRef<Scene> for Viewer {
    /// The scene, with its own camera and its instances at the last pose.
    fn as_ref(&self) -> &Scene {
        &self.scene
    }
}

impl Viewer {
    /// What its renders share.
    #[cfg(test)]
    pub(crate) fn shared(&self) -> &Shared {
        &self.shared
    }

    /// Places the scene's instances for the renders that follow: each of `transforms` (an
    /// instance's object index and the map from its mesh's coordinates to the world's) where it
    /// says, every other one where the scene places it. Only the instances whose place changes
    /// are moved, and the BVH is joined again from the meshes' trees kept from the first render.
    pub fn pose(&mut self, transforms: &[(usize, DAffine3)]) -> Result<()> {
        let mut wanted = self.own.clone();
        for &(object, m) in transforms {
            let k = (self.scene.instances.iter().position(|p| p.object == object)).ok_or_else(
                || Error::Argument {
                    option: "transforms".into(),
                    message: format!("object {object} is not an instance of the scene"),
                },
            )?;
            wanted[k] = m;
        }
        // Each moved copy placed again in its own soup's memory, the objects in parallel: new
        // memory for every copy, each frame, cost more than the placing.
        let mut moves = vec![None; self.scene.objects.len()];
        for (p, m) in self.scene.instances.iter_mut().zip(wanted) {
            if p.transform != m {
                p.transform = m;
                moves[p.object] = Some((p.mesh.clone(), m));
            }
        }
        if moves.iter().all(Option::is_none) {
            return Ok(());
        }
        (self.scene.objects.par_iter_mut())
            .zip(moves)
            .for_each(|(object, moved)| {
                if let (Object::Soup { triangles, .. }, Some((mesh, m))) = (object, moved) {
                    crate::scene::place_into(triangles, &mesh.triangles, &m);
                }
            });
        self.shared.objects_moved();
        Ok(())
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
        let mut viewer = Viewer::from(scene.clone());
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
