//! Meshes declared once and placed by instances (#64), end to end: an instanced scene renders
//! exactly as the same scene with every copy written out as a soup (transforms exact in f64,
//! a mirrored copy with its corners in reverse order); a mesh declared and never placed is a
//! warning; bad instances are one `error:` line, exit code 2 and no output.

use crate::common;

use common::assert_no_files;

use tempfile::TempDir;

/// A tetrahedron, dyadic coordinates.
const CORNERS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.25, 0.25, 0.75],
];
const FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];

/// An OBJ of triangles, one vertex line a corner.
fn obj(triangles: &[[[f64; 3]; 3]]) -> String {
    let mut text = String::new();
    for t in triangles {
        for [x, y, z] in t {
            text += &format!("v {x:?} {y:?} {z:?}\n");
        }
    }
    for k in 0..triangles.len() {
        text += &format!("f {} {} {}\n", 3 * k + 1, 3 * k + 2, 3 * k + 3);
    }
    text
}

fn tetrahedron() -> Vec<[[f64; 3]; 3]> {
    FACES.iter().map(|f| f.map(|i| CORNERS[i])).collect()
}

const CAMERA: &str = r#""camera": {"eye": [0.5, 0.5, 6], "look": [0, 0, -1], "up": [0, 1, 0],
    "focal_length": 2, "width": 1.6, "height": 1.2, "resolution": [64, 48]}"#;

/// Renders `scene` (JSON, written beside `files`) to npy ids, distances and normals; returns
/// them.
fn render(dir: &TempDir, name: &str, scene: &str, files: &[(String, String)]) -> Vec<Vec<u8>> {
    for (file, text) in files {
        std::fs::write(dir.path().join(file), text).unwrap();
    }
    let path = dir.path().join(format!("{name}.json"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.path().join(name);
    render_arrays(&path, &out, &[]);
    arrays(&out)
}

/// `raycast render SCENE -o OUT` of npy ids, distances and normals, with `more` arguments;
/// asserts that it succeeds.
fn render_arrays(scene: &std::path::Path, out: &std::path::Path, more: &[&str]) {
    let run = common::raycast()
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .args(["--format", "npy", "--outputs", "id,distance,normal"])
        .args(more)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// The npy files [`render_arrays`] writes in `folder`.
fn arrays(folder: &std::path::Path) -> Vec<Vec<u8>> {
    ["id.npy", "distance.npy", "normal.npy"]
        .map(|f| std::fs::read(folder.join(f)).unwrap())
        .to_vec()
}

/// Three copies, by a matrix, by translate and scale, and mirrored, render as the same copies
/// written out; the mirrored copy's normals face out as the written-out one's (corners
/// reversed) do.
#[test]
fn instances_render_as_their_copies_written_out() {
    let dir = tempfile::tempdir().unwrap();
    let placed = |f: &dyn Fn([f64; 3]) -> [f64; 3], mirror: bool| {
        let t: Vec<[[f64; 3]; 3]> = (tetrahedron().iter())
            .map(|t| {
                let [a, b, c] = t.map(f);
                if mirror { [a, c, b] } else { [a, b, c] }
            })
            .collect();
        obj(&t)
    };
    let copies = [
        placed(&|[x, y, z]| [2.0 * x - 1.5, 0.5 * y + 1.0, z], false),
        placed(
            &|[x, y, z]| [0.5 * x + 0.25, 0.5 * y - 1.0, 0.5 * z + 0.125],
            false,
        ),
        placed(&|[x, y, z]| [-x + 2.5, y, z], true),
    ];
    let soups: Vec<(String, String)> = (copies.iter().enumerate())
        .map(|(k, t)| (format!("copy{k}.obj"), t.clone()))
        .collect();
    let written = format!(
        r#"{{{CAMERA}, "objects": [{}]}}"#,
        (0..3)
            .map(|k| format!(r#"{{"type": "soup", "obj": "copy{k}.obj"}}"#))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let instanced = format!(
        r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}}}, "objects": [
            {{"type": "instance", "mesh": "tet", "transform": [[2, 0, 0, -1.5], [0, 0.5, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]]}},
            {{"type": "instance", "mesh": "tet", "transform": {{"translate": [0.25, -1, 0.125], "scale": 0.5}}}},
            {{"type": "instance", "mesh": "tet", "transform": {{"translate": [2.5, 0, 0], "scale": [-1, 1, 1]}}}}]}}"#
    );
    let a = render(&dir, "written", &written, &soups);
    let b = render(
        &dir,
        "instanced",
        &instanced,
        &[("tet.obj".into(), obj(&tetrahedron()))],
    );
    assert_eq!(a, b);
    // Every copy is seen: ids 0, 1 and 2 in the id image (int32 after the npy header).
    let ids = &b[0];
    let header = 10 + u16::from_le_bytes([ids[8], ids[9]]) as usize;
    let seen: std::collections::BTreeSet<i32> = (ids[header..].chunks(4))
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert!([0, 1, 2].iter().all(|k| seen.contains(k)), "{seen:?}");
}

