//! The `raycast` binary on bad input: every failure exits with code 2, prints exactly one
//! `error: ` line naming the file and field (or line:column, or option) at fault, and leaves
//! no files in the output folder. One valid render checks the harness itself.

use crate::common;

use common::{assert_no_files, file_names};

use std::path::PathBuf;
use std::process::Output;

use tempfile::TempDir;

/// A small valid scene; the cases below edit it with [`edit`].
const VALID: &str = r#"{"camera":{"type":"perspective","eye":[0,0,5],"look":[0,0,-1],"up":[0,1,0],"focal_length":3,"width":1.6,"height":0.9,"resolution":[32,18]},"objects":[{"type":"sphere","center":[0,0,0],"radius":0.5}]}"#;

/// `VALID` with `from` (which must occur exactly once) replaced by `to`.
fn edit(from: &str, to: &str) -> String {
    assert_eq!(VALID.matches(from).count(), 1, "`{from}` must occur once");
    VALID.replace(from, to)
}

/// `VALID` with its object list replaced by `objects` (a JSON array).
fn with_objects(objects: &str) -> String {
    edit(
        r#"[{"type":"sphere","center":[0,0,0],"radius":0.5}]"#,
        objects,
    )
}

/// A scratch folder holding `scene.json`; `out` (not created) is where output goes.
struct Case {
    dir: TempDir,
    scene: PathBuf,
    out: PathBuf,
}

impl Case {
    fn new(scene_json: &str) -> Case {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.json");
        std::fs::write(&scene, scene_json).unwrap();
        let out = dir.path().join("out");
        Case { dir, scene, out }
    }

    /// Writes a further file (a mesh) next to the scene.
    fn file(&self, name: &str, bytes: &[u8]) -> &Case {
        std::fs::write(self.dir.path().join(name), bytes).unwrap();
        self
    }

    /// The scene file as error messages print it, followed by `:`.
    fn scene_prefix(&self) -> String {
        format!("error: {}:", self.scene.display())
    }

    /// Runs `raycast render scene.json -o out ARGS` with extra environment variables.
    fn run(&self, args: &[&str], envs: &[(&str, &str)]) -> Output {
        common::raycast()
            .arg("render")
            .arg(&self.scene)
            .arg("-o")
            .arg(&self.out)
            .args(args)
            .envs(envs.iter().copied())
            .output()
            .expect("the raycast binary runs")
    }

    /// Runs and checks the failure contract; returns the one stderr line.
    fn fail(&self, args: &[&str], envs: &[(&str, &str)]) -> String {
        let output = self.run(args, envs);
        let stderr = String::from_utf8(output.stderr).expect("stderr is UTF-8");
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert_eq!(
            output.status.code(),
            Some(2),
            "exit status {:?}\nstderr:\n{stderr}",
            output.status
        );
        assert!(
            stdout.is_empty(),
            "nothing on stdout on failure, got:\n{stdout}"
        );
        assert!(
            stderr.starts_with("error: ") && stderr.ends_with('\n') && stderr.lines().count() == 1,
            "stderr must be one `error: ` line, got:\n{stderr}"
        );
        assert_no_files(&self.out);
        stderr.trim_end().to_owned()
    }
}

/// Runs `scene_json` with `extra_args`, checks the failure contract and that the message starts
/// with the scene file's path; returns the message.
fn run_err(scene_json: &str, extra_args: &[&str]) -> String {
    let case = Case::new(scene_json);
    let message = case.fail(extra_args, &[]);
    assert!(
        message.starts_with(&case.scene_prefix()),
        "message must start with the scene file: {message}"
    );
    message
}

/// Asserts `message` contains every one of `parts`.
fn assert_has(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "`{part}` missing from: {message}");
    }
}

// 1. Malformed JSON.

