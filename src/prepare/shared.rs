//! What the renders of one scene share whatever their camera: the views of a [`crate::Viewer`]
//! (a dataset's, datasets/src/views.rs, or the live page's) render one set of objects from camera
//! after camera, and what depends on the objects alone is made once for all of them.

use std::cell::RefCell;
use std::sync::Arc;

use super::bvh::{MeshTree, Rest, Topology};
use crate::scene::{Mesh, Placement, Scene};

/// What the renders of one scene's objects share, each part made at the first render that
/// needs it and kept for the next ([`sharing`]): the shape of its BVH, and the largest
/// magnitude of its objects' coordinates (a pass over every triangle, which each preparation
/// needs for its unit, `super::unit_exponent`).
#[derive(Debug, Default)]
pub(crate) struct Shared {
    topology: Option<Arc<Topology>>,
    magnitude: Option<f64>,
    /// The trees of the meshes the objects place, and of the objects other than instances,
    /// which outlive a change of pose.
    meshes: Vec<(Arc<Mesh>, Arc<MeshTree>)>,
    rest: Option<Arc<Rest>>,
}

impl Shared {
    /// Forgets what depends on where the objects are, which instances moving changes (the
    /// BVH's shape, the extent), and keeps the meshes' own trees and the other objects' tree.
    pub(crate) fn objects_moved(&mut self) {
        self.topology = None;
        self.magnitude = None;
    }

    /// Forgets everything but the trees of the meshes `placed` still places: what a commit of
    /// a [`crate::Geometry`] keeps for the next, whose other objects may have changed since.
    pub(crate) fn keep_trees_of(&mut self, placed: &[Placement]) {
        *self = Shared {
            meshes: std::mem::take(&mut self.meshes),
            ..Shared::default()
        };
        (self.meshes).retain(|(m, _)| placed.iter().any(|p| Arc::ptr_eq(&p.mesh, m)));
    }

    /// The meshes' own trees made so far.
    #[cfg(test)]
    pub(crate) fn mesh_trees(&self) -> Vec<Arc<MeshTree>> {
        self.meshes.iter().map(|(_, t)| t.clone()).collect()
    }

    /// The BVH's shape, once a render has built it.
    #[cfg(test)]
    pub(crate) fn topology(&self) -> Option<&Arc<Topology>> {
        self.topology.as_ref()
    }

    /// The tree of the objects other than instances, once a render has built it.
    #[cfg(test)]
    pub(crate) fn rest(&self) -> Option<&Arc<Rest>> {
        self.rest.as_ref()
    }
}

/// The objects (by address and count) whose renders on this thread share [`Shared`].
type Sharing = ((usize, usize), Shared);

thread_local! {
    /// What the renders on this thread share, and for which objects ([`sharing`]).
    static SHARED: RefCell<Option<Sharing>> = const { RefCell::new(None) };
}

/// The key of `scene`'s objects: these very objects, as the views of one scene share them.
fn key(scene: &Scene) -> (usize, usize) {
    (scene.objects.as_ptr() as usize, scene.objects.len())
}

/// Runs `f`, in which every preparation this thread makes for `scene`'s objects takes what
/// `shared` holds, and leaves there what it made for the next call. What it holds depends on
/// the objects alone, so this changes no result, only the time a render of another view takes.
pub(crate) fn sharing<R>(scene: &Scene, shared: &mut Shared, f: impl FnOnce() -> R) -> R {
    let before = SHARED.replace(Some((key(scene), std::mem::take(shared))));
    let result = f();
    if let Some((_, made)) = SHARED.replace(before) {
        *shared = made;
    }
    result
}

/// `part` of what is shared for `scene`'s objects, made by `make` unless it is there, and kept
/// there where they are shared; `make`'s value where they are not. `make` runs outside the
/// borrow of what is shared, which it may use itself ([`mesh_tree`]).
fn shared<T: Clone>(
    scene: &Scene,
    part: impl Fn(&mut Shared) -> &mut Option<T>,
    make: impl FnOnce() -> T,
) -> T {
    let is_shared = |sharing: &Option<Sharing>| matches!(sharing, Some((k, _)) if *k == key(scene));
    let kept = SHARED.with_borrow_mut(|sharing| match sharing {
        Some((k, shared)) if *k == key(scene) => part(shared).clone(),
        _ => None,
    });
    if let Some(kept) = kept {
        return kept;
    }
    let made = make();
    SHARED.with_borrow_mut(|sharing| {
        if is_shared(sharing)
            && let Some((_, shared)) = sharing
        {
            *part(shared) = Some(made.clone());
        }
    });
    made
}

/// [`Topology::build`] of `scene`, or the one shared for its objects.
pub(crate) fn topology(scene: &Scene) -> Arc<Topology> {
    shared(
        scene,
        |s| &mut s.topology,
        || Arc::new(Topology::build(scene)),
    )
}

/// `scene`'s objects other than its instances, as the joined tree takes them (`make`), or the
/// ones shared for them: they outlive a change of pose ([`Shared::objects_moved`]).
pub(crate) fn rest_tree(scene: &Scene, make: impl FnOnce() -> Rest) -> Arc<Rest> {
    shared(scene, |s| &mut s.rest, || Arc::new(make()))
}

/// [`Scene::objects_magnitude`], or the one shared for `scene`'s objects.
pub(crate) fn objects_magnitude(scene: &Scene) -> f64 {
    shared(scene, |s| &mut s.magnitude, || scene.objects_magnitude())
}

/// The own tree of `mesh`, or the one shared for it: built once for all its placements and
/// poses ([`crate::Viewer`] keeps it while the instances move).
pub(crate) fn mesh_tree(mesh: &Arc<Mesh>) -> Arc<MeshTree> {
    let kept = SHARED.with_borrow(|sharing| {
        let (_, shared) = sharing.as_ref()?;
        let (_, tree) = (shared.meshes.iter()).find(|(m, _)| Arc::ptr_eq(m, mesh))?;
        Some(tree.clone())
    });
    kept.unwrap_or_else(|| {
        let tree = Arc::new(MeshTree::build(mesh));
        SHARED.with_borrow_mut(|sharing| {
            if let Some((_, shared)) = sharing {
                shared.meshes.push((mesh.clone(), tree.clone()));
            }
        });
        tree
    })
}
