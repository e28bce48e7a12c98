//! The scene file format (JSON, a superset of the course's) and its validation into [`Scene`].

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use glam::DVec3;

use super::instance::{self, TransformFile};
use super::{
    Camera, DEFAULT_RESOLUTION, Lens, Light, Lighting, Material, Mesh, MeshPart, OBJECT_VALUES,
    Object, Placement, Projection, Scene, Split, Triangle, camera,
};
use crate::error::{Error, Result};
use crate::math::{Vec3, length, normalize};
use std::sync::Arc;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: CameraFile,
    /// Meshes by name, each loaded once and placed by `instance` objects.
    #[serde(default)]
    meshes: BTreeMap<String, MeshFile>,
    objects: Vec<ObjectFile>,
    /// The course's ray-tracing scenes add these (validated, not rendered).
    #[serde(default)]
    materials: Vec<MaterialFile>,
    #[serde(default)]
    lights: Vec<LightFile>,
    /// Free text: what the scene is for. Ignored by the renderer.
    #[serde(default)]
    #[allow(dead_code)]
    comment: Option<serde_json::Value>,
}

#[derive(Deserialize, Default, Debug, Clone)]
#[serde(rename_all = "lowercase")]
enum ProjectionFile {
    #[default]
    Perspective,
    Orthographic,
}

/// The course's camera fields, and their alternatives: `look_at` for `look`; `fov` or
/// `intrinsics` (with `near`) for `focal_length`, `width` and `height`.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    /// A view's name, in a views file (`--views`); a scene's camera has none.
    name: Option<String>,
    #[serde(rename = "type", default)]
    projection: ProjectionFile,
    eye: [f64; 3],
    look: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: [f64; 3],
    focal_length: Option<f64>,
    width: Option<f64>,
    height: Option<f64>,
    fov: Option<f64>,
    intrinsics: Option<IntrinsicsFile>,
    near: Option<f64>,
    resolution: Option<[u32; 2]>,
}

/// Pixel intrinsics, OpenCV's convention.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct IntrinsicsFile {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    name: String,
    ka: [f64; 3],
    kd: [f64; 3],
    ks: [f64; 3],
    km: [f64; 3],
    phong_exponent: f64,
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightFile {
    Directional {
        direction: [f64; 3],
        color: [f64; 3],
    },
    Point {
        position: [f64; 3],
        color: [f64; 3],
    },
}

/// A mesh file a scene declares once (`"meshes"`), as one object wherever it is placed.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshFile {
    stl: Option<String>,
    obj: Option<String>,
    ply: Option<String>,
    #[serde(default)]
    #[allow(dead_code)]
    comment: Option<serde_json::Value>,
}

/// An object: its shape and, in ray-tracing scenes, the name of its material.
#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum ObjectFile {
    Sphere {
        center: [f64; 3],
        radius: f64,
        #[serde(default)]
        #[allow(dead_code)]
        comment: Option<serde_json::Value>,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        values: Option<Vec<f64>>,
    },
    Plane {
        point: [f64; 3],
        normal: [f64; 3],
        #[serde(default)]
        #[allow(dead_code)]
        comment: Option<serde_json::Value>,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        values: Option<Vec<f64>>,
    },
    Triangle {
        corners: [[f64; 3]; 3],
        #[serde(default)]
        #[allow(dead_code)]
        comment: Option<serde_json::Value>,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        values: Option<Vec<f64>>,
    },
    /// The key names the format for the reader of the scene; the loader goes by the file's
    /// extension (`.obj`, `.ply`, anything else STL), as it always has.
    Soup {
        stl: Option<String>,
        obj: Option<String>,
        ply: Option<String>,
        /// Which parts of an OBJ file are objects of their own (default: each `o`).
        #[serde(default)]
        split: Option<Split>,
        #[serde(default)]
        #[allow(dead_code)]
        comment: Option<serde_json::Value>,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        values: Option<Vec<f64>>,
    },
    /// A declared mesh placed by a transform (identity where none is given).
    Instance {
        mesh: String,
        #[serde(default)]
        transform: Option<TransformFile>,
        #[serde(default)]
        #[allow(dead_code)]
        comment: Option<serde_json::Value>,
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        values: Option<Vec<f64>>,
    },
}

/// Resolves a soup's mesh file name, in the parts a [`Split`] asks for: what a scene's loader
/// is given.
pub(crate) type LoadMesh<'a> = dyn FnMut(&str, Split) -> Result<Vec<MeshPart>> + 'a;

impl ObjectFile {
    fn material(&self) -> Option<&str> {
        match self {
            ObjectFile::Sphere { material, .. }
            | ObjectFile::Plane { material, .. }
            | ObjectFile::Triangle { material, .. }
            | ObjectFile::Soup { material, .. }
            | ObjectFile::Instance { material, .. } => material.as_deref(),
        }
    }

    fn values(&self) -> Option<&[f64]> {
        match self {
            ObjectFile::Sphere { values, .. }
            | ObjectFile::Plane { values, .. }
            | ObjectFile::Triangle { values, .. }
            | ObjectFile::Soup { values, .. }
            | ObjectFile::Instance { values, .. } => values.as_deref(),
        }
    }
}

