//! The course's six scenes rendered on the GPU (lavapipe in CI) against the course's 18
//! reference renders (made in f64 by the course's own program), with the lecture's (textbook)
//! algorithms.
//!
//! - f64 kernel: every pixel of all 18 pictures is identical.
//! - f32 kernel, tolerances of the foundation issue: the id picture differs on at most 0.01% of
//!   pixels; depth and normal pictures are identical on at least 99.9% of pixels and, wherever
//!   the id agrees, differ by at most one level. f32 rounding moves a few values across an
//!   8-bit truncation boundary and a few silhouette pixels across an edge.
//!   One exemption, itself asserted: in `bunny` and `inside-a-sphere` the walls x = +-1 and
//!   y = +-1 meet in creases that project exactly onto the pixel diagonals |us| = |vs|
//!   (i + j = 499 and j - i = 140 at 640x360). On those pixels the two walls are at the same
//!   distance up to the scene's `width` = 1.7777777778 exceeding 16/9 by 1.25e-11 (relative),
//!   far below f32 resolution, so f32 picks either wall. Every f32 id mismatch in those scenes
//!   must lie on those diagonals, and off them the 0.01% bound holds.

use crate::common;

use common::*;
use raycast::Algorithm::Textbook;
use raycast::Pictures;
use raycast::Precision;

struct Comparison {
    name: String,
    pixels: usize,
    id: PixelDiff,
    depth: PixelDiff,
    depth_same_id: PixelDiff,
    normal: PixelDiff,
    normal_same_id: PixelDiff,
    /// (row, column) of every pixel whose id differs.
    id_mismatches: Vec<(u32, u32)>,
}

fn compare_with_course(name: &str, precision: Precision) -> (Comparison, Pictures) {
    let scene = course_scene(name);
    assert_eq!(scene.camera.resolution, [640, 360]);
    let ours = api_render(gpu(), &scene, precision, Textbook).pictures();
    let pixels = (ours.width * ours.height) as usize;
    let id_ref = course_render(name, "id");
    let same_id: Vec<bool> = ours
        .id
        .chunks(3)
        .zip(id_ref.chunks(3))
        .map(|(a, b)| a == b)
        .collect();
    let id_mismatches = (0..pixels)
        .filter(|&k| !same_id[k])
        .map(|k| (k as u32 / ours.width, k as u32 % ours.width))
        .collect();
    let depth_ref = course_render(name, "depth");
    let normal_ref = course_render(name, "normal");
    let c = Comparison {
        name: format!("{name} ({precision})"),
        pixels,
        id: diff(&ours.id, &id_ref, 3, None),
        depth: diff(&ours.depth, &depth_ref, 1, None),
        depth_same_id: diff(&ours.depth, &depth_ref, 1, Some(&same_id)),
        normal: diff(&ours.normal, &normal_ref, 3, None),
        normal_same_id: diff(&ours.normal, &normal_ref, 3, Some(&same_id)),
        id_mismatches,
    };
    println!(
        "{}: id differs on {} px; depth on {} px (max {} level where ids agree); \
         normal on {} px (max {} level where ids agree); of {}",
        c.name,
        c.id.differing,
        c.depth.differing,
        c.depth_same_id.max_level,
        c.normal.differing,
        c.normal_same_id.max_level,
        c.pixels
    );
    (c, ours)
}

/// Saves our pictures next to the course's for a failed scene and returns the folder.
fn save_all(name: &str, ours: &Pictures) -> std::path::PathBuf {
    let (w, h) = (ours.width, ours.height);
    save_failure(
        &format!("{name}.id"),
        &ours.id,
        &course_render(name, "id"),
        w,
        h,
        3,
    );
    save_failure(
        &format!("{name}.depth"),
        &ours.depth,
        &course_render(name, "depth"),
        w,
        h,
        1,
    );
    save_failure(
        &format!("{name}.normal"),
        &ours.normal,
        &course_render(name, "normal"),
        w,
        h,
        3,
    )
}

/// Pixels whose centre ray has |us| = |vs| at 640x360 (see the module comment).
fn on_crease_diagonal((i, j): (u32, u32)) -> bool {
    i + j == 499 || j == i + 140
}

fn check_scene(name: &str) {
    let (exact, ours) = compare_with_course(name, Precision::F64);
    let differing = exact.id.differing + exact.depth.differing + exact.normal.differing;
    assert!(
        differing == 0,
        "{}: the f64 render differs from the course's; see {}",
        exact.name,
        save_all(name, &ours).display()
    );

    let (c, ours) = compare_with_course(name, Precision::F32);
    let ties_possible = matches!(name, "bunny" | "inside-a-sphere");
    let off_diagonal = c
        .id_mismatches
        .iter()
        .filter(|&&p| !(ties_possible && on_crease_diagonal(p)))
        .count();
    let failure = if off_diagonal * 10_000 > c.pixels {
        Some(format!(
            "id differs on {off_diagonal} pixels off the crease diagonals (> 0.01%)"
        ))
    } else if c.depth.differing * 1000 > c.pixels || c.depth_same_id.max_level > 1 {
        Some(format!(
            "depth differs on {} pixels (limit 0.1%), by up to {} levels where ids agree",
            c.depth.differing, c.depth_same_id.max_level
        ))
    } else if c.normal.differing * 1000 > c.pixels || c.normal_same_id.max_level > 1 {
        Some(format!(
            "normal differs on {} pixels (limit 0.1%), by up to {} levels where ids agree",
            c.normal.differing, c.normal_same_id.max_level
        ))
    } else {
        None
    };
    if let Some(f) = failure {
        panic!("{}: {f}; see {}", c.name, save_all(name, &ours).display());
    }
}

