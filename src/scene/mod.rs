//! The validated scene: a camera and a list of objects, all in f64, as read from a scene file.
//!
//! Flow: scene file --[`Scene::load`]--> [`Scene`] --> camera frame + primitives --> GPU or CPU.
//! Every check that can fail on user input happens here, so later stages can assume
//! finite numbers, positive sizes and non-degenerate camera vectors.

mod camera;
mod file;
mod instance;
pub(crate) use file::MAX_MAGNITUDE;
pub use file::{ViewCamera, parse_poses, parse_views};
pub(crate) use instance::{moved_box, place, place_into, singular};
mod mesh;
mod orbit;

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

pub use camera::{Camera, CameraOverrides, Lens, Projection};
pub(crate) use mesh::load_mesh_parts;
pub use mesh::{MeshPart, Split, load_mesh, parse_mesh};
pub use orbit::Orbit;

/// The image size used when neither the scene nor the command line gives one (the course's).
pub const DEFAULT_RESOLUTION: [u32; 2] = [640, 360];

/// The built-in scene `raycast render` uses when given no scene file.
pub(crate) const DEFAULT_SCENE_JSON: &str = include_str!("../../scenes/default.json");
/// The mesh the default scene refers to as `bunny.stl` (the course's bunny).
pub(crate) const DEFAULT_SCENE_BUNNY: &[u8] = include_bytes!("../../scenes/bunny.stl");
/// The built-in scene's files, as [`load_viewed`] reads them without a path: its scene file
/// and its mesh.
pub const DEFAULT_SCENE_FILES: [&[u8]; 2] = [DEFAULT_SCENE_JSON.as_bytes(), DEFAULT_SCENE_BUNNY];

/// One triangle by its corners, in the order that fixes its normal.
pub type Triangle = [DVec3; 3];

/// A scene object. Its id is its index in [`Scene::objects`]; a soup is one object (a mesh
/// file split in parts, [`Split`], is a soup for each).
#[derive(Clone, Debug, PartialEq)]
pub enum Object {
    /// A sphere.
    Sphere {
        /// Its centre.
        center: DVec3,
        /// Its radius, positive.
        radius: f64,
    },
    /// A plane.
    Plane {
        /// A point on it.
        point: DVec3,
        /// Its normal, unit length (normalised on load).
        normal: DVec3,
    },
    /// A single triangle.
    Triangle {
        /// Its corners, whose order gives its normal.
        corners: Triangle,
    },
    /// A triangle mesh loaded from `path`.
    Soup {
        /// The mesh file, as the scene names it (`<memory>` for one given in code).
        path: PathBuf,
        /// Its triangles.
        triangles: Vec<Triangle>,
    },
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The camera that renders it.
    pub camera: Camera,
    /// The objects, their ids their indices.
    pub objects: Vec<Object>,
    /// Materials and lights, as the course's ray-tracing scenes give them: validated and kept,
    /// but the ray caster renders geometry only (ids, distances, normals).
    pub lighting: Lighting,
    /// What the scene file holds that is allowed but likely a mistake (a mesh declared and
    /// never placed), a line each, for the caller to show.
    pub warnings: Vec<String>,
    /// The objects that are a declared mesh placed by a transform (`instance` objects), each
    /// also in `objects` as the soup it places: the BVH is built from the meshes' own trees.
    pub(crate) instances: Vec<Placement>,
}

/// A mesh a scene file declares once (`"meshes"`), in its own coordinates.
#[derive(Debug, PartialEq)]
pub(crate) struct Mesh {
    /// Its file, as the scene names it.
    pub path: PathBuf,
    pub triangles: Vec<Triangle>,
}

impl Mesh {
    /// The box bounding its triangles, if it has any.
    pub(crate) fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let (lo, hi) = (self.triangles.iter().flatten())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), c| {
                (l.min(*c), h.max(*c))
            });
        (lo.x <= hi.x).then_some((lo, hi))
    }
}

/// Object `object` of a scene is `mesh` moved by `transform` into world space: the soup
/// [`instance::place`] makes of them.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Placement {
    pub object: usize,
    pub mesh: std::sync::Arc<Mesh>,
    pub transform: glam::DAffine3,
}

/// A material of the course's ray-tracing assignment (Blinn-Phong with a mirror term): RGB
/// coefficients, each component finite and at least 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The name objects refer to it by.
    pub name: String,
    /// Ambient coefficients.
    pub ka: DVec3,
    /// Diffuse coefficients.
    pub kd: DVec3,
    /// Specular coefficients.
    pub ks: DVec3,
    /// Mirror coefficients.
    pub km: DVec3,
    /// The Blinn-Phong exponent.
    pub phong_exponent: f64,
}

/// A light of the course's ray-tracing assignment; `color` components are finite and at least 0.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Light arriving along `direction` (non-zero) from infinitely far.
    Directional {
        /// The direction the light travels in.
        direction: DVec3,
        /// Its RGB intensity.
        color: DVec3,
    },
    /// Light from a point.
    Point {
        /// Where the light is.
        position: DVec3,
        /// Its RGB intensity.
        color: DVec3,
    },
}