/// Parses and validates scene JSON. `file` names the source in error messages. A soup split
/// in several parts is as many objects, one after the other.
pub(super) fn parse(text: &str, file: &Path, load_mesh: &mut LoadMesh) -> Result<Scene> {
    let raw: SceneFile =
        deserialize(text, file).map_err(|e| wrong_shape(text, file, Shape::Scene).unwrap_or(e))?;
    let checker = Checker {
        file,
        camera: "camera",
    };
    if raw.camera.name.is_some() {
        return Err(checker.fail("camera.name", "only the cameras of a views file have names"));
    }
    let mut meshes = Meshes {
        declared: &raw.meshes,
        loaded: HashMap::new(),
        placed: Vec::new(),
    };
    let objects = raw
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| checker.object(i, o, load_mesh, &mut meshes))
        .collect::<Result<Vec<_>>>()?;
    let warnings = (raw.meshes.keys())
        .filter(|name| !meshes.loaded.contains_key(*name))
        .map(|name| {
            format!(
                "{}: meshes.{name} is declared but no instance places it",
                file.display()
            )
        })
        .collect();
    let counts: Vec<usize> = objects.iter().map(Vec::len).collect();
    let objects: Vec<Object> = objects.into_iter().flatten().collect();
    let firsts: Vec<usize> = (counts.iter())
        .scan(0, |next, n| Some(std::mem::replace(next, *next + n)))
        .collect();
    let instances = (meshes.placed.into_iter())
        .map(|(i, mesh, transform)| Placement {
            object: firsts[i],
            mesh,
            transform,
        })
        .collect();
    let camera = checker.camera(&raw.camera, &objects)?;
    let lighting = checker.lighting(&raw, &counts)?;
    Ok(Scene {
        camera,
        objects,
        lighting,
        warnings,
        instances,
    })
}

/// A view of a views file (`--views`) or a poses file (`--poses`): its name, its camera and
/// the instances it moves, checked as a scene's are except for what the scene's objects
/// decide ([`ViewCamera::camera`]).
#[derive(Debug, Clone)]
pub struct ViewCamera {
    /// Its name, the folder its files go in.
    pub name: String,
    /// The resolution it gives, if any.
    pub resolution: Option<[u32; 2]>,
    /// A pose's transforms: instances (by object index) moved from where the scene places
    /// them, each by the map from its mesh's coordinates to the world's. The scene's other
    /// instances stay where the scene file places them.
    pub transforms: Vec<(usize, glam::DAffine3)>,
    /// What errors name it by: `[3]` in a views file, `line 4` in a poses file.
    place: String,
    /// What its camera's fields are named under: `[3]`, or `line 4: camera`.
    under: String,
    /// Its camera; a pose may give none (the scene's).
    camera: Option<CameraFile>,
}

/// A line of a poses file.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PoseFile {
    name: String,
    #[serde(default)]
    transforms: Vec<MovedFile>,
    camera: Option<CameraFile>,
}

/// An instance a pose moves.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MovedFile {
    object: usize,
    transform: TransformFile,
}

/// The views of a views file (`file`, which errors name): a JSON list of cameras in any form a
/// scene's camera takes, each with a `name` (docs/datasets.md). Every camera is checked here
/// against no objects, so a bad field is refused before anything renders.
pub fn parse_views(text: &str, file: &Path) -> Result<Vec<ViewCamera>> {
    checked(
        views_of_list(text, file)?,
        file,
        "a list of at least one camera",
    )
}

/// The views of a poses file (`file`, which errors name): JSON lines, a view a line, its
/// `name`, the `transforms` of the instances it moves and maybe a `camera`
/// (docs/datasets.md#poses). Every camera and transform is checked here against no objects.
pub fn parse_poses(text: &str, file: &Path) -> Result<Vec<ViewCamera>> {
    checked(poses_of_lines(text, file)?, file, "a pose a line")
}

/// `views` with their cameras checked against no objects; an error if there are none (`give`
/// says what a file gives).
fn checked(views: Vec<ViewCamera>, file: &Path, give: &str) -> Result<Vec<ViewCamera>> {
    if views.is_empty() {
        return Err(Error::SceneValue {
            file: file.to_owned(),
            field: "views".into(),
            message: format!("no views: give {give}"),
        });
    }
    for view in &views {
        if let Some(camera) = &view.camera {
            view.checker(file).camera(camera, &[])?;
        }
    }
    Ok(views)
}

/// The views of a views file's list.
fn views_of_list(text: &str, file: &Path) -> Result<Vec<ViewCamera>> {
    let cameras: Vec<CameraFile> = deserialize(text, file)
        .map_err(|e| wrong_shape(text, file, Shape::ViewsFile).unwrap_or(e))?;
    (cameras.into_iter().enumerate())
        .map(|(index, camera)| match camera.name.clone() {
            Some(name) => Ok(ViewCamera {
                name,
                resolution: camera.resolution,
                transforms: Vec::new(),
                place: format!("[{index}]"),
                under: format!("[{index}]"),
                camera: Some(camera),
            }),
            None => Err(Error::SceneValue {
                file: file.to_owned(),
                field: format!("[{index}]"),
                message: "needs a `name` (the folder its images go in)".into(),
            }),
        })
        .collect()
}