/// Runs `raycast render` on `scene` (with the tetrahedron as tet.obj) in a scratch folder,
/// with `poses` as `--poses poses.jsonl` where given: what it printed, and where its output
/// would be.
fn run(scene: &str, poses: Option<&str>) -> (std::process::Output, std::path::PathBuf, TempDir) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tet.obj"), obj(&tetrahedron())).unwrap();
    let path = dir.path().join("scene.json");
    std::fs::write(&path, scene).unwrap();
    let out = dir.path().join("out");
    let mut command = common::raycast();
    command.args([
        "render",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    if let Some(poses) = poses {
        let file = dir.path().join("poses.jsonl");
        std::fs::write(&file, poses).unwrap();
        command.args(["--poses", file.to_str().unwrap()]);
    }
    (command.output().unwrap(), out, dir)
}

/// `output` is one `error: ` line naming `file` and saying `expected`, exit code 2, and
/// nothing is written in `out`.
fn assert_one_line_error(
    output: &std::process::Output,
    out: &std::path::Path,
    file: &str,
    expected: &str,
) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("error: ") && stderr.contains(file),
        "{stderr}"
    );
    assert!(
        stderr.contains(expected),
        "`{expected}` missing from: {stderr}"
    );
    assert_no_files(out);
}

#[test]
fn a_mesh_never_placed_is_a_warning() {
    let scene = format!(
        r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}, "spare": {{"obj": "tet.obj"}}}},
            "objects": [{{"type": "instance", "mesh": "tet"}}]}}"#
    );
    let (output, out, _dir) = run(&scene, None);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: ")
            && stderr.contains("meshes.spare is declared but no instance places it"),
        "{stderr}"
    );
    assert!(out.join("id.png").exists());
}

#[test]
fn bad_instances_are_one_line_naming_the_field() {
    let cases = [
        (
            r#"{"type": "instance", "mesh": "tett"}"#,
            "objects[0].mesh: unknown mesh `tett`, did you mean `tet`?",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]}"#,
            "objects[0].transform: is singular",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]}"#,
            "objects[0].transform[3]: the last row must be [0, 0, 0, 1]",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"scale": [1, 0, 1]}}"#,
            "objects[0].transform.scale: must not be 0",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"rotate": {"axis": [0, 0, 0], "degrees": 30}}}"#,
            "objects[0].transform.rotate.axis: must be a non-zero vector",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"translate": [1e30, 0, 0]}}"#,
            "objects[0].transform.translate[0]: magnitude",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"move": [1, 0, 0]}}"#,
            "expected a 4x4 matrix (four rows of four numbers) or an object of \"translate\", \"rotate\" and \"scale\"",
        ),
    ];
    for (object, expected) in cases {
        let scene = format!(
            r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}}}, "objects": [{object}]}}"#
        );
        let (output, out, _dir) = run(&scene, None);
        assert_one_line_error(&output, &out, "scene.json", expected);
    }
}

/// The scene of three placed tetrahedra the poses below move.
fn placed_scene(camera: &str, transforms: [&str; 3]) -> String {
    format!(
        r#"{{{camera}, "meshes": {{"tet": {{"obj": "tet.obj"}}}}, "objects": [
            {{"type": "instance", "mesh": "tet", "transform": {}}},
            {{"type": "sphere", "center": [0, 0, -2], "radius": 0.5}},
            {{"type": "instance", "mesh": "tet", "transform": {}}},
            {{"type": "instance", "mesh": "tet", "transform": {}}}]}}"#,
        transforms[0], transforms[1], transforms[2]
    )
}

const OWN: [&str; 3] = [
    r#"[[2, 0, 0, -1.5], [0, 0.5, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]]"#,
    r#"{"translate": [0.25, -1, 0.125], "scale": 0.5}"#,
    r#"{"translate": [2.5, 0, 0], "scale": [-1, 1, 1]}"#,
];

