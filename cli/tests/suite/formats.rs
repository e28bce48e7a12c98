//! The files other tools read: `render.exr`, `render.npz`, `depth16.png`, planar `z.npy` and
//! `camera.json`, checked against the npy arrays of the same render and against the scene's
//! geometry; and a mesh file rendered directly, framed by its default view.

use crate::common;

use std::path::Path;

use glam::{DMat3, DMat4, DVec3};
use tempfile::TempDir;

/// `raycast render ARGS -o DIR` into a new folder; panics unless it succeeds.
fn render(args: &[&str]) -> TempDir {
    let dir = tempfile::tempdir().unwrap();
    let output = common::raycast()
        .arg("render")
        .args(args)
        .arg("-o")
        .arg(dir.path())
        .env("NODEVICE_SELECT", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "render {args:?} failed:\n{stderr}");
    dir
}

fn course(name: &str) -> String {
    common::repo_path(&format!("scenes/course/{name}.json"))
        .display()
        .to_string()
}

/// An npy file's dtype, shape and data.
fn npy(path: &Path) -> (String, Vec<usize>, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = String::from_utf8_lossy(&bytes[10..10 + len]).into_owned();
    let field = |key: &str, end: char| {
        let from = header.find(key).unwrap() + key.len();
        header[from..][..header[from..].find(end).unwrap()].to_owned()
    };
    let shape = field("'shape': (", ')')
        .split(',')
        .filter_map(|d| d.trim().parse().ok())
        .collect();
    (field("'descr': '", '\''), shape, bytes[10 + len..].to_vec())
}

/// An npy file's values as f64 (float32, float64 or int32).
fn npy_values(path: &Path) -> Vec<f64> {
    let (dtype, _, data) = npy(path);
    match dtype.as_str() {
        "<f4" => data
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64)
            .collect(),
        "<f8" => data
            .chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect(),
        "<i4" => data
            .chunks(4)
            .map(|c| i32::from_le_bytes(c.try_into().unwrap()) as f64)
            .collect(),
        other => panic!("unexpected dtype {other}"),
    }
}

/// The EXR's channels by name, each as raw 32-bit words.
fn exr_channels(path: &Path) -> Vec<(String, Vec<u32>)> {
    use exr::prelude::FlatSamples;
    let image = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
    (image.layer_data.channel_data.list.iter())
        .map(|c| {
            let words = match &c.sample_data {
                FlatSamples::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
                FlatSamples::F16(_) => panic!("no f16 channels are written"),
            };
            (c.name.to_string(), words)
        })
        .collect()
}

/// The words an EXR channel should hold: the npy file's values rounded to f32.
fn f32_words(values: &[f64]) -> Vec<u32> {
    values.iter().map(|&x| (x as f32).to_bits()).collect()
}