/// The views of a poses file's lines (blank lines skipped).
fn poses_of_lines(text: &str, file: &Path) -> Result<Vec<ViewCamera>> {
    let mut views = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let place = format!("line {}", k + 1);
        let pose: PoseFile = deserialize(line, file).map_err(|e| match e {
            Error::SceneSyntax {
                file,
                column,
                message,
                ..
            } => Error::SceneSyntax {
                file,
                line: k + 1,
                column,
                message,
            },
            e => e,
        })?;
        let under = format!("{place}: camera");
        let checker = Checker {
            file,
            camera: &under,
        };
        if pose.camera.as_ref().is_some_and(|c| c.name.is_some()) {
            return Err(checker.fail("camera.name", "a pose is named by its own `name`"));
        }
        let transforms = (pose.transforms.iter().enumerate())
            .map(|(i, moved)| {
                let field = format!("{place}: transforms[{i}].transform");
                Ok((moved.object, checker.transform(&field, &moved.transform)?))
            })
            .collect::<Result<Vec<_>>>()?;
        views.push(ViewCamera {
            name: pose.name,
            resolution: pose.camera.as_ref().and_then(|c| c.resolution),
            transforms,
            place,
            under,
            camera: pose.camera,
        });
    }
    Ok(views)
}

impl ViewCamera {
    /// The camera of this view for `scene` (whose objects set a field-of-view or intrinsics
    /// camera's default `near`): its own, or the scene's for a pose that gives none. Also
    /// checks that each instance it moves is one of the scene's, once; `file` is the views
    /// file, for errors.
    pub fn camera(&self, file: &Path, scene: &Scene) -> Result<Camera> {
        let checker = self.checker(file);
        let mut moved = vec![false; scene.objects.len()];
        for (i, (object, m)) in self.transforms.iter().enumerate() {
            let field = format!("{}: transforms[{i}].object", self.place);
            let Some(placed) = scene.instances.iter().find(|p| p.object == *object) else {
                let message = format!(
                    "object {object} is not an instance of the scene (the scene's instances: {})",
                    instance_list(scene)
                );
                return Err(checker.fail(field, message));
            };
            if std::mem::replace(&mut moved[*object], true) {
                return Err(checker.fail(field, format!("object {object} is moved twice")));
            }
            // The placed mesh lies within its moved box, whose corners bound its coordinates.
            let moved_box = placed.mesh.bounds().map(|b| super::moved_box(b, m));
            if let Some((lo, hi)) = moved_box
                && lo.abs().max(hi.abs()).max_element() > MAX_MAGNITUDE
            {
                let field = format!("{}: transforms[{i}].transform", self.place);
                let message = format!(
                    "places the mesh beyond {MAX_MAGNITUDE:e}, the largest coordinate a scene may hold"
                );
                return Err(checker.fail(field, message));
            }
        }
        match &self.camera {
            Some(camera) => checker.camera(camera, &scene.objects),
            None => Ok(scene.camera.clone()),
        }
    }

    fn checker<'a>(&'a self, file: &'a Path) -> Checker<'a> {
        Checker {
            file,
            camera: &self.under,
        }
    }
}

/// The object indices of `scene`'s instances, as an error lists them: `none` or `1, 3, 5`
/// (the first ten, then how many more).
fn instance_list(scene: &Scene) -> String {
    let mut objects: Vec<usize> = scene.instances.iter().map(|p| p.object).collect();
    objects.sort_unstable();
    let shown: Vec<String> = objects.iter().take(10).map(usize::to_string).collect();
    match objects.len() {
        0 => "none".into(),
        n if n > 10 => format!("{}, and {} more", shown.join(", "), n - 10),
        _ => shown.join(", "),
    }
}

/// A scene of the mesh file `path` alone, its parts as `split` asks objects 0, 1, ..., with
/// the camera `camera(bounds)` makes for the mesh's bounding box; the mesh's numbers are
/// checked as a scene's.
pub(super) fn mesh_scene(
    path: &Path,
    split: Split,
    camera: impl FnOnce(Option<(DVec3, DVec3)>) -> Result<Camera>,
) -> Result<Scene> {
    let parts = super::mesh::load_mesh_parts(path, split)?;
    let checker = Checker {
        file: path,
        camera: "camera",
    };
    let objects = checker.soups(path, "", parts)?;
    let n = objects.len();
    Ok(Scene {
        camera: camera(super::bounds(&objects))?,
        lighting: Lighting {
            object_materials: vec![None; n],
            object_values: vec![[0.0; OBJECT_VALUES]; n],
            ..Lighting::default()
        },
        objects,
        warnings: Vec::new(),
        instances: Vec::new(),
    })
}