/// `raycast render SCENE --poses FILE`: each frame's files are those of the scene file with its
/// instances placed as the frame says (the others as the scene places them, whatever frame came
/// before) and the frame's camera where it gives one; a frame rendered again alone is the same.
#[test]
fn each_pose_renders_as_its_scene_placed_so() {
    let dir = tempfile::tempdir().unwrap();
    let tet = [("tet.obj".to_owned(), obj(&tetrahedron()))];
    let moved = r#"{"translate": [-1, -0.5, 0.5], "rotate": {"axis": [0, 1, 1], "degrees": 40}, "scale": [0.7, 1.2, 0.9]}"#;
    let mirrored = r#"[[0, -1, 0, 0.5], [-1, 0, 0, 1.5], [0, 0, 1, -0.5], [0, 0, 0, 1]]"#;
    // One line: a pose is a line.
    let eye = concat!(
        r#""camera": {"eye": [1.5, 0.5, 6], "look": [-0.2, 0, -1], "up": [0, 1, 0], "#,
        r#""focal_length": 2, "width": 1.6, "height": 1.2, "resolution": [64, 48]}"#
    );
    let frames = [
        (CAMERA, OWN, r#"{"name": "f-000"}"#.to_owned()),
        (
            CAMERA,
            [moved, OWN[1], OWN[2]],
            format!(
                r#"{{"name": "f-001", "transforms": [{{"object": 0, "transform": {moved}}}]}}"#
            ),
        ),
        (
            eye,
            [OWN[0], mirrored, moved],
            format!(
                r#"{{"name": "f-002", "transforms": [{{"object": 3, "transform": {moved}}}, {{"object": 2, "transform": {mirrored}}}], {eye}}}"#
            ),
        ),
    ];
    let poses = dir.path().join("poses.jsonl");
    let lines: Vec<&str> = frames.iter().map(|(_, _, line)| line.as_str()).collect();
    std::fs::write(&poses, lines.join("\n") + "\n\n").unwrap();
    let scene = dir.path().join("table.json");
    std::fs::write(dir.path().join("tet.obj"), &tet[0].1).unwrap();
    std::fs::write(&scene, placed_scene(CAMERA, OWN)).unwrap();
    let out = dir.path().join("frames");
    let render_poses = || render_arrays(&scene, &out, &["--poses", poses.to_str().unwrap()]);
    render_poses();
    let frame_files = |name: &str| arrays(&out.join("table").join(name));
    let mut seen = Vec::new();
    for (k, (camera, transforms, _)) in frames.iter().enumerate() {
        let name = format!("f-00{k}");
        let alone = render(
            &dir,
            &format!("alone{k}"),
            &placed_scene(camera, *transforms),
            &tet,
        );
        let framed = frame_files(&name);
        assert_eq!(framed, alone, "{name}");
        seen.push(framed);
    }
    assert_ne!(seen[0], seen[1], "the pose moved an instance");
    // Frame 1 again, after frame 2 in the same run.
    std::fs::remove_dir_all(out.join("table/f-001")).unwrap();
    let lines = [frames[2].2.as_str(), frames[1].2.as_str()];
    std::fs::write(&poses, lines.join("\n")).unwrap();
    render_poses();
    assert_eq!(frame_files("f-001"), seen[1]);
}

#[test]
fn bad_poses_are_one_line_naming_the_line_and_field() {
    let moved = r#"{"translate": [1, 0, 0]}"#;
    let cases = [
        (
            format!(r#"{{"name": "a", "transforms": [{{"object": 1, "transform": {moved}}}]}}"#),
            "poses.jsonl: line 1: transforms[0].object: object 1 is not an instance of the scene (the scene's instances: 0, 2, 3)",
        ),
        (
            concat!(
                r#"{"name": "a"}"#,
                "\n\n",
                r#"{"name": "b", "transforms": [{"object": 0, "transform": {"scale": 0}}]}"#
            )
            .to_owned(),
            "poses.jsonl: line 3: transforms[0].transform.scale: must not be 0",
        ),
        (
            r#"{"name": "a", "transforms": [{"object": 0}]}"#.to_owned(),
            "poses.jsonl:1:",
        ),
        (
            format!(
                r#"{{"name": "a", "transforms": [{{"object": 0, "transform": {moved}}}, {{"object": 0, "transform": {moved}}}]}}"#
            ),
            "line 1: transforms[1].object: object 0 is moved twice",
        ),
        (
            r#"{"name": "a", "transforms": [{"object": 0, "transform": {"translate": [9e17, 0, 0], "scale": 2e17}}]}"#.to_owned(),
            "line 1: transforms[0].transform: places the mesh beyond 1e18",
        ),
        (
            r#"{"name": "a", "camera": {"eye": [0, 0, 1], "look": [0, 0, -1], "up": [0, 0, 1], "fov": 60}}"#.to_owned(),
            "line 1: camera.up",
        ),
    ];
    for (poses, expected) in cases {
        let (output, out, _dir) = run(&placed_scene(CAMERA, OWN), Some(&poses));
        assert_one_line_error(&output, &out, "poses.jsonl", expected);
    }
}