#[test]
fn malformed_json_names_file_line_and_column() {
    // The comma between "type" and "center" of the sphere (line 2) is missing.
    let line2 = r#""objects":[{"type":"sphere" "center":[0,0,0],"radius":0.5}]}"#;
    let camera = &VALID[..VALID.find(r#""objects""#).unwrap()];
    let text = format!("{camera}\n{line2}");
    let column = line2.find(r#""center""#).unwrap() + 1;
    let message = run_err(&text, &[]);
    assert_has(
        &message,
        &[&format!(
            "scene.json:2:{column}: objects[0]: expected `,` or `}}`"
        )],
    );
}

#[test]
fn trailing_characters_after_the_scene_are_an_error() {
    let text = format!("{VALID}\n  x\n");
    let message = run_err(&text, &[]);
    assert_has(&message, &["scene.json:2:3: ", "trailing characters"]);
}

#[test]
fn empty_scene_file_is_an_error() {
    let message = run_err("", &[]);
    assert_has(&message, &["scene.json:1:0: ", "EOF"]);
}

#[test]
fn a_list_given_as_a_scene_says_what_a_scene_file_is() {
    let message = run_err(r#"[{"name": "front", "eye": [0, 0, 2]}]"#, &[]);
    assert_has(
        &message,
        &[
            "scene.json:1:1: a scene file is a JSON object with a `camera` and `objects`, got a list (is it a views file?)",
        ],
    );
}

// 2. Unknown object type.

#[test]
fn unknown_object_type() {
    let message = run_err(&edit(r#""type":"sphere""#, r#""type":"cone""#), &[]);
    assert_has(&message, &["objects[0].type", "`cone`", "`sphere`"]);
}

// 3. Unknown fields.

#[test]
fn unknown_field_in_an_object() {
    let message = run_err(
        &edit(r#""radius":0.5"#, r#""radius":0.5,"colour":[1,0,0]"#),
        &[],
    );
    assert_has(&message, &["objects[0]", "unknown field `colour`"]);
}

#[test]
fn unknown_field_in_the_camera() {
    let message = run_err(
        &edit(r#""focal_length":3"#, r#""focal_length":3,"aperture":2"#),
        &[],
    );
    assert_has(&message, &["camera.aperture", "unknown field `aperture`"]);
}

#[test]
fn a_misspelt_field_or_type_gets_the_nearest_name() {
    let message = run_err(&edit(r#""objects""#, r#""objcts""#), &[]);
    assert_has(
        &message,
        &["unknown field `objcts`, did you mean `objects`?"],
    );
    let message = run_err(&edit(r#""type":"sphere""#, r#""type":"sphre""#), &[]);
    assert_has(
        &message,
        &["unknown variant `sphre`, did you mean `sphere`?"],
    );
    let message = run_err(&edit(r#""look""#, r#""lok""#), &[]);
    assert_has(&message, &["camera.lok", "did you mean `look`?"]);
}

// 3b. Materials and lights (the course's ray-tracing scenes): checked, then ignored.

/// `VALID` with `materials`, `lights` and the sphere's `material`.
fn lit(materials: &str, lights: &str, material: &str) -> String {
    let with_material = edit(
        r#""radius":0.5"#,
        &format!(r#""radius":0.5,"material":"{material}""#),
    );
    with_material.replacen(
        r#""objects""#,
        &format!(r#""materials":{materials},"lights":{lights},"objects""#),
        1,
    )
}

const MATTE: &str = r#"[{"name":"matte","ka":[0.1,0.1,0.1],"kd":[0.5,0.5,0.5],"ks":[0.2,0.2,0.2],"km":[0,0,0],"phong_exponent":20}]"#;
const LAMP: &str = r#"[{"type":"point","position":[0,2,2],"color":[0.8,0.8,0.8]}]"#;

#[test]
fn an_object_naming_a_missing_material() {
    let message = run_err(&lit(MATTE, LAMP, "glossy"), &[]);
    assert_has(&message, &["objects[0].material", "`glossy`"]);
}

#[test]
fn materials_and_lights_are_checked() {
    let negative = MATTE.replace(r#""kd":[0.5,0.5,0.5]"#, r#""kd":[0.5,-0.5,0.5]"#);
    let message = run_err(&lit(&negative, LAMP, "matte"), &[]);
    assert_has(&message, &["materials[0].kd[1]", "must be >= 0"]);
    let twice = format!("[{0},{0}]", &MATTE[1..MATTE.len() - 1]);
    let message = run_err(&lit(&twice, LAMP, "matte"), &[]);
    assert_has(&message, &["materials[1].name", "`matte`"]);
    let message = run_err(
        &lit(
            MATTE,
            r#"[{"type":"directional","direction":[0,0,0],"color":[1,1,1]}]"#,
            "matte",
        ),
        &[],
    );
    assert_has(&message, &["lights[0].direction", "non-zero"]);
    let message = run_err(&lit(MATTE, &LAMP.replace("point", "spot"), "matte"), &[]);
    assert_has(
        &message,
        &["lights[0]", "unknown variant `spot`", "`point`"],
    );
    let message = run_err(&lit(MATTE, &LAMP.replace("color", "colour"), "matte"), &[]);
    assert_has(&message, &["unknown field `colour`, did you mean `color`?"]);
}

#[test]
fn bad_object_values() {
    for (values, expected) in [
        ("[]", &["objects[0].values", "1 to 4 numbers (got 0)"][..]),
        ("[1,2,3,4,5]", &["objects[0].values", "(got 5)"]),
        (
            "[0,1e19]",
            &["objects[0].values[1]", "exceeds the supported"],
        ),
        // serde names the object, not the field, inside a tagged enum.
        ("[0,\"a\"]", &["objects[0]", "invalid type: string \"a\""]),
        ("3", &["objects[0]", "invalid type: integer `3`"]),
    ] {
        let scene = edit(
            r#""radius":0.5"#,
            &format!(r#""radius":0.5,"values":{values}"#),
        );
        let message = run_err(&scene, &[]);
        assert_has(&message, expected);
    }
}

#[test]
fn lit_is_refused_where_it_cannot_run() {
    let case = Case::new(&lit(MATTE, LAMP, "matte"));
    let toon = common::repo_path("shaders/examples/toon.wgsl");
    for (args, expected) in [
        (
            &["--lit", "--shader", toon.to_str().unwrap()][..],
            "error: --lit: is the shade hook shaders/examples/raytrace.wgsl",
        ),
        (
            &["--lit", "--precision", "adaptive"],
            "error: --lit: runs with --precision f32 or f64",
        ),
        (
            &["--lit", "--outputs", "id"],
            "error: --lit: the hook colours color.png",
        ),
        (&["--lit", "--background", "0,0,0"], "error: --background: "),
        (
            &["--shader", toon.to_str().unwrap(), "--device", "cpu"],
            "error: --shader: the CPU reference runs no shader but the course's ray tracer (--lit)",
        ),
    ] {
        let message = case.fail(args, &[]);
        assert!(message.starts_with(expected), "{args:?}: {message}");
        assert_no_files(&case.out);
    }
    // It runs on the CPU, by the mirror, on the GPU whole and in bands, and says how many rays
    // it cast: the same in each.
    let mut counts = Vec::new();
    for args in [
        &["--lit", "--device", "cpu", "--precision", "f32"][..],
        &["--lit", "--precision", "f32"],
        &["--lit", "--precision", "f32", "--band-rows", "5"],
    ] {
        let output = case.run(args, &[]);
        assert!(output.status.success(), "{args:?}: {output:?}");
        let stdout = String::from_utf8_lossy(&output.stdout);
        let line = (stdout.lines())
            .find(|l| l.starts_with("cast 576 camera rays and "))
            .unwrap_or_else(|| panic!("{args:?}: {stdout}"));
        counts.push(line.split(' ').nth(5).unwrap().to_owned());
        assert!(case.out.join("color.png").exists());
    }
    assert!(counts.iter().all(|c| *c == counts[0]), "{counts:?}");
    // Supersampled, every sample's rays count.
    let output = case.run(&["--lit", "--precision", "f32", "--spp", "4"], &[]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("cast 2304 camera rays and ")),
        "{stdout}"
    );
}

#[test]
fn a_lit_scene_renders_its_geometry_with_one_note() {
    let case = Case::new(&lit(MATTE, LAMP, "matte"));
    let output = case.run(&[], &[]);
    assert!(output.status.success(), "{output:?}");
    let stderr = String::from_utf8_lossy(&output.stderr);
    let notes: Vec<&str> = stderr.lines().filter(|l| l.starts_with("note: ")).collect();
    assert_eq!(notes.len(), 1, "{stderr}");
    assert_has(
        notes[0],
        &[
            "scene.json",
            "--lit",
            "1 light, 1 material, a material on 1 object",
        ],
    );
    let plain = Case::new(VALID);
    assert!(plain.run(&[], &[]).status.success());
    // Every file, color.png too: the materials and lights change nothing.
    let names = file_names(&case.out);
    assert_eq!(names, file_names(&plain.out));
    for name in names {
        let a = std::fs::read(case.out.join(&name)).unwrap();
        assert_eq!(a, std::fs::read(plain.out.join(&name)).unwrap(), "{name}");
    }
}

// 4. Missing fields.

#[test]
fn sphere_without_radius() {
    let message = run_err(&edit(r#","radius":0.5"#, ""), &[]);
    assert_has(&message, &["objects[0]", "missing field `radius`"]);
}

#[test]
fn camera_without_eye() {
    let message = run_err(&edit(r#""eye":[0,0,5],"#, ""), &[]);
    assert_has(&message, &["camera", "missing field `eye`"]);
}

// 5. Numbers that are not finite or too large.

#[test]
fn non_finite_number() {
    // serde_json rejects 1e999 itself ("number out of range") at its line and column.
    let text = edit(r#""radius":0.5"#, r#""radius":1e999"#);
    let column = text.find("1e999").unwrap() + "1e999".len();
    let message = run_err(&text, &[]);
    assert_has(
        &message,
        &[
            &format!("scene.json:1:{column}: "),
            "objects[0].radius",
            "out of range",
        ],
    );

    let message = run_err(
        &edit(r#""focal_length":3"#, r#""focal_length":-1e999"#),
        &[],
    );
    assert_has(&message, &["camera.focal_length", "out of range"]);
}

#[test]
fn too_large_magnitude() {
    let message = run_err(&edit(r#""center":[0,0,0]"#, r#""center":[0,1e30,0]"#), &[]);
    assert_has(&message, &["objects[0].center[1]", "1e30", "1e18"]);

    let message = run_err(&edit(r#""eye":[0,0,5]"#, r#""eye":[0,0,-1e30]"#), &[]);
    assert_has(&message, &["camera.eye[2]", "1e30"]);

    // OBJ is read in f64, so 1e39 (infinite in f32) is a number, refused for its magnitude.
    let case = Case::new(&soup("obj", "far.obj"));
    case.file("far.obj", b"v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
    let message = case.fail(&[], &[]);
    assert_has(&message, &["objects[0] triangle 0", "1e39", "1e18"]);
}

// 6. Radius.

#[test]
fn radius_must_be_positive() {
    for radius in ["0", "-1"] {
        let text = edit(r#""radius":0.5"#, &format!(r#""radius":{radius}"#));
        let message = run_err(&text, &[]);
        assert_has(&message, &["objects[0].radius", "must be > 0"]);
    }
}

// 7. Plane normal.

#[test]
fn zero_plane_normal() {
    let text = with_objects(
        r#"[{"type":"sphere","center":[0,0,0],"radius":0.5},
            {"type":"plane","point":[0,-1,0],"normal":[0,0,0]}]"#,
    );
    let message = run_err(&text, &[]);
    assert_has(&message, &["objects[1].normal", "non-zero"]);
}

// 8. Look direction.

#[test]
fn zero_look() {
    let message = run_err(&edit(r#""look":[0,0,-1]"#, r#""look":[0,0,0]"#), &[]);
    assert_has(&message, &["camera.look", "non-zero"]);
}

// 9. Up parallel to look.

#[test]
fn up_parallel_to_look() {
    let message = run_err(&edit(r#""up":[0,1,0]"#, r#""up":[0,0,2]"#), &[]);
    assert_has(&message, &["camera.up", "parallel", "camera.look"]);
}

// 10. Image-plane sizes.

#[test]
fn focal_length_width_and_height_must_be_positive() {
    for (from, to, field) in [
        (
            r#""focal_length":3"#,
            r#""focal_length":0"#,
            "camera.focal_length",
        ),
        (
            r#""focal_length":3"#,
            r#""focal_length":-2"#,
            "camera.focal_length",
        ),
        (r#""width":1.6"#, r#""width":0"#, "camera.width"),
        (r#""width":1.6"#, r#""width":-1.6"#, "camera.width"),
        (r#""height":0.9"#, r#""height":0"#, "camera.height"),
        (r#""height":0.9"#, r#""height":-0.9"#, "camera.height"),
    ] {
        let message = run_err(&edit(from, to), &[]);
        assert_has(&message, &[field, "must be > 0"]);
    }
}

// 11. Resolution.

#[test]
fn zero_resolution_in_the_scene() {
    let message = run_err(&edit("[32,18]", "[0,10]"), &[]);
    assert_has(&message, &["camera.resolution", "0x10"]);
}

#[test]
fn zero_size_on_the_command_line() {
    // Rejected by clap's value parser, which exits with 2 as well.
    let case = Case::new(VALID);
    let message = case.fail(&["--size", "0x10"], &[]);
    assert_has(&message, &["--size", "0x10"]);
}

#[test]
fn malformed_size_and_format_on_the_command_line() {
    let case = Case::new(VALID);
    let message = case.fail(&["--size", "wide"], &[]);
    assert_has(&message, &["--size", "wide", "WIDTHxHEIGHT"]);
    let message = case.fail(&["--format", "png,jpg"], &[]);
    assert_has(&message, &["--format", "jpg"]);
}

#[test]
fn size_wider_than_the_device_can_dispatch() {
    // 600000 pixels need more than the 65535 workgroups of 8 pixels a row can have.
    let case = Case::new(VALID);
    let message = case.fail(&["--size", "600000x1"], &[]);
    assert_has(&message, &["resolution", "600000x1"]);
}

/// The renders whose images cannot fit in this machine's memory: refused before they start
/// with one line naming the option, exit 2, and no output folder at all. The issue's request
/// (the course bunny at 1920x1080 and 4096 samples a pixel, 178 GB held whole) and images of
/// 100000x100000 pixels held whole (on the CPU, in adaptive precision, as a dataset's views)
/// need more than any machine the suite runs on; `RAYCAST_MEMORY` sets what there is.
#[test]
fn renders_beyond_memory_are_refused_before_they_start() {
    let bunny = |dir: &TempDir| Case {
        scene: common::repo_path("scenes/course/bunny.json"),
        out: dir.path().join("out"),
        dir: tempfile::tempdir().unwrap(),
    };
    let huge = ["--size", "100000x100000"];
    /// Arguments, environment, parts of the message.
    type Refusal<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a [&'a str]);
    let cases: &[Refusal] = &[
        (
            &["--size", "1920x1080", "--spp", "4096"],
            &[],
            &[
                "--spp 4096: 1920x1080 pixels of 4096 samples",
                "GB",
                "lower --spp or --size",
            ],
        ),
        (
            &[huge[0], huge[1], "--device", "cpu"],
            &[],
            &["--size 100000x100000", "(f64) needs 360 GB", "in bands"],
        ),
        (
            &[huge[0], huge[1], "--precision", "adaptive"],
            &[],
            &["--size 100000x100000", "(adaptive) needs 210 GB"],
        ),
        (
            &[huge[0], huge[1], "--device", "cpu", "--orbit", "2"],
            &[],
            &["--size 100000x100000", "(f64) needs 360 GB"],
        ),
        (
            &["--size", "640x360", "--device", "cpu"],
            &[("RAYCAST_MEMORY", "8M")],
            &[
                "--size 640x360",
                "needs 8.3 MB",
                "more than the 8.0 MB RAYCAST_MEMORY allows",
            ],
        ),
        (
            &["--device", "cpu"],
            &[("RAYCAST_MEMORY", "lots")],
            &["RAYCAST_MEMORY: must be a number of bytes", "`lots`"],
        ),
    ];
    for (args, envs, parts) in cases {
        let dir = tempfile::tempdir().unwrap();
        let case = bunny(&dir);
        let message = case.fail(args, envs);
        assert_has(&message, parts);
        assert!(!case.out.exists(), "{args:?}: no output folder");
    }
    // Within what RAYCAST_MEMORY allows, the same render runs.
    let dir = tempfile::tempdir().unwrap();
    let case = bunny(&dir);
    let output = case.run(
        &["--size", "64x36", "--device", "cpu"],
        &[("RAYCAST_MEMORY", "8M")],
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// An allocation the system refuses (here under a 2 GB address-space limit, `ulimit -v`, with
/// the estimate lifted by `RAYCAST_MEMORY`) ends the command with one line and exit 2, not
/// Rust's abort (exit 134), and leaves no file.
#[cfg(unix)]
#[test]
fn a_refused_allocation_ends_with_one_line_not_an_abort() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scene = common::repo_path("scenes/course/bunny.json");
    let command =
        "ulimit -v 2000000 && exec \"$0\" render \"$1\" --size 12000x12000 --device cpu -o \"$2\"";
    let output = std::process::Command::new("sh")
        .args(["-c", command, env!("CARGO_BIN_EXE_raycast")])
        .arg(&scene)
        .arg(&out)
        .env("RAYCAST_MEMORY", "1T")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with("error: out of memory: the system refused ")
            && stderr.lines().count() == 1,
        "{stderr}"
    );
    assert_no_files(&out);
}

// 12. Mesh files.

fn soup(kind: &str, file: &str) -> String {
    with_objects(&format!(r#"[{{"type":"soup","{kind}":"{file}"}}]"#))
}

/// Runs a scene whose only object is the mesh `name` (written with `bytes` unless `None`);
/// the message must name the mesh file.
fn mesh_err(kind: &str, name: &str, bytes: Option<&[u8]>) -> String {
    let case = Case::new(&soup(kind, name));
    if let Some(bytes) = bytes {
        case.file(name, bytes);
    }
    let message = case.fail(&[], &[]);
    let mesh = case.dir.path().join(name);
    assert!(
        message.starts_with(&format!("error: {}: ", mesh.display())),
        "message must start with the mesh file: {message}"
    );
    message
}

#[test]
fn missing_mesh_file() {
    let message = mesh_err("stl", "nope.stl", None);
    assert_has(&message, &["nope.stl", "cannot read"]);
    let message = mesh_err("obj", "nope.obj", None);
    assert_has(&message, &["nope.obj", "cannot read"]);
}

#[test]
fn corrupt_stl_files() {
    // Fixed pseudo-random bytes: an 80-byte header, then a huge triangle count.
    let mut state = 0x2545_f491_u32;
    let noise: Vec<u8> = (0..300)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 24) as u8
        })
        .collect();
    let count = u32::from_le_bytes(noise[80..84].try_into().unwrap());
    assert!(
        count > 4,
        "the noise must promise more triangles than it holds"
    );
    let message = mesh_err("stl", "noise.stl", Some(&noise));
    assert_has(
        &message,
        &[&format!(
            "noise.stl: byte 84: binary STL declares {count} triangles"
        )],
    );

    // A binary STL promising 5 triangles and holding one.
    let mut truncated = vec![0u8; 80];
    truncated.extend_from_slice(&5u32.to_le_bytes());
    truncated.extend_from_slice(&[0u8; 50]);
    let message = mesh_err("stl", "truncated.stl", Some(&truncated));
    assert_has(
        &message,
        &[
            "truncated.stl: byte 84: binary STL declares 5 triangles (334 bytes) but the file has 134 bytes",
        ],
    );

    // ASCII STL cut off in the middle of a facet.
    let ascii = b"solid broken\n facet normal 0 0 1\n  outer loop\n   vertex 0 0\n";
    let message = mesh_err("stl", "cut.stl", Some(ascii));
    assert_has(
        &message,
        &["cut.stl: line 4: expected 3 numbers after 'vertex', found end of line"],
    );
}

#[test]
fn corrupt_obj_file() {
    // A face that refers to vertices the file never defines.
    let message = mesh_err("obj", "garbage.obj", Some(b"f 1 2 3\n"));
    assert_has(
        &message,
        &["garbage.obj: line 1: face index 1 but only 0 vertices so far"],
    );
}

// 13. Output folder.

#[test]
fn output_folder_under_a_regular_file() {
    let case = Case::new(VALID);
    let afile = case.dir.path().join("afile");
    std::fs::write(&afile, b"").unwrap();
    let out = afile.join("out");
    let output = common::raycast()
        .arg("render")
        .arg(&case.scene)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(output.status.code(), Some(2), "stderr:\n{stderr}");
    assert!(output.stdout.is_empty());
    assert_eq!(stderr.lines().count(), 1, "one line, got:\n{stderr}");
    let expected = format!(
        "error: {}: {} is a file, not a folder",
        out.display(),
        afile.display()
    );
    assert_eq!(stderr.trim_end(), expected);
    // Nothing else written: the scratch folder holds what the test put there, unchanged.
    assert_eq!(file_names(case.dir.path()), ["afile", "scene.json"]);
    assert_eq!(std::fs::read(&afile).unwrap(), b"");
}

// 14. No adapter.

#[test]
fn no_adapter() {
    let case = Case::new(VALID);
    let message = case.fail(
        &[],
        &[
            ("VK_ICD_FILENAMES", "/nonexistent.json"),
            ("VK_DRIVER_FILES", "/nonexistent.json"),
            ("WGPU_BACKEND", "vulkan"),
        ],
    );
    assert_has(&message, &["no GPU adapter", "mesa-vulkan-drivers"]);
}

#[test]
fn adapter_name_matching_nothing() {
    let case = Case::new(VALID);
    let message = case.fail(&[], &[("WGPU_ADAPTER_NAME", "no-such-gpu")]);
    assert_has(&message, &["WGPU_ADAPTER_NAME", "no-such-gpu"]);
}

// 15. The harness itself: a valid scene renders.

/// Renders `VALID` with `args`; returns the sorted names of the files written.
fn render_ok(args: &[&str]) -> Vec<String> {
    let case = Case::new(VALID);
    let output = case.run(args, &[]);
    assert_eq!(
        output.status.code(),
        Some(0),
        "stderr:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    file_names(&case.out)
}

#[test]
fn valid_scene_renders_png() {
    assert_eq!(
        render_ok(&[]),
        [
            "camera.json",
            "color.png",
            "depth.png",
            "id.png",
            "normal.png"
        ]
    );
}

#[test]
fn valid_scene_renders_every_format() {
    assert_eq!(
        render_ok(&["--format", "png,npy,ppm"]),
        [
            "camera.json",
            "color.png",
            "depth.png",
            "depth.ppm",
            "distance.npy",
            "id.npy",
            "id.png",
            "id.ppm",
            "normal.npy",
            "normal.png",
            "normal.ppm",
        ]
    );
}

/// `raycast render ... | head -1`: a reader that goes away early is not a reason to panic.
#[test]
fn closed_stdout_is_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, VALID).unwrap();
    let mut child = common::raycast()
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(dir.path().join("out"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

// 12. Cameras by field of view, a point to look at, or pixel intrinsics.

/// `VALID`'s course image plane (focal length, width, height, resolution).
const COURSE_PLANE: &str = r#""focal_length":3,"width":1.6,"height":0.9,"resolution":[32,18]"#;

#[test]
fn contradictory_or_incomplete_cameras_name_the_field() {
    let intrinsics = r#""intrinsics":{"fx":60,"fy":60,"cx":15.5,"cy":8.5}"#;
    let cases: Vec<(String, &[&str])> = vec![
        (
            edit(COURSE_PLANE, r#""fov":40,"height":0.9"#),
            &[
                "camera.fov",
                "alternative to focal_length, width and height",
                "`height`",
            ],
        ),
        (
            edit(COURSE_PLANE, r#""fov":180"#),
            &["camera.fov", "between 0 and 180"],
        ),
        (
            edit(COURSE_PLANE, r#""fov":0"#),
            &["camera.fov", "between 0 and 180"],
        ),
        (
            edit(COURSE_PLANE, r#""fov":-30"#),
            &["camera.fov", "between 0 and 180"],
        ),
        (
            edit(COURSE_PLANE, intrinsics),
            &["camera.intrinsics", "camera.resolution"],
        ),
        (
            edit(
                COURSE_PLANE,
                &format!(r#""fov":40,{intrinsics},"resolution":[32,18]"#),
            ),
            &["camera.intrinsics", "alternative to camera.fov"],
        ),
        (
            edit(
                COURSE_PLANE,
                &format!(r#"{intrinsics},"width":1.6,"resolution":[32,18]"#),
            ),
            &["camera.intrinsics", "`width`"],
        ),
        (
            edit(
                COURSE_PLANE,
                r#""intrinsics":{"fx":0,"fy":60,"cx":15.5,"cy":8.5},"resolution":[32,18]"#,
            ),
            &["camera.intrinsics.fx", "must be > 0"],
        ),
        (
            edit(
                COURSE_PLANE,
                r#""intrinsics":{"fx":60,"fy":60,"cx":15.5},"resolution":[32,18]"#,
            ),
            &["camera.intrinsics", "missing field `cy`"],
        ),
        (
            edit(COURSE_PLANE, r#""fov":40,"near":0"#),
            &["camera.near", "must be > 0"],
        ),
        (
            edit(r#""focal_length":3"#, r#""focal_length":3,"near":0.1"#),
            &["camera.near", "fov or intrinsics"],
        ),
        (
            edit(r#""focal_length":3,"#, ""),
            &[
                "camera",
                "missing field `focal_length`",
                "fov or intrinsics",
            ],
        ),
        (
            edit(r#""type":"perspective""#, r#""type":"orthographic""#)
                .replace(COURSE_PLANE, r#""fov":40"#),
            &["camera.fov", "perspective"],
        ),
        (
            edit(r#""look":[0,0,-1]"#, r#""look":[0,0,-1],"look_at":[0,0,0]"#),
            &["camera.look_at", "alternative to camera.look"],
        ),
        (edit(r#""look":[0,0,-1],"#, ""), &["camera", "`look_at`"]),
        (
            edit(r#""look":[0,0,-1]"#, r#""look_at":[0,0,5]"#),
            &["camera.look_at", "is the eye"],
        ),
        (
            edit(r#""look":[0,0,-1]"#, r#""look_at":[0,7,5]"#),
            &["camera.up", "parallel", "camera.look_at"],
        ),
        (
            edit(
                COURSE_PLANE,
                r#""intrinsics":{"fx":1e-300,"fy":60,"cx":15.5,"cy":8.5},"resolution":[32,18]"#,
            ),
            &["camera.intrinsics", "image plane", "1e18"],
        ),
        (
            edit(r#""look":[0,0,-1]"#, r#""look_at":[0,0,1e30]"#),
            &["camera.look_at[2]", "1e30"],
        ),
    ];
    for (scene, parts) in cases {
        let message = run_err(&scene, &[]);
        assert_has(&message, parts);
    }
}

// 13. Output formats, depths and camera options.

#[test]
fn bad_format_depth_and_camera_options_name_the_option() {
    let ortho = edit(r#""type":"perspective""#, r#""type":"orthographic""#);
    let far = edit(r#""focal_length":3"#, r#""focal_length":1e17"#);
    let cases: &[(&str, &[&str], &[&str])] = &[
        (
            VALID,
            &["--format", "exr", "--band-rows", "4"],
            &["--format exr", "whole"],
        ),
        (
            VALID,
            &["--format", "npz", "--band-rows", "4"],
            &["--format npz", "whole"],
        ),
        (
            VALID,
            &["--format", "npz,png", "--outputs", "color"],
            &["--format npz", "none of them"],
        ),
        (
            VALID,
            &["--format", "depth16", "--outputs", "id"],
            &["--format depth16", "distance"],
        ),
        (VALID, &["--depth", "zz"], &["--depth", "zz"]),
        (
            VALID,
            &["--split", "grups"],
            &["--split", "grups", "groups"],
        ),
        (
            VALID,
            &["--split", "groups"],
            &["--split", "scene file", "\"split\""],
        ),
        (
            VALID,
            &["--depth-scale", "0"],
            &["--depth-scale", "positive"],
        ),
        (
            VALID,
            &["--depth-scale", "-1"],
            &["--depth-scale", "positive"],
        ),
        (
            VALID,
            &["--depth-scale", "nan"],
            &["--depth-scale", "positive"],
        ),
        (VALID, &["--eye", "1,2"], &["--eye", "X,Y,Z"]),
        (VALID, &["--eye", "1e30,0,0"], &["--eye", "magnitude"]),
        (VALID, &["--look-at", "0,0,x"], &["--look-at", "X,Y,Z"]),
        (VALID, &["--fov", "180"], &["--fov", "between 0 and 180"]),
        (VALID, &["--fov", "-5"], &["--fov", "between 0 and 180"]),
        (VALID, &["--look-at", "0,0,5"], &["--look-at", "is the eye"]),
        (VALID, &["--up", "0,0,0"], &["--up", "non-zero"]),
        (VALID, &["--up", "0,0,1"], &["--up", "parallel"]),
        (&ortho, &["--fov", "40"], &["--fov", "perspective"]),
        (
            &far,
            &["--fov", "179.99"],
            &["--fov", "image plane", "1e18"],
        ),
    ];
    for (scene, args, parts) in cases {
        let message = Case::new(scene).fail(args, &[]);
        assert_has(&message, parts);
    }
}

#[test]
fn bad_mesh_files_rendered_directly_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let huge = dir.path().join("huge.obj");
    std::fs::write(&huge, "v 0 0 0\nv 1 0 0\nv 0 1e30 0\nf 1 2 3\n").unwrap();
    let missing = dir.path().join("missing.stl");
    let good = dir.path().join("good.obj");
    std::fs::write(&good, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let parts_obj = dir.path().join("parts.obj");
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\no a\nf 1 2 3\no b\ng c\nf 1 2 4\n";
    std::fs::write(&parts_obj, text).unwrap();
    let huge_part = dir.path().join("huge-part.obj");
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 1e30 0\no a\nf 1 2 3\no b\nf 1 2 4\n";
    std::fs::write(&huge_part, text).unwrap();
    for (mesh, args, parts) in [
        (&huge, &[][..], &["huge.obj", "triangle 0", "1e30"][..]),
        (
            &parts_obj,
            &["--split", "groups"],
            &["parts.obj: line 8: face index 4 but only 3 vertices so far"],
        ),
        (
            &huge_part,
            &[],
            &["huge-part.obj", "part `b` triangle 0", "1e30"],
        ),
        (&missing, &[], &["missing.stl", "cannot read"]),
        // The default view looks at the box's centre, (0.5, 0.5, 0), up +y.
        (&good, &["--eye", "0.5,0.5,0"], &["--eye", "looked at"]),
        (&good, &["--eye", "0.5,3,0"], &["--eye", "parallel"]),
        (
            &good,
            &["--eye", "2,1,0", "--look-at", "2,-3,0"],
            &["--look-at", "parallel"],
        ),
    ] {
        let case = Case {
            dir: tempfile::tempdir().unwrap(),
            scene: mesh.clone(),
            out: out.clone(),
        };
        let message = case.fail(args, &[]);
        assert_has(&message, parts);
    }
}