fn deserialize<T: serde::de::DeserializeOwned>(text: &str, file: &Path) -> Result<T> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let raw = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
        let path = e.path().to_string();
        // `?` stands for a position between fields, which the line and column already give.
        let path = path.trim_end_matches('?').trim_end_matches('.');
        let inner = e.into_inner();
        let message = suggest_name(&strip_position(&inner.to_string()));
        let message = (instance::SHAPES.iter()).fold(message, |m, (serde_says, we_say)| {
            m.replace(serde_says, we_say)
        });
        let message = if path.is_empty() || path == "." {
            message
        } else {
            format!("{path}: {message}")
        };
        Error::SceneSyntax {
            file: file.to_owned(),
            line: inner.line(),
            column: inner.column(),
            message,
        }
    })?;
    // Anything but whitespace after the scene object is an error, not ignored.
    de.end().map_err(|e| Error::SceneSyntax {
        file: file.to_owned(),
        line: e.line(),
        column: e.column(),
        message: strip_position(&e.to_string()),
    })?;
    Ok(raw)
}

/// What a scene file or a views file holds at the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    /// A scene file: an object.
    Scene,
    /// A views file: a list of cameras.
    ViewsFile,
}

/// The error for `text`, meant as a file of `shape`, where it is JSON of another shape: what
/// the file should hold and what it holds, guessing the other kind of file (a scene file given
/// as views, or the reverse), at the value's start; `None` where the shape is right or the
/// text is no JSON, whose own error says more.
fn wrong_shape(text: &str, file: &Path, shape: Shape) -> Option<Error> {
    use serde_json::Value;
    let value: Value = serde_json::from_str(text).ok()?;
    let got = match (&value, shape) {
        (Value::Object(_), Shape::Scene) | (Value::Array(_), Shape::ViewsFile) => return None,
        (Value::Object(_), Shape::ViewsFile) => "an object (is it a scene file?)",
        (Value::Array(_), Shape::Scene) => "a list (is it a views file?)",
        (Value::String(_), _) => "a string",
        (Value::Number(_), _) => "a number",
        (Value::Bool(_), _) => "a boolean",
        (Value::Null, _) => "null",
    };
    let expected = match shape {
        Shape::Scene => "a scene file is a JSON object with a `camera` and `objects`",
        Shape::ViewsFile => "a views file is a JSON list of cameras",
    };
    let before = &text[..text.len() - text.trim_start().len()];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Some(Error::SceneSyntax {
        file: file.to_owned(),
        line: before.matches('\n').count() + 1,
        column: before[line_start..].chars().count() + 1,
        message: format!("{expected}, got {got}"),
    })
}

/// serde's "unknown field `objcts`, expected one of `camera`, `objects`, ..." (or variant, for
/// an object's `type`) becomes "unknown field `objcts`, did you mean `objects`?" where one
/// expected name is within a third of the name's length in edits (at least one edit); other
/// messages are kept.
fn suggest_name(message: &str) -> String {
    let quoted: Vec<&str> = message.split('`').skip(1).step_by(2).collect();
    let is_unknown =
        message.starts_with("unknown field `") || message.starts_with("unknown variant `");
    let Some((given, expected)) = quoted.split_first().filter(|_| is_unknown) else {
        return message.to_owned();
    };
    let limit = (given.chars().count() / 3).max(1);
    let nearest = expected
        .iter()
        .map(|name| (edit_distance(given, name), *name))
        .filter(|(d, _)| *d <= limit)
        .min();
    match nearest {
        Some((_, name)) => {
            let what = message.split('`').next().unwrap_or_default();
            format!("{what}`{given}`, did you mean `{name}`?")
        }
        None => message.to_owned(),
    }
}

/// Levenshtein distance: single-character insertions, deletions and substitutions.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// serde_json appends " at line L column C"; we print the position up front instead.
fn strip_position(message: &str) -> String {
    match message.rfind(" at line ") {
        Some(i) => message[..i].to_owned(),
        None => message.to_owned(),
    }
}

/// Largest coordinate magnitude accepted: beyond it f32 (the GPU's precision) overflows
/// as soon as two values are multiplied.
pub(crate) const MAX_MAGNITUDE: f64 = 1e18;

struct Checker<'a> {
    file: &'a Path,
    /// What the camera's fields are named under: `camera` in a scene, `[k]` in a views file.
    camera: &'a str,
}