#[test]
fn exr_channels_equal_the_npy_arrays() {
    let scene = course("sphere-and-plane");
    for extra in [
        &["--precision", "f32"][..],
        &["--precision", "f32", "--depth", "z", "--spp", "4"],
        // f64: the EXR holds the values rounded to f32.
        &["--device", "cpu", "--precision", "f64"],
    ] {
        let mut args = vec![scene.as_str(), "--size", "96x54", "--format", "npy,exr"];
        args.extend_from_slice(extra);
        let out = render(&args);
        let dir = out.path();
        let depth = if extra.contains(&"z") {
            "z"
        } else {
            "distance"
        };
        let normal = npy_values(&dir.join("normal.npy"));
        let ids: Vec<u32> = npy_values(&dir.join("id.npy"))
            .iter()
            .map(|&id| id as i32 as u32)
            .collect();
        let mut expected = vec![
            (
                "N.X",
                f32_words(&normal.iter().step_by(3).copied().collect::<Vec<_>>()),
            ),
            (
                "N.Y",
                f32_words(
                    &normal
                        .iter()
                        .skip(1)
                        .step_by(3)
                        .copied()
                        .collect::<Vec<_>>(),
                ),
            ),
            (
                "N.Z",
                f32_words(
                    &normal
                        .iter()
                        .skip(2)
                        .step_by(3)
                        .copied()
                        .collect::<Vec<_>>(),
                ),
            ),
            (
                "Z",
                f32_words(&npy_values(&dir.join(format!("{depth}.npy")))),
            ),
            ("id", ids),
        ];
        if extra.contains(&"--spp") {
            expected.push(("A", f32_words(&npy_values(&dir.join("alpha.npy")))));
        }
        let mut got = exr_channels(&dir.join("render.exr"));
        got.sort();
        expected.sort();
        let names = |v: &[(String, Vec<u32>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        let expected: Vec<(String, Vec<u32>)> = expected
            .into_iter()
            .map(|(n, w)| (n.to_owned(), w))
            .collect();
        assert_eq!(names(&got), names(&expected), "{extra:?}");
        for ((name, got), (_, want)) in got.iter().zip(&expected) {
            assert!(
                got == want,
                "{extra:?}: channel {name} differs from the npy file"
            );
        }
        // Misses: id 0xFFFFFFFF, Z +inf.
        let ids = &expected.iter().find(|(n, _)| n == "id").unwrap().1;
        assert!(ids.contains(&u32::MAX) && ids.iter().any(|&id| id != u32::MAX));
    }
}

#[test]
fn exr_channels_follow_the_outputs_asked_for() {
    let scene = course("sphere-and-plane");
    let out = render(&[
        &scene,
        "--size",
        "32x18",
        "--format",
        "exr",
        "--outputs",
        "id",
    ]);
    let names: Vec<String> = exr_channels(&out.path().join("render.exr"))
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(names, ["id"]);
}

#[test]
fn npz_holds_the_npy_files() {
    let scene = course("bunny");
    let out = render(&[
        &scene, "--size", "64x36", "--format", "npy,npz", "--spp", "4",
    ]);
    let dir = out.path();
    let file = std::fs::File::open(dir.join("render.npz")).unwrap();
    let mut zip = zip::ZipArchive::new(file).unwrap();
    let mut names = Vec::new();
    for k in 0..zip.len() {
        let mut entry = zip.by_index(k).unwrap();
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut bytes).unwrap();
        let name = entry.name().unwrap().into_owned();
        assert_eq!(bytes, std::fs::read(dir.join(&name)).unwrap(), "{name}");
        names.push(name);
    }
    names.sort();
    assert_eq!(names, ["alpha.npy", "distance.npy", "id.npy", "normal.npy"]);
}

/// `depth16.png`'s levels.
fn depth16(dir: &Path) -> Vec<u16> {
    match image::open(dir.join("depth16.png")).unwrap() {
        image::DynamicImage::ImageLuma16(img) => img.into_raw(),
        other => panic!("depth16.png is not 16-bit grey: {:?}", other.color()),
    }
}

#[test]
fn depth16_is_the_depth_times_the_scale_rounded() {
    let scene = course("sphere-and-plane");
    for (extra, depth, scale) in [
        (&["--depth", "distance"][..], "distance", 1000.0),
        (
            &["--depth", "z", "--depth-scale", "20000"][..],
            "z",
            20000.0,
        ),
    ] {
        let mut args = vec![scene.as_str(), "--size", "96x54", "--format", "npy,depth16"];
        args.extend_from_slice(extra);
        let out = render(&args);
        let levels = depth16(out.path());
        let values = npy_values(&out.path().join(format!("{depth}.npy")));
        let mut beyond = 0;
        for (&level, &d) in levels.iter().zip(&values) {
            let want = (d * scale).round();
            if d.is_finite() && want <= 65535.0 {
                assert_eq!(f64::from(level), want, "{depth} {d}");
            } else {
                beyond += usize::from(d.is_finite());
                assert_eq!(level, 0, "a miss or a depth beyond 65535 is 0");
            }
        }
        // At 20000 levels a unit, much of the plane (beyond 3.3) is out of range.
        assert!(
            scale <= 1000.0 || beyond > 100,
            "{depth}: {beyond} beyond the range"
        );
    }
}

/// camera.json as JSON.
fn camera_json(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("camera.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn depth16_holds_planar_z_unless_asked_and_camera_json_says_which() {
    let scene = course("sphere-and-plane");
    let base = [scene.as_str(), "--size", "64x36", "--device", "cpu"];
    let run = |extra: &[&str]| render(&[&base[..], extra].concat());
    let default = run(&["--format", "npy,depth16"]);
    let z = run(&["--format", "npy,depth16", "--depth", "z"]);
    let distance = run(&["--format", "depth16", "--depth", "distance"]);
    // The arrays keep distance by default; depth16 holds z, as it does with --depth z.
    assert!(default.path().join("distance.npy").exists());
    assert!(!default.path().join("z.npy").exists());
    assert_eq!(depth16(default.path()), depth16(z.path()));
    assert_ne!(depth16(default.path()), depth16(distance.path()));
    for (dir, arrays, depth16) in [
        (&default, "distance", "z"),
        (&z, "z", "z"),
        (&distance, "distance", "distance"),
    ] {
        let json = camera_json(dir.path());
        assert_eq!(json["depth"], arrays);
        assert_eq!(json["depth16"], depth16);
        assert_eq!(json["depth16_scale"], 1000.0);
    }
    // Without depth16, camera.json does not describe one.
    let png = run(&[]);
    assert!(camera_json(png.path()).get("depth16").is_none());
}

/// The world points Open3D's `PointCloud.create_from_depth_image(depth, intrinsic, extrinsic,
/// depth_scale)` makes of depth16.png (cpp/open3d/geometry/PointCloudFactory.cpp), by pixel
/// with its level: for column `u` and row `v` with a level above 0, z = level / depth_scale
/// (in float32, as Open3D's float depth image holds it), x = (u - cx) z / fx,
/// y = (v - cy) z / fy, and the point is inverse(extrinsic) (x, y, z, 1); the intrinsics are
/// camera.json's `K`, the extrinsic its `world_to_camera`.
fn open3d_points(dir: &Path, depth_scale: f64) -> Vec<(usize, DVec3)> {
    let json = camera_json(dir);
    let rows = |key: &str| -> Vec<Vec<f64>> { serde_json::from_value(json[key].clone()).unwrap() };
    let k = rows("K");
    let (fx, fy, cx, cy) = (k[0][0], k[1][1], k[0][2], k[1][2]);
    let e = rows("world_to_camera");
    let extrinsic =
        DMat4::from_cols_array_2d(&[0, 1, 2, 3].map(|c| [e[0][c], e[1][c], e[2][c], e[3][c]]));
    let camera_pose = extrinsic.inverse();
    let width = json["width"].as_u64().unwrap() as usize;
    (depth16(dir).iter().enumerate())
        .filter(|(_, level)| **level > 0)
        .map(|(p, &level)| {
            let (u, v) = ((p % width) as f64, (p / width) as f64);
            let z = f64::from(f32::from(level) / depth_scale as f32);
            let local = DVec3::new((u - cx) * z / fx, (v - cy) * z / fy, z);
            (p, camera_pose.transform_point3(local))
        })
        .collect()
}

#[test]
fn depth16_back_projected_as_open3d_does_puts_the_floor_on_its_plane() {
    // The course's floor, y = -0.5 (object 1), under a sphere.
    let scene = common::repo_path("scenes/ray-tracing/sphere-and-plane.json");
    let scene = scene.display().to_string();
    let args = [scene.as_str(), "--size", "160x90", "--device", "cpu"];
    let floor_error = |extra: &[&str]| {
        let out = render(&[&args[..], &["--format", "npy,depth16"], extra].concat());
        let ids = npy_values(&out.path().join("id.npy"));
        let floor: Vec<f64> = (open3d_points(out.path(), 1000.0).into_iter())
            .filter(|(p, _)| ids[*p] == 1.0)
            .map(|(_, point)| (point.y + 0.5).abs())
            .collect();
        assert!(floor.len() > 2000, "{} floor pixels", floor.len());
        floor.into_iter().fold(0.0, f64::max)
    };
    let error = floor_error(&[]);
    assert!(error <= 1e-3, "the floor lands up to {error} off y = -0.5");
    // Distance read as if it were z puts the floor far off its plane.
    let error = floor_error(&["--depth", "distance"]);
    assert!(error > 0.01, "distance puts the floor only {error} off");
}

#[test]
fn depth16_in_bands_equals_the_whole_image() {
    let scene = course("bunny");
    let args = [
        scene.as_str(),
        "--size",
        "64x36",
        "--format",
        "depth16",
        "--precision",
        "f32",
    ];
    let whole = render(&args);
    let mut banded = args.to_vec();
    banded.extend(["--band-rows", "7"]);
    let bands = render(&banded);
    assert_eq!(depth16(whole.path()), depth16(bands.path()));
    assert!(bands.path().join("camera.json").exists());
}

/// camera.json's K and camera_to_world.
fn camera_of(dir: &Path) -> (DMat3, DMat4) {
    let text = std::fs::read_to_string(dir.join("camera.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let rows = |key: &str| -> Vec<Vec<f64>> { serde_json::from_value(json[key].clone()).unwrap() };
    let k = rows("K");
    let m = rows("camera_to_world");
    let k = DMat3::from_cols_array_2d(&[0, 1, 2].map(|c| [k[0][c], k[1][c], k[2][c]]));
    let m = DMat4::from_cols_array_2d(&[0, 1, 2, 3].map(|c| [m[0][c], m[1][c], m[2][c], m[3][c]]));
    (k, m)
}

/// Writes sphere-and-plane with `camera` (JSON) into `dir`; returns its path.
fn sphere_and_plane_with(dir: &Path, camera: &str) -> String {
    let text = format!(
        r#"{{"camera": {camera}, "objects": [{{"type": "sphere", "center": [0.2, 0.1, 0], "radius": 0.5}},
            {{"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}}]}}"#
    );
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn z_back_projected_with_camera_json_lands_on_the_sphere() {
    let scratch = tempfile::tempdir().unwrap();
    let (center, radius) = (DVec3::new(0.2, 0.1, 0.0), 0.5);
    for (camera, extra) in [
        (
            r#"{"eye": [0, 0, 5], "look": [0, 0, -1], "up": [0, 1, 0], "focal_length": 3,
                "width": 1.6, "height": 0.9, "resolution": [96, 54]}"#,
            &["--precision", "f32"][..],
        ),
        (
            r#"{"eye": [1, 2, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                "resolution": [80, 60]}"#,
            &["--device", "cpu", "--precision", "f64"],
        ),
        (
            r#"{"eye": [-1, 0.5, 3], "look_at": [0.2, 0, 0], "up": [0, 1, 0.2],
                "intrinsics": {"fx": 90, "fy": 80, "cx": 30.5, "cy": 40}, "resolution": [96, 64]}"#,
            &["--precision", "f32"],
        ),
    ] {
        let scene = sphere_and_plane_with(scratch.path(), camera);
        let mut args = vec![scene.as_str(), "--format", "npy", "--depth", "z"];
        args.extend_from_slice(extra);
        let out = render(&args);
        let dir = out.path();
        let (k, camera_to_world) = camera_of(dir);
        let z = npy_values(&dir.join("z.npy"));
        let ids = npy_values(&dir.join("id.npy"));
        let (_, shape, _) = npy(&dir.join("z.npy"));
        let width = shape[1];
        let inverse = k.inverse();
        let mut on_sphere = 0;
        for (p, (&z, &id)) in z.iter().zip(&ids).enumerate() {
            if id != 0.0 {
                continue;
            }
            let (i, j) = ((p / width) as f64, (p % width) as f64);
            let local = inverse * DVec3::new(j, i, 1.0) * z;
            let world = camera_to_world.transform_point3(local);
            let off = ((world - center).length() / radius - 1.0).abs();
            assert!(
                off <= 1e-4,
                "{camera}: pixel ({i}, {j}) is {off:e} off the sphere"
            );
            on_sphere += 1;
        }
        assert!(
            on_sphere > 100,
            "{camera}: {on_sphere} pixels on the sphere"
        );
    }
}

#[test]
fn a_mesh_file_renders_framed_by_its_default_view() {
    let mesh = common::repo_path("scenes/bunny.stl").display().to_string();
    let out = render(&[&mesh, "--size", "96x54", "--format", "npy"]);
    let dir = out.path();
    let ids = npy_values(&dir.join("id.npy"));
    let (w, h) = (96, 54);
    assert!(
        ids.iter().filter(|&&id| id == 0.0).count() > 200,
        "the mesh is seen"
    );
    // The bounding box's sphere fits the image: no hit on its border.
    for (p, &id) in ids.iter().enumerate() {
        let (i, j) = (p / w, p % w);
        if i == 0 || j == 0 || i == h - 1 || j == w - 1 {
            assert_eq!(id, -1.0, "a hit on the border at ({i}, {j})");
        }
    }
    // Every vertex projects inside the image, in front of the camera.
    let (k, camera_to_world) = camera_of(dir);
    let to_camera = camera_to_world.inverse();
    let triangles = raycast::load_mesh(mesh.as_ref()).unwrap();
    for corner in triangles.iter().flatten() {
        let local = to_camera.transform_point3(DVec3::from_array(corner.to_array()));
        assert!(local.z > 0.0);
        let pixel = k * (local / local.z);
        assert!((0.0..w as f64).contains(&pixel.x) && (0.0..h as f64).contains(&pixel.y));
    }
    // The options replace the default view's settings.
    let out = render(&[
        &mesh,
        "--size",
        "32x18",
        "--fov",
        "25",
        "--eye",
        "0,0.1,-1",
        "--up",
        "1,1,0",
        "--look-at",
        "0,0.1,0",
    ]);
    let text = std::fs::read_to_string(out.path().join("camera.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let scene = &json["scene_camera"];
    assert_eq!(scene["fov"], 25.0);
    assert_eq!(scene["eye"], serde_json::json!([0.0, 0.1, -1.0]));
    assert_eq!(scene["look"], serde_json::json!([0.0, 0.0, 1.0]));
}