/// The materials and lights of a scene, and each object's material.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lighting {
    /// The materials, in the file's order.
    pub materials: Vec<Material>,
    /// The lights.
    pub lights: Vec<Light>,
    /// Per object of [`Scene::objects`], the index in `materials` of the material it names.
    pub object_materials: Vec<Option<usize>>,
    /// Per object of [`Scene::objects`], the numbers its `values` gives (zeros where it gives
    /// none or fewer than `OBJECT_VALUES`): the user's own per-object data, which shade
    /// hooks read as `object_values(id)` (shaders/hooks.wgsl).
    pub object_values: Vec<[f64; OBJECT_VALUES]>,
}

/// How many numbers an object's `values` holds at most: a hook reads them as one `vec4<f32>`.
pub(crate) const OBJECT_VALUES: usize = 4;

impl Lighting {
    /// Whether the scene gives no material, light or object material at all.
    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
            && self.lights.is_empty()
            && self.object_materials.iter().all(Option::is_none)
            && self
                .object_values
                .iter()
                .all(|v| *v == [0.0; OBJECT_VALUES])
    }

    /// Object `k`'s material (its index in `materials`) and values, as hooks read them: none
    /// and zeros beyond the lists (a scene built in code may leave them empty).
    pub(crate) fn object_data(&self, k: usize) -> (Option<usize>, [f64; OBJECT_VALUES]) {
        (
            self.object_materials.get(k).copied().flatten(),
            self.object_values.get(k).copied().unwrap_or_default(),
        )
    }
}

impl std::fmt::Display for Lighting {
    /// What the scene gives, e.g. `2 lights, 5 materials, a material on 8 objects`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let plural = |n: usize, what: &str| match n {
            1 => format!("1 {what}"),
            n => format!("{n} {what}s"),
        };
        let with = self.object_materials.iter().flatten().count();
        write!(
            f,
            "{}, {}, a material on {}",
            plural(self.lights.len(), "light"),
            plural(self.materials.len(), "material"),
            plural(with, "object")
        )
    }
}