impl Checker<'_> {
    fn fail(&self, field: impl Into<String>, message: impl Into<String>) -> Error {
        let rename = |s: String| match self.camera {
            "camera" => s,
            under => s.replace("camera.", &format!("{under}.")),
        };
        let field = field.into();
        Error::SceneValue {
            file: self.file.to_owned(),
            field: match field.as_str() {
                "camera" => self.camera.to_owned(),
                _ => rename(field),
            },
            message: rename(message.into()),
        }
    }

    fn number(&self, field: &str, x: f64) -> Result<f64> {
        match number_problem(x) {
            Some(message) => Err(self.fail(field, message)),
            None => Ok(x),
        }
    }

    fn positive(&self, field: &str, x: f64) -> Result<f64> {
        let x = self.number(field, x)?;
        if x <= 0.0 {
            return Err(self.fail(field, format!("must be > 0 (got {x})")));
        }
        Ok(x)
    }

    fn vector(&self, field: &str, v: [f64; 3]) -> Result<Vec3<f64>> {
        for (k, &x) in v.iter().enumerate() {
            self.number(&format!("{field}[{k}]"), x)?;
        }
        Ok(Vec3::from_array(v))
    }

    /// [`Checker::vector`] as glam's.
    fn point(&self, field: &str, v: [f64; 3]) -> Result<DVec3> {
        self.vector(field, v)
            .map(|v| DVec3::from_array(v.to_array()))
    }

    fn nonzero(&self, field: &str, v: [f64; 3]) -> Result<Vec3<f64>> {
        let v = self.vector(field, v)?;
        let len = length(v);
        if len == 0.0 || !len.is_finite() {
            return Err(self.fail(field, "must be a non-zero vector"));
        }
        Ok(v)
    }

    fn camera(&self, c: &CameraFile, objects: &[Object]) -> Result<Camera> {
        let eye = self.point("camera.eye", c.eye)?;
        let look = match (c.look, c.look_at) {
            (Some(look), None) => self.point("camera.look", look)?,
            (None, Some(target)) => {
                let look = self.point("camera.look_at", target)? - eye;
                if look == DVec3::ZERO {
                    return Err(self.fail("camera.look_at", "is the eye: no direction to look in"));
                }
                look
            }
            (Some(_), Some(_)) => {
                return Err(self.fail(
                    "camera.look_at",
                    "is an alternative to camera.look (a direction): give one of the two",
                ));
            }
            (None, None) => {
                return Err(self.fail(
                    "camera",
                    "needs `look` (a direction) or `look_at` (a point)",
                ));
            }
        };
        if look == DVec3::ZERO {
            return Err(self.fail("camera.look", "must be a non-zero vector"));
        }
        let up = self.point("camera.up", c.up)?;
        if up == DVec3::ZERO {
            return Err(self.fail("camera.up", "must be a non-zero vector"));
        }
        // Relative test: exact or near-exact parallelism leaves no usable horizontal axis.
        // Nearly parallel vectors (angle above ~1e-12 rad) still give a valid frame.
        let side = look.normalize().cross(up.normalize()).length();
        if side <= 1e-12 {
            let look_field = if c.look.is_some() {
                "camera.look"
            } else {
                "the direction from camera.eye to camera.look_at"
            };
            return Err(self.fail("camera.up", format!("is parallel to {look_field}")));
        }
        let resolution = c.resolution.unwrap_or(DEFAULT_RESOLUTION);
        if resolution[0] == 0 || resolution[1] == 0 {
            return Err(self.fail(
                "camera.resolution",
                format!(
                    "must be at least 1x1 pixels (got {}x{})",
                    resolution[0], resolution[1]
                ),
            ));
        }
        let projection = match c.projection {
            ProjectionFile::Perspective => Projection::Perspective,
            ProjectionFile::Orthographic => Projection::Orthographic,
        };
        let (lens, given_distance) = self.lens(c, projection)?;
        let bounds = super::bounds(objects);
        let focal_length = match given_distance {
            Some(d) => d,
            None => camera::default_near(eye, bounds),
        };
        let depth_white = match lens {
            Lens::Size { .. } => focal_length,
            _ => camera::default_depth_white(eye, bounds).max(focal_length),
        };
        let camera = Camera {
            projection,
            eye,
            look,
            up,
            focal_length,
            lens,
            resolution,
            depth_white,
        };
        // Intrinsics or a field of view give the plane's size indirectly: it must stay within
        // what the course's fields may give.
        if let Some(x) = camera.oversized_plane() {
            let field = match lens {
                Lens::Intrinsics { .. } => "camera.intrinsics",
                _ => "camera.fov",
            };
            return Err(self.fail(
                field,
                format!(
                    "gives an image plane of size {x:e}, beyond the supported {MAX_MAGNITUDE:e}"
                ),
            ));
        }
        Ok(camera)
    }

    /// The image plane's description and the distance to it, where the file gives one (the
    /// course's focal length, or `near`).
    fn lens(&self, c: &CameraFile, projection: Projection) -> Result<(Lens, Option<f64>)> {
        let course = [
            ("focal_length", c.focal_length),
            ("width", c.width),
            ("height", c.height),
        ];
        let alternative = match (c.fov.is_some(), c.intrinsics.is_some()) {
            (true, true) => {
                return Err(self.fail(
                    "camera.intrinsics",
                    "is an alternative to camera.fov: give one of the two",
                ));
            }
            (true, false) => Some("fov"),
            (false, true) => Some("intrinsics"),
            (false, false) => None,
        };
        let Some(alternative) = alternative else {
            if c.near.is_some() {
                return Err(self.fail(
                    "camera.near",
                    "goes with fov or intrinsics (the course's camera draws from its focal_length on)",
                ));
            }
            if let Some((missing, _)) = course.iter().find(|(_, x)| x.is_none()) {
                return Err(self.fail(
                    "camera",
                    format!(
                        "missing field `{missing}` (the image plane is given by focal_length, width and height, or by fov or intrinsics)"
                    ),
                ));
            }
            let lens = Lens::Size {
                width: self.positive("camera.width", c.width.unwrap_or_default())?,
                height: self.positive("camera.height", c.height.unwrap_or_default())?,
            };
            let d = self.positive("camera.focal_length", c.focal_length.unwrap_or_default())?;
            return Ok((lens, Some(d)));
        };
        let field = format!("camera.{alternative}");
        if let Some((first, _)) = course.iter().find(|(_, x)| x.is_some()) {
            return Err(self.fail(
                field,
                format!("is an alternative to focal_length, width and height: remove `{first}` or `{alternative}`"),
            ));
        }
        if projection == Projection::Orthographic {
            return Err(self.fail(
                field,
                "needs a perspective camera (an orthographic one takes focal_length, width and height)",
            ));
        }
        let near = c
            .near
            .map(|x| self.positive("camera.near", x))
            .transpose()?;
        if let Some(degrees) = c.fov {
            let degrees = self.number("camera.fov", degrees)?;
            if !(degrees > 0.0 && degrees < 180.0) {
                return Err(self.fail(
                    "camera.fov",
                    format!("must be between 0 and 180 degrees, both excluded (got {degrees})"),
                ));
            }
            return Ok((Lens::Fov { degrees }, near));
        }
        let k = c.intrinsics.as_ref().expect("intrinsics were given");
        let Some(resolution) = c.resolution else {
            return Err(self.fail(
                "camera.intrinsics",
                "needs camera.resolution, the image size in pixels the intrinsics are for",
            ));
        };
        let lens = Lens::Intrinsics {
            fx: self.positive("camera.intrinsics.fx", k.fx)?,
            fy: self.positive("camera.intrinsics.fy", k.fy)?,
            cx: self.number("camera.intrinsics.cx", k.cx)?,
            cy: self.number("camera.intrinsics.cy", k.cy)?,
            resolution,
        };
        Ok((lens, near))
    }

    /// The objects of `objects[i]`: one, or a soup's parts.
    fn object(
        &self,
        i: usize,
        o: &ObjectFile,
        load_mesh: &mut LoadMesh,
        meshes: &mut Meshes,
    ) -> Result<Vec<Object>> {
        let field = |name: &str| format!("objects[{i}].{name}");
        Ok(vec![match o {
            ObjectFile::Sphere { center, radius, .. } => Object::Sphere {
                center: self.vector(&field("center"), *center)?.into(),
                radius: self.positive(&field("radius"), *radius)?,
            },
            ObjectFile::Plane { point, normal, .. } => {
                let n = self.nonzero(&field("normal"), *normal)?;
                Object::Plane {
                    point: self.vector(&field("point"), *point)?.into(),
                    normal: normalize(n).into(),
                }
            }
            ObjectFile::Triangle { corners, .. } => {
                let mut c = [glam::DVec3::ZERO; 3];
                for (k, corner) in corners.iter().enumerate() {
                    c[k] = self
                        .vector(&field(&format!("corners[{k}]")), *corner)?
                        .into();
                }
                Object::Triangle { corners: c }
            }
            ObjectFile::Soup {
                stl,
                obj,
                ply,
                split,
                ..
            } => {
                let name = match (stl, obj, ply) {
                    (Some(name), None, None)
                    | (None, Some(name), None)
                    | (None, None, Some(name)) => name,
                    _ => {
                        return Err(self.fail(
                            format!("objects[{i}]"),
                            "a soup needs exactly one of \"stl\", \"obj\" or \"ply\"",
                        ));
                    }
                };
                let parts = load_mesh(name, split.unwrap_or_default())?;
                return self.soups(Path::new(name), &format!("objects[{i}] "), parts);
            }
            ObjectFile::Instance {
                mesh, transform, ..
            } => {
                let m = match transform {
                    Some(t) => self.transform(&field("transform"), t)?,
                    None => glam::DAffine3::IDENTITY,
                };
                let mesh = meshes.load(mesh, self, &field("mesh"), load_mesh)?;
                let triangles = instance::place(&mesh.triangles, &m);
                self.mesh_values(&format!("objects[{i}] "), &triangles)?;
                let path = mesh.path.clone();
                meshes.placed.push((i, mesh, m));
                Object::Soup { path, triangles }
            }
        }])
    }

    /// The affine map of the transform at `field`: finite numbers, an affine matrix or
    /// non-zero parts, not singular.
    fn transform(&self, field: &str, t: &TransformFile) -> Result<glam::DAffine3> {
        for (under, x) in t.numbers() {
            self.number(&format!("{field}{under}"), x)?;
        }
        t.affine()
            .map_err(|(under, message)| self.fail(format!("{field}{under}"), message))
    }

    /// The objects of a mesh file's `parts`, each a soup of the file `path`; `place` starts
    /// errors, which name the part where there are several.
    fn soups(&self, path: &Path, place: &str, parts: Vec<MeshPart>) -> Result<Vec<Object>> {
        let several = parts.len() > 1;
        (parts.into_iter())
            .map(|part| {
                let place = match several {
                    true => format!("{place}part `{}` ", part.name),
                    false => place.to_owned(),
                };
                self.mesh_values(&place, &part.triangles)?;
                Ok(Object::Soup {
                    path: path.to_owned(),
                    triangles: part.triangles,
                })
            })
            .collect()
    }

    /// Finite components, each at least 0.
    fn color(&self, field: &str, v: [f64; 3]) -> Result<Vec3<f64>> {
        for (k, &x) in v.iter().enumerate() {
            if self.number(&format!("{field}[{k}]"), x)? < 0.0 {
                return Err(self.fail(format!("{field}[{k}]"), format!("must be >= 0 (got {x})")));
            }
        }
        Ok(Vec3::from_array(v))
    }

    /// The scene's materials and lights, and each object's: those of the scene file's
    /// `objects[i]` for each of the `counts[i]` objects it makes.
    fn lighting(&self, raw: &SceneFile, counts: &[usize]) -> Result<Lighting> {
        let mut materials: Vec<Material> = Vec::with_capacity(raw.materials.len());
        let mut by_name: HashMap<&str, usize> = HashMap::new();
        for (i, m) in raw.materials.iter().enumerate() {
            let field = |name: &str| format!("materials[{i}].{name}");
            if by_name.insert(&m.name, i).is_some() {
                let message = format!(
                    "`{}` is the name of an earlier material too",
                    m.name.escape_debug()
                );
                return Err(self.fail(field("name"), message));
            }
            let phong_exponent = self.number(&field("phong_exponent"), m.phong_exponent)?;
            if phong_exponent < 0.0 {
                let message = format!("must be >= 0 (got {phong_exponent})");
                return Err(self.fail(field("phong_exponent"), message));
            }
            materials.push(Material {
                name: m.name.clone(),
                ka: self.color(&field("ka"), m.ka)?.into(),
                kd: self.color(&field("kd"), m.kd)?.into(),
                ks: self.color(&field("ks"), m.ks)?.into(),
                km: self.color(&field("km"), m.km)?.into(),
                phong_exponent,
            });
        }
        let lights = raw
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let field = |name: &str| format!("lights[{i}].{name}");
                Ok(match l {
                    LightFile::Directional { direction, color } => Light::Directional {
                        direction: self.nonzero(&field("direction"), *direction)?.into(),
                        color: self.color(&field("color"), *color)?.into(),
                    },
                    LightFile::Point { position, color } => Light::Point {
                        position: self.vector(&field("position"), *position)?.into(),
                        color: self.color(&field("color"), *color)?.into(),
                    },
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let object_materials = raw
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let Some(name) = o.material() else {
                    return Ok(None);
                };
                match by_name.get(name) {
                    Some(&k) => Ok(Some(k)),
                    None => Err(self.fail(
                        format!("objects[{i}].material"),
                        format!(
                            "no material is named `{}` in `materials`",
                            name.escape_debug()
                        ),
                    )),
                }
            })
            .collect::<Result<Vec<_>>>()?;
        let object_values = raw
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| self.object_values(&format!("objects[{i}].values"), o.values()))
            .collect::<Result<Vec<_>>>()?;
        Ok(Lighting {
            materials,
            lights,
            object_materials: per_object(object_materials, counts),
            object_values: per_object(object_values, counts),
        })
    }

    /// An object's own `values` for shade hooks: 1 to [`OBJECT_VALUES`] numbers, checked as
    /// every number of a scene (within [`MAX_MAGNITUDE`], so inside f32's range, in which hooks
    /// read them), the rest 0; all 0 where none are given.
    fn object_values(&self, field: &str, values: Option<&[f64]>) -> Result<[f64; OBJECT_VALUES]> {
        let mut out = [0.0; OBJECT_VALUES];
        let Some(values) = values else {
            return Ok(out);
        };
        if values.is_empty() || values.len() > OBJECT_VALUES {
            let message = format!(
                "must hold 1 to {OBJECT_VALUES} numbers (got {})",
                values.len()
            );
            return Err(self.fail(field, message));
        }
        for (k, &x) in values.iter().enumerate() {
            out[k] = self.number(&format!("{field}[{k}]"), x)?;
        }
        Ok(out)
    }

    /// Every coordinate finite and within [`MAX_MAGNITUDE`]; errors name `place` and the
    /// triangle.
    fn mesh_values(&self, place: &str, triangles: &[Triangle]) -> Result<()> {
        // The field is named only for a bad value: formatting a name for every coordinate
        // would dominate a large mesh's load.
        for (k, t) in triangles.iter().enumerate() {
            for x in t.iter().flat_map(|c| c.to_array()) {
                if let Some(message) = number_problem(x) {
                    return Err(self.fail(format!("{place}triangle {k}"), message));
                }
            }
        }
        Ok(())
    }
}