#[test]
fn bunny() {
    check_scene("bunny");
}

#[test]
fn inside_a_sphere() {
    check_scene("inside-a-sphere");
}

#[test]
fn sphere_and_plane() {
    check_scene("sphere-and-plane");
}

#[test]
fn sphere_packing() {
    check_scene("sphere-packing");
}

#[test]
fn triangle() {
    check_scene("triangle");
}

#[test]
fn two_spheres_and_plane() {
    check_scene("two-spheres-and-plane");
}

/// The spot values the course documents.
#[test]
fn course_spot_pixels() {
    let at = |name: &str, row: u32, col: u32| {
        let scene = course_scene(name);
        let p = api_render(gpu(), &scene, Precision::F64, Textbook).pictures();
        let k = (row * p.width + col) as usize;
        (
            [p.id[3 * k], p.id[3 * k + 1], p.id[3 * k + 2]],
            p.depth[k],
            [p.normal[3 * k], p.normal[3 * k + 1], p.normal[3 * k + 2]],
        )
    };
    assert_eq!(
        at("sphere-and-plane", 180, 320),
        ([228, 26, 28], 169, [128, 126, 254])
    );
    assert_eq!(
        at("sphere-and-plane", 359, 320),
        ([55, 126, 184], 125, [127, 255, 127])
    );
    // The pixel-centre ray passes just below the triangle's bottom edge.
    assert_eq!(at("triangle", 180, 320), ([0, 0, 0], 0, [0, 0, 0]));
    // The image plane lies inside the sphere: the back surface, outward normal (0, 0, -1).
    assert_eq!(at("inside-a-sphere", 180, 320).2, [127, 127, 0]);
}

/// `raycast render SCENE`, with no option, reproduces every course render: the id picture
/// exactly, depth and normal within one level. The default is adaptive precision (robust f32,
/// uncertain pixels cast again in f64), which needs the certainty test to judge which root of a
/// sphere is the hit, not only whether the sphere is hit: inside-a-sphere has a ring of pixels
/// whose near root lies within the start test's error bound of the image plane, where f32 takes
/// the far root of the same sphere.
#[test]
fn the_default_render_reproduces_every_course_render() {
    let dir = tempfile::tempdir().unwrap();
    for name in COURSE_SCENES {
        let out = dir.path().join(name);
        let run = common::raycast()
            .arg("render")
            .arg(repo_path(&format!("scenes/course/{name}.json")))
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(stdout.contains("gpu:adaptive:robust"), "{name}: {stdout}");
        let read = |kind: &str| {
            let img = image::open(out.join(format!("{kind}.png"))).unwrap();
            match kind {
                "depth" => img.into_luma8().into_raw(),
                _ => img.into_rgb8().into_raw(),
            }
        };
        let ours = Pictures {
            width: 640,
            height: 360,
            id: read("id"),
            depth: read("depth"),
            normal: read("normal"),
        };
        let id = diff(&ours.id, &course_render(name, "id"), 3, None);
        let depth = diff(&ours.depth, &course_render(name, "depth"), 1, None);
        let normal = diff(&ours.normal, &course_render(name, "normal"), 3, None);
        println!(
            "{name}: id {} px, depth {} px (max {}), normal {} px (max {})",
            id.differing, depth.differing, depth.max_level, normal.differing, normal.max_level
        );
        let ok = id.differing == 0 && depth.max_level <= 1 && normal.max_level <= 1;
        assert!(ok, "{name}: see {}", save_all(name, &ours).display());
    }
}

/// The course's ray-tracing scenes (scenes/ray-tracing/) load: their lights and materials as the
/// file lists them, each object's material resolved by name, and the camera and objects exactly
/// those of the same file without `lights`, `materials` and the objects' `material`.
#[test]
fn ray_tracing_scenes_load_with_their_materials_and_lights() {
    const FOLDER: &str = "scenes/ray-tracing";
    let dir = repo_path(FOLDER);
    let names = scene_files(FOLDER);
    assert_eq!(names.len(), 10);
    for path in names {
        let scene = raycast::Scene::load(&path).unwrap();
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let listed = |key: &str| json[key].as_array().map_or(0, Vec::len);
        let lighting = &scene.lighting;
        assert_eq!(
            lighting.lights.len(),
            listed("lights"),
            "{}",
            path.display()
        );
        assert_eq!(lighting.materials.len(), listed("materials"));
        assert_eq!(lighting.object_materials.len(), scene.objects.len());
        for (object, material) in json["objects"]
            .as_array()
            .unwrap()
            .iter()
            .zip(&lighting.object_materials)
        {
            let named = object["material"].as_str();
            assert_eq!(named, material.map(|k| lighting.materials[k].name.as_str()));
        }
        let mut plain = json.clone();
        let top = plain.as_object_mut().unwrap();
        top.remove("lights");
        top.remove("materials");
        for object in top["objects"].as_array_mut().unwrap() {
            object.as_object_mut().unwrap().remove("material");
        }
        let plain = raycast::Scene::from_json(&plain.to_string(), &path, &mut |mesh, split| {
            let mesh = dir.join(mesh);
            raycast::parse_mesh(&std::fs::read(&mesh).unwrap(), &mesh, split)
        })
        .unwrap();
        assert!(plain.lighting.is_empty());
        assert_eq!(
            (&scene.camera, &scene.objects),
            (&plain.camera, &plain.objects)
        );
    }
}