/// The corners of the box bounding `objects` (spheres whole, planes by their point, triangles
/// and meshes by their corners), if there are any.
pub fn bounds<'a>(objects: impl IntoIterator<Item = &'a Object>) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    let mut grow = |&p: &DVec3, r: f64| {
        lo = lo.min(p - r);
        hi = hi.max(p + r);
    };
    for object in objects {
        match object {
            Object::Sphere { center, radius } => grow(center, *radius),
            Object::Plane { point, .. } => grow(point, 0.0),
            Object::Triangle { corners } => corners.iter().for_each(|c| grow(c, 0.0)),
            Object::Soup { triangles, .. } => triangles.iter().flatten().for_each(|c| grow(c, 0.0)),
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

/// The scene of `path` ([`Scene::load`]; a mesh file, `.obj`, `.stl` or `.ply`, is a scene of
/// that mesh alone, `Scene::of_mesh`, its parts objects as `split` asks), or without one the
/// built-in default scene, with its resolution replaced by `size` where given (`--size`) and
/// its camera's settings by `view`'s ([`CameraOverrides`]; for a mesh file they replace those
/// of its default view): the command line's loader.
pub fn load_viewed(
    path: Option<&Path>,
    size: Option<[u32; 2]>,
    view: &CameraOverrides,
    split: Split,
) -> Result<Scene> {
    if let Some(path) = path.filter(|p| is_mesh_file(p)) {
        return Scene::of_mesh(path, size.unwrap_or(DEFAULT_RESOLUTION), view, split);
    }
    let mut scene = match path {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    if let Some(size) = size {
        scene.camera.resolution = size;
    }
    if !view.is_empty() {
        scene.camera = view.apply(&scene.camera)?;
    }
    Ok(scene)
}

/// Whether `path` names a mesh file (`.obj`, `.stl`, `.ply`, any case) rather than a scene.
pub fn is_mesh_file(path: &Path) -> bool {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    ["obj", "stl", "ply"]
        .iter()
        .any(|e| extension.eq_ignore_ascii_case(e))
}

impl Scene {
    /// Reads and validates a scene file; mesh paths are relative to the file's folder.
    ///
    /// ```
    /// let scene = raycast::Scene::load("scenes/course/bunny.json".as_ref())?;
    /// assert_eq!(scene.camera.resolution, [640, 360]);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn load(path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let base = path.parent().unwrap_or(Path::new(""));
        file::parse(&text, path, &mut |name, split| {
            load_mesh_parts(&base.join(name), split)
        })
    }

    /// The mesh file `path` as a scene of its parts as `split` asks (one object for an STL or
    /// PLY file), seen by its default view ([`CameraOverrides::framing`]) at `resolution`
    /// pixels, with `view`'s settings.
    pub(crate) fn of_mesh(
        path: &Path,
        resolution: [u32; 2],
        view: &CameraOverrides,
        split: Split,
    ) -> Result<Scene> {
        file::mesh_scene(path, split, |bounds| view.framing(bounds, resolution))
    }

    /// Parses scene JSON from memory; `name` labels errors, `load_mesh` resolves a soup's path
    /// into the parts its `split` asks for, each an object ([`parse_mesh`] parses a mesh
    /// file's bytes so; a loader that returns one part makes the soup one object).
    pub fn from_json(
        text: &str,
        name: &Path,
        load_mesh: &mut dyn FnMut(&str, Split) -> Result<Vec<MeshPart>>,
    ) -> Result<Scene> {
        file::parse(text, name, load_mesh)
    }

    /// The built-in default scene (the course bunny in a room with two spheres).
    pub(crate) fn default_scene() -> Scene {
        let name = Path::new("<built-in default scene>");
        Scene::from_json(DEFAULT_SCENE_JSON, name, &mut |file, split| {
            assert_eq!(file, "bunny.stl", "the default scene embeds only bunny.stl");
            mesh::parse_mesh(DEFAULT_SCENE_BUNNY, Path::new(file), split)
        })
        .expect("the built-in default scene is valid")
    }

    /// The scene with every length (positions, radii, the camera's focal length and image
    /// plane) multiplied by `2^k`, directions kept: exact in binary floating point, barring
    /// overflow and subnormals.
    pub(crate) fn scaled_by_pow2(&self, k: i32) -> Scene {
        let f = 2f64.powi(k);
        let v = |p: DVec3| p * f;
        let mut scene = self.clone();
        let c = &mut scene.camera;
        c.eye *= f;
        c.focal_length *= f;
        c.depth_white *= f;
        if let Lens::Size { width, height } = &mut c.lens {
            (*width, *height) = (*width * f, *height * f);
        }
        for object in &mut scene.objects {
            match object {
                Object::Sphere { center, radius } => (*center, *radius) = (v(*center), *radius * f),
                Object::Plane { point, .. } => *point = v(*point),
                Object::Triangle { corners } => *corners = corners.map(v),
                Object::Soup { triangles, .. } => {
                    triangles.iter_mut().for_each(|t| *t = t.map(v));
                }
            }
        }
        for light in &mut scene.lighting.lights {
            if let Light::Point { position, .. } = light {
                *position = v(*position);
            }
        }
        // A mesh keeps its own coordinates: its placement scales instead.
        for p in &mut scene.instances {
            p.transform = glam::DAffine3::from_scale(DVec3::splat(f)) * p.transform;
        }
        scene
    }

    /// How many spheres, planes and triangles (loose ones plus soups) the scene has.
    pub fn primitive_counts(&self) -> [usize; 3] {
        let mut n = [0; 3];
        for object in &self.objects {
            match object {
                Object::Sphere { .. } => n[0] += 1,
                Object::Plane { .. } => n[1] += 1,
                Object::Triangle { .. } => n[2] += 1,
                Object::Soup { triangles, .. } => n[2] += triangles.len(),
            }
        }
        n
    }

    /// The largest magnitude of any coordinate, radius or camera length of the scene.
    #[cfg(test)]
    pub(crate) fn largest_magnitude(&self) -> f64 {
        self.camera_magnitude().max(self.objects_magnitude())
    }

    /// The largest magnitude of the camera's eye, lengths and shifts.
    pub(crate) fn camera_magnitude(&self) -> f64 {
        let c = &self.camera;
        let plane = c.image_plane();
        c.eye
            .abs()
            .max_element()
            .max(c.focal_length)
            .max(plane.width)
            .max(plane.height)
            .max(plane.shift[0].abs())
            .max(plane.shift[1].abs())
    }

    /// The largest magnitude of any coordinate or radius of the objects (0 without any).
    pub(crate) fn objects_magnitude(&self) -> f64 {
        let largest = |v: &DVec3| v.x.abs().max(v.y.abs()).max(v.z.abs());
        let triangle = |t: &Triangle| t.iter().map(largest).fold(0.0, f64::max);
        // In parallel over the objects, and within a large mesh: a pass over every coordinate,
        // made once per scene and pose (prepare::shared). A mesh's own parallel pass each,
        // for many small meshes, cost more than the pass.
        self.objects
            .par_iter()
            .map(|object| match object {
                Object::Sphere { center, radius } => largest(center).max(*radius),
                Object::Plane { point, .. } => largest(point),
                Object::Triangle { corners } => triangle(corners),
                Object::Soup { triangles, .. } if triangles.len() < 1 << 14 => {
                    triangles.iter().map(triangle).fold(0.0, f64::max)
                }
                Object::Soup { triangles, .. } => (triangles.par_iter())
                    .map(triangle)
                    .reduce(|| 0.0, f64::max),
            })
            .reduce(|| 0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_loads() {
        let scene = Scene::default_scene();
        assert!(scene.primitive_counts()[2] >= 1000);
        assert_eq!(scene.camera.resolution, DEFAULT_RESOLUTION);
    }
}