/// The meshes a scene declares, each loaded when an instance first places it, and the
/// instances placed so far: the file's object index, the mesh and the transform.
struct Meshes<'a> {
    declared: &'a BTreeMap<String, MeshFile>,
    loaded: HashMap<String, Arc<Mesh>>,
    placed: Vec<(usize, Arc<Mesh>, glam::DAffine3)>,
}

impl Meshes<'_> {
    /// Mesh `name`'s file and triangles (an instance's `field` names it).
    fn load(
        &mut self,
        name: &str,
        checker: &Checker,
        field: &str,
        load_mesh: &mut LoadMesh,
    ) -> Result<Arc<Mesh>> {
        if !self.loaded.contains_key(name) {
            let Some(declared) = self.declared.get(name) else {
                let known: Vec<&str> = self.declared.keys().map(String::as_str).collect();
                let nearest = (known.iter())
                    .map(|k| (edit_distance(name, k), *k))
                    .filter(|(d, _)| *d <= (name.chars().count() / 3).max(1))
                    .min();
                let message = match (known.is_empty(), nearest) {
                    (true, _) => format!("no mesh `{name}`: the scene declares none in \"meshes\""),
                    (false, Some((_, k))) => format!("unknown mesh `{name}`, did you mean `{k}`?"),
                    (false, None) => format!(
                        "unknown mesh `{name}`, expected one of `{}`",
                        known.join("`, `")
                    ),
                };
                return Err(checker.fail(field, message));
            };
            let place = format!("meshes.{name}");
            let file = match (&declared.stl, &declared.obj, &declared.ply) {
                (Some(f), None, None) | (None, Some(f), None) | (None, None, Some(f)) => f,
                _ => {
                    return Err(checker.fail(
                        place,
                        "a mesh needs exactly one of \"stl\", \"obj\" or \"ply\"",
                    ));
                }
            };
            let triangles: Vec<Triangle> = (load_mesh(file, Split::None)?.into_iter())
                .flat_map(|part| part.triangles)
                .collect();
            checker.mesh_values(&format!("{place} "), &triangles)?;
            let mesh = Mesh {
                path: PathBuf::from(file),
                triangles,
            };
            self.loaded.insert(name.to_owned(), Arc::new(mesh));
        }
        Ok(self.loaded[name].clone())
    }
}

