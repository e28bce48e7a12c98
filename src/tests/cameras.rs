//! Cameras given other ways than the course's: a field of view and a point to look at, or
//! pixel intrinsics (OpenCV's convention). The same camera described each way renders the same
//! image; an off-centre principal point moves the image by whole pixels as it should.

use super::common;

use std::path::Path;

use raycast::Scene;
use raycast::render::{self, AnyImages};
use serde_json::{Value, json};

/// Course scene `name` with its camera replaced by `camera(course camera)`.
fn with_camera(name: &str, camera: impl Fn(&Course) -> Value) -> Scene {
    let path = common::repo_path(&format!("scenes/course/{name}.json"));
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let course = Course::of(&scene["camera"]);
    scene["camera"] = camera(&course);
    let base = path.parent().unwrap().to_owned();
    Scene::from_json(
        &scene.to_string(),
        Path::new("rewritten.json"),
        &mut |file, split| raycast::scene::load_mesh_parts(&base.join(file), split),
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The numbers of a course camera.
struct Course {
    eye: [f64; 3],
    look: [f64; 3],
    up: Value,
    d: f64,
    width: f64,
    height: f64,
    resolution: [u32; 2],
}

impl Course {
    fn of(camera: &Value) -> Course {
        let v3 = |key: &str| -> [f64; 3] { serde_json::from_value(camera[key].clone()).unwrap() };
        Course {
            eye: v3("eye"),
            look: v3("look"),
            up: camera["up"].clone(),
            d: camera["focal_length"].as_f64().unwrap(),
            width: camera["width"].as_f64().unwrap(),
            height: camera["height"].as_f64().unwrap(),
            resolution: serde_json::from_value(camera["resolution"].clone()).unwrap_or([640, 360]),
        }
    }

    /// The same camera by vertical field of view and the point one look vector ahead.
    fn as_fov(&self) -> Value {
        let target: Vec<f64> = (0..3).map(|k| self.eye[k] + self.look[k]).collect();
        let fov = 2.0 * (self.height / (2.0 * self.d)).atan().to_degrees();
        json!({"eye": self.eye, "look_at": target, "up": self.up, "fov": fov, "near": self.d,
               "resolution": self.resolution})
    }

    /// The same camera by pixel intrinsics, principal point moved by `shift` pixels.
    fn as_intrinsics(&self, shift: [f64; 2]) -> Value {
        let [nx, ny] = self.resolution.map(f64::from);
        let k = json!({"fx": self.d * nx / self.width, "fy": self.d * ny / self.height,
                       "cx": (nx - 1.0) / 2.0 + shift[0], "cy": (ny - 1.0) / 2.0 + shift[1]});
        json!({"eye": self.eye, "look": self.look, "up": self.up, "intrinsics": k,
               "near": self.d, "resolution": self.resolution})
    }
}

/// The ids of `scene` rendered in `mode`.
fn ids_in(scene: &Scene, mode: &str) -> Vec<i32> {
    let mode = mode.parse().unwrap();
    match render::render(scene, mode, Some(common::gpu()), None).unwrap() {
        AnyImages::F32(images) => images.id,
        AnyImages::F64(images) => images.id,
    }
}

fn ids(scene: &Scene) -> Vec<i32> {
    ids_in(scene, "gpu:f32")
}

#[test]
fn a_course_camera_rewritten_with_fov_and_look_at_or_intrinsics_renders_the_same_ids() {
    for name in common::COURSE_SCENES {
        let course = common::course_scene(name);
        let reference = ids(&course);
        for (how, scene) in [
            ("fov + look_at", with_camera(name, Course::as_fov)),
            (
                "intrinsics",
                with_camera(name, |c| c.as_intrinsics([0.0, 0.0])),
            ),
        ] {
            let got = ids(&scene);
            let differ = got.iter().zip(&reference).filter(|(a, b)| a != b).count();
            // Rounding of the converted numbers only: at most 0.01% of the pixels.
            assert!(
                differ as f64 <= 1e-4 * reference.len() as f64,
                "{name} by {how}: {differ} of {} pixels differ",
                reference.len()
            );
        }
    }
}

#[test]
fn moving_the_principal_point_by_whole_pixels_moves_the_image() {
    let (dx, dy) = (7, 4);
    let centred = with_camera("bunny", |c| c.as_intrinsics([0.0, 0.0]));
    let moved = with_camera("bunny", |c| c.as_intrinsics([dx as f64, dy as f64]));
    let [nx, ny] = centred.camera.resolution;
    // In f64, where a pixel's ray computed two ways differs by far less than f32's rounding.
    let (a, b) = (ids_in(&centred, "cpu:f64"), ids_in(&moved, "cpu:f64"));
    // Pixel (i, j) of the moved image looks where pixel (i - dy, j - dx) of the centred one
    // does.
    let mut differ = 0;
    let mut compared = 0;
    for i in dy..ny as usize {
        for j in dx..nx as usize {
            compared += 1;
            differ += usize::from(b[i * nx as usize + j] != a[(i - dy) * nx as usize + j - dx]);
        }
    }
    assert!(
        differ as f64 <= 1e-4 * compared as f64,
        "{differ} of {compared} pixels differ"
    );
    // And the image did move: the unshifted comparison differs at the bunny's outline.
    let unmoved = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert!(unmoved > 100, "only {unmoved} pixels changed");
}