/// `values[i]` repeated `counts[i]` times, for each `i`.
fn per_object<T: Clone>(values: Vec<T>, counts: &[usize]) -> Vec<T> {
    (values.into_iter().zip(counts))
        .flat_map(|(v, &n)| std::iter::repeat_n(v, n))
        .collect()
}

/// What is wrong with a scene number `x`, if anything: not finite, or beyond [`MAX_MAGNITUDE`].
fn number_problem(x: f64) -> Option<String> {
    if !x.is_finite() {
        return Some(format!("must be a finite number (got {x})"));
    }
    if x.abs() > MAX_MAGNITUDE {
        return Some(format!(
            "magnitude {x:e} exceeds the supported {MAX_MAGNITUDE:e}"
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene of `objects` (JSON) with a fixed camera, its soups the OBJ `MESH`.
    fn scene_of(objects: &str) -> Result<Scene> {
        const MESH: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\no a\ng x\nf 1 2 3\ng y\nf 1 2 3\n\
                            o b\nf 1 2 3\n";
        let text = format!(
            r#"{{"camera": {{"eye": [0, 0, 5], "look": [0, 0, -1], "up": [0, 1, 0], "fov": 40}},
                "materials": [{{"name": "m", "ka": [0, 0, 0], "kd": [0, 0, 0], "ks": [0, 0, 0],
                                "km": [0, 0, 0], "phong_exponent": 1}}],
                "objects": {objects}}}"#
        );
        parse(&text, Path::new("s.json"), &mut |name, split| {
            super::super::parse_mesh(MESH.as_bytes(), Path::new(name), split)
        })
    }

    #[test]
    fn a_split_soup_is_an_object_a_part_and_shares_its_material_and_values() {
        let soups = |split: &str| {
            format!(
                r#"[{{"type": "soup", "obj": "m.obj", {split} "material": "m", "values": [7]}},
                    {{"type": "sphere", "center": [0, 0, 0], "radius": 1, "values": [9]}}]"#
            )
        };
        for (split, parts) in [
            ("", 2),
            (r#""split": "objects","#, 2),
            (r#""split": "groups","#, 3),
            (r#""split": "none","#, 1),
        ] {
            let scene = scene_of(&soups(split)).unwrap();
            let n = parts + 1;
            assert_eq!(scene.objects.len(), n, "{split}");
            assert!(matches!(scene.objects[parts], Object::Sphere { .. }));
            let mut materials = vec![Some(0); parts];
            materials.push(None);
            assert_eq!(scene.lighting.object_materials, materials, "{split}");
            let values: Vec<f64> = scene.lighting.object_values.iter().map(|v| v[0]).collect();
            let mut want = vec![7.0; parts];
            want.push(9.0);
            assert_eq!(values, want, "{split}");
        }
        let err = scene_of(&soups(r#""split": "grups","#)).unwrap_err();
        assert!(
            err.to_string()
                .contains("unknown variant `grups`, did you mean `groups`?"),
            "{err}"
        );
    }

    #[test]
    fn edit_distance_counts_insertions_deletions_and_substitutions() {
        assert_eq!(edit_distance("objcts", "objects"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("same", "same"), 0);
    }

    #[test]
    fn unknown_names_get_the_nearest_expected_one() {
        let m = "unknown field `objcts`, expected one of `camera`, `objects`, `materials`";
        assert_eq!(
            suggest_name(m),
            "unknown field `objcts`, did you mean `objects`?"
        );
        let m = "unknown variant `sphre`, expected one of `sphere`, `plane`, `triangle`, `soup`";
        assert_eq!(
            suggest_name(m),
            "unknown variant `sphre`, did you mean `sphere`?"
        );
        // Too far from every name: the list stays.
        let m = "unknown field `zzzzzz`, expected `camera` or `objects`";
        assert_eq!(suggest_name(m), m);
        let m = "missing field `camera`";
        assert_eq!(suggest_name(m), m);
    }
}
