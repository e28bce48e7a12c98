//! `raycast render SCENE... --views FILE | --orbit N`: every view the same bytes as the single
//! render of its camera, shards that together write what one run writes, runs that resume
//! where a killed one stopped, views of other options or changed scenes rendered again, and
//! bad views refused before anything renders.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use common::{raycast, repo_path};

/// Every file under `dir` (hidden ones too) by its path relative to `dir`, with its bytes.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, files: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, files);
            } else {
                let name = path.strip_prefix(root).unwrap().display().to_string();
                files.insert(name, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut files = BTreeMap::new();
    walk(dir, dir, &mut files);
    files
}

fn run(args: &[&str]) -> Output {
    raycast().arg("render").args(args).output().unwrap()
}

fn succeeds(args: &[&str]) -> String {
    let out = run(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The number before ` views in` on the summary line: how many views the run rendered.
fn rendered(stdout: &str) -> usize {
    let line = stdout.lines().next().unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// The number after `rendered again` on the summary line: how many of the views rendered were
/// stale.
fn stale(stdout: &str) -> usize {
    let line = stdout.lines().next().unwrap();
    let (_, rest) = line.split_once("rendered again ").expect(line);
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

/// The record of what a view's folder was rendered with, beside the render's files.
const RECORD: &str = "job.json";

const BUNNY: &str = "scenes/course/bunny.json";
const SPHERES: &str = "scenes/course/two-spheres-and-plane.json";

/// `scene` (a scene file of the repository) with `camera` in place of its own, written into
/// `dir`, its meshes named by absolute paths.
fn with_camera(scene: &str, camera: &serde_json::Value, dir: &Path, name: &str) -> PathBuf {
    let path = repo_path(scene);
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    for object in json["objects"].as_array_mut().unwrap() {
        if let Some(mesh) = object.get("stl").and_then(|m| m.as_str()) {
            let absolute = path.parent().unwrap().join(mesh);
            object["stl"] = absolute.display().to_string().into();
        }
    }
    let mut camera = camera.clone();
    camera.as_object_mut().unwrap().remove("name");
    json["camera"] = camera;
    let file = dir.join(format!("{name}.json"));
    std::fs::write(&file, json.to_string()).unwrap();
    file
}

/// Asserts that the view folder `view` holds exactly what the single render of `scene` writes,
/// and its record.
fn same_as_single(view: &Path, scene: &Path, extra: &[&str], dir: &Path) {
    let single = dir.join("single");
    let _ = std::fs::remove_dir_all(&single);
    let mut args = vec![scene.to_str().unwrap(), "-o", single.to_str().unwrap()];
    args.extend(extra);
    succeeds(&args);
    let (mut a, b) = (tree(view), tree(&single));
    assert!(a.remove(RECORD).is_some(), "{}: no record", view.display());
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "{}",
        view.display()
    );
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{}: {name} differs", view.display());
    }
}

#[test]
fn every_view_is_the_single_render_of_its_camera_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let cameras = serde_json::json!([
        {"name": "course", "eye": [0.3, 0.2, 2], "look": [-0.1, -0.1, -1], "up": [0, 1, 0],
         "focal_length": 1, "width": 1.7777777778, "height": 1},
        {"name": "side", "eye": [2.5, 0.5, 0.3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 50},
        {"name": "pinhole", "eye": [0, 0, 2.2], "look": [0, 0, -1], "up": [0, 1, 0],
         "intrinsics": {"fx": 100, "fy": 100, "cx": 47.5, "cy": 26.5}, "resolution": [96, 54]}
    ]);
    let views = dir.path().join("views.json");
    std::fs::write(&views, cameras.to_string()).unwrap();
    let out = dir.path().join("out");
    let size = ["--size", "96x54"];
    let formats = ["--format", "png,npy,depth16"];
    let mut args = vec![BUNNY, SPHERES, "--views", views.to_str().unwrap()];
    args.extend(["-o", out.to_str().unwrap()]);
    args.extend(size.iter().chain(&formats));
    let stdout = succeeds(&args);
    assert_eq!(rendered(&stdout), 6, "{stdout}");
    // The scenes' folders and the manifest, and no lock file left.
    let names = ["bunny", "manifest.jsonl", "two-spheres-and-plane"];
    assert_eq!(common::file_names(&out), names);
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = manifest
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 6);
    assert_eq!(lines[4]["dir"], "two-spheres-and-plane/side");
    assert!(lines.iter().all(|l| l["status"] == "done"));
    let extra: Vec<&str> = size.iter().chain(&formats).copied().collect();
    for scene in [BUNNY, SPHERES] {
        let stem = Path::new(scene).file_stem().unwrap().to_str().unwrap();
        for camera in cameras.as_array().unwrap() {
            let name = camera["name"].as_str().unwrap();
            let file = with_camera(scene, camera, dir.path(), name);
            same_as_single(&out.join(stem).join(name), &file, &extra, dir.path());
        }
    }
    // An orbit's views: each the render of the camera its camera.json gives in scene form.
    let orbit = dir.path().join("orbit");
    succeeds(&[
        BUNNY,
        "--orbit",
        "3",
        "-o",
        orbit.to_str().unwrap(),
        "--size",
        "96x54",
    ]);
    for k in 0..3 {
        let view = orbit.join(format!("bunny/orbit-00{k}"));
        let camera: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(view.join("camera.json")).unwrap())
                .unwrap();
        let file = with_camera(BUNNY, &camera["scene_camera"], dir.path(), "orbit");
        same_as_single(&view, &file, &["--size", "96x54"], dir.path());
    }
}

#[test]
fn shards_together_write_exactly_what_one_run_writes() {
    let dir = tempfile::tempdir().unwrap();
    let job = |out: &Path, extra: &[&str]| {
        let mut args = vec![BUNNY, SPHERES, "--orbit", "5", "--size", "48x27"];
        args.extend(["-o", out.to_str().unwrap()]);
        args.extend(extra);
        succeeds(&args)
    };
    let whole = dir.path().join("whole");
    assert_eq!(rendered(&job(&whole, &[])), 10);
    let sharded = dir.path().join("sharded");
    let mut counts = Vec::new();
    for shard in ["0/3", "1/3", "2/3"] {
        counts.push(rendered(&job(&sharded, &["--shard", shard])));
    }
    assert_eq!(counts.iter().sum::<usize>(), 10, "{counts:?}");
    assert!(counts.iter().all(|&n| n >= 2), "balanced: {counts:?}");
    assert_eq!(tree(&whole), tree(&sharded));
    // The shard a Slurm array task or a Kubernetes Indexed Job is given.
    for (vars, count) in [
        (
            &[
                ("SLURM_ARRAY_TASK_ID", "8"),
                ("SLURM_ARRAY_TASK_MIN", "7"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ][..],
            None,
        ),
        (&[("JOB_COMPLETION_INDEX", "1")][..], Some("3")),
    ] {
        let auto = dir.path().join("auto");
        let _ = std::fs::remove_dir_all(&auto);
        let mut command = raycast();
        command.args([
            "render", BUNNY, SPHERES, "--orbit", "5", "--size", "48x27", "--shard", "auto",
        ]);
        command.arg("-o").arg(&auto).envs(vars.iter().copied());
        if let Some(n) = count {
            command.args(["--shard-count", n]);
        }
        let out = command.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let views: Vec<String> = tree(&auto)
            .keys()
            .filter(|k| k.ends_with("camera.json"))
            .cloned()
            .collect();
        let one_of_three = dir.path().join("one");
        let _ = std::fs::remove_dir_all(&one_of_three);
        job(&one_of_three, &["--shard", "1/3"]);
        let expected: Vec<String> = tree(&one_of_three)
            .keys()
            .filter(|k| k.ends_with("camera.json"))
            .cloned()
            .collect();
        assert_eq!(views, expected, "{vars:?}");
    }
}

#[cfg(unix)]
#[test]
fn a_killed_run_resumes_without_rendering_its_finished_views_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let job = |out: &Path| -> Vec<String> {
        let args = [BUNNY, "--orbit", "30", "--size", "320x180", "-o"].map(String::from);
        args.into_iter()
            .chain([out.display().to_string()])
            .collect()
    };
    let owned = job(&out);
    let args: Vec<&str> = owned.iter().map(String::as_str).collect();
    let views = |out: &Path| -> Vec<PathBuf> {
        let scene = out.join("bunny");
        let Ok(entries) = std::fs::read_dir(&scene) else {
            return Vec::new();
        };
        entries
            .map(|e| e.unwrap().path())
            .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
            .collect()
    };
    let mut child = raycast().arg("render").args(&args).spawn().unwrap();
    common::wait_until(&mut child, "five views", || views(&out).len() >= 5);
    child.kill().unwrap(); // SIGKILL: nothing of the run can tidy up
    child.wait().unwrap();
    let finished = views(&out);
    assert!(finished.len() < 30, "killed before the end");
    let names = [
        "camera.json",
        "color.png",
        "depth.png",
        "id.png",
        RECORD,
        "normal.png",
    ];
    let mut stamps = BTreeMap::new();
    for view in &finished {
        // A view's folder is whole or absent.
        assert_eq!(common::file_names(view), names, "{}", view.display());
        stamps.insert(
            view.clone(),
            std::fs::metadata(view.join("id.png"))
                .unwrap()
                .modified()
                .unwrap(),
        );
    }
    let stdout = succeeds(&args);
    assert_eq!(rendered(&stdout), 30 - finished.len(), "{stdout}");
    assert!(
        stdout.contains(&format!("skipped {} complete", finished.len())),
        "{stdout}"
    );
    for (view, stamp) in stamps {
        assert_eq!(
            std::fs::metadata(view.join("id.png"))
                .unwrap()
                .modified()
                .unwrap(),
            stamp
        );
    }
    // No temporary folder is left, and the whole job is what one uninterrupted run writes.
    assert_eq!(common::file_names(&out.join("bunny")).len(), 30);
    let whole = dir.path().join("whole");
    succeeds(&job(&whole).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(tree(&whole) == tree(&out));
    // --force renders every view again (of a small job).
    let small = dir.path().join("small");
    let small = [
        BUNNY,
        "--orbit",
        "3",
        "--size",
        "32x18",
        "-o",
        small.to_str().unwrap(),
    ];
    assert_eq!(rendered(&succeeds(&small)), 3);
    assert_eq!(rendered(&succeeds(&small)), 0, "complete already");
    assert_eq!(rendered(&succeeds(&[&small[..], &["--force"]].concat())), 3);
}

/// A job's options: each flag with its value (`None` for a switch), in order.
type Options<'a> = Vec<(&'a str, Option<&'a str>)>;

/// `options` with each of `changes` set: its value replaced where the flag is there, else
/// added.
fn changed<'a>(options: &Options<'a>, changes: &Options<'a>) -> Options<'a> {
    let mut options = options.clone();
    for &(flag, value) in changes {
        match options.iter_mut().find(|(f, _)| *f == flag) {
            Some(option) => option.1 = value,
            None => options.push((flag, value)),
        }
    }
    options
}

/// Runs the job of `options` into `out`, asserting that it renders `expected` views of which
/// `again` stale, and skips the rest of `total` as complete.
fn resumes(options: &Options, out: &Path, [expected, again, total]: [usize; 3]) {
    let mut args: Vec<&str> = vec!["-o", out.to_str().unwrap()];
    for &(flag, value) in options {
        args.push(flag);
        args.extend(value);
    }
    let stdout = succeeds(&args);
    assert_eq!(
        (rendered(&stdout), stale(&stdout)),
        (expected, again),
        "{args:?}: {stdout}"
    );
    let skipped = format!("skipped {} complete", total - expected);
    assert!(stdout.contains(&skipped), "{args:?}: {stdout}");
}

/// Asserts that a resumed job's folder `out` holds exactly what a fresh run of `options` writes
/// (the manifest too): no file of another job is left.
fn as_fresh(options: &Options, out: &Path, dir: &Path) {
    let fresh = dir.join("fresh");
    let _ = std::fs::remove_dir_all(&fresh);
    resumes(options, &fresh, [2, 0, 2]);
    assert!(tree(&fresh) == tree(out), "{options:?}");
}

/// Copies the course bunny's scene file and mesh into `dir`, to be changed there.
fn own_bunny(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    for file in ["bunny.json", "bunny.stl"] {
        std::fs::copy(repo_path(&format!("scenes/course/{file}")), dir.join(file)).unwrap();
    }
    dir.join("bunny.json")
}

/// Each option that changes a view's files (the orbit's among them), and the scene's and its
/// mesh's contents: a job run again with it changed renders every view again as stale,
/// leaving what a fresh run writes; run once more, it skips every view. A view whose record is
/// missing (a folder of a version without records) is stale too. On the CPU, 2 views of 16x9
/// pixels each.
#[test]
fn a_changed_option_or_scene_renders_the_views_again_and_the_same_skip_them() {
    let dir = tempfile::tempdir().unwrap();
    type Edit = fn(&Path);
    let none: Edit = |_| {};
    let move_a_wall: Edit = |scene| {
        let text = std::fs::read_to_string(scene).unwrap();
        let moved = text.replacen("[-1,0,0]", "[-1.25,0,0]", 1);
        assert_ne!(moved, text);
        std::fs::write(scene, moved).unwrap();
    };
    let move_a_vertex: Edit = |scene| {
        let mesh = scene.with_file_name("bunny.stl");
        let mut bytes = std::fs::read(&mesh).unwrap();
        // Binary STL: the first triangle's first corner's x after its normal.
        let x = &mut bytes[96..100];
        let moved = f32::from_le_bytes(x.try_into().unwrap()) * 1.01;
        x.copy_from_slice(&moved.to_le_bytes());
        std::fs::write(&mesh, bytes).unwrap();
    };
    let forget_a_record: Edit = |scene| {
        let view = scene.parent().unwrap().join("out/bunny/orbit-001");
        std::fs::remove_file(view.join(RECORD)).unwrap();
    };
    let cases: [(Options, Edit, usize); 17] = [
        (vec![("--size", Some("16x8"))], none, 2),
        (vec![("--precision", Some("f32"))], none, 2),
        (vec![("--algorithm", Some("textbook"))], none, 2),
        (vec![("--format", Some("png,depth16,npy"))], none, 2),
        (vec![("--outputs", Some("id,distance"))], none, 2),
        (vec![("--depth", Some("z"))], none, 2),
        (vec![("--depth-scale", Some("500"))], none, 2),
        (vec![("--spp", Some("4"))], none, 2),
        (vec![("--background", Some("255,255,255"))], none, 2),
        (vec![("--lit", None)], none, 2),
        (vec![("--device", Some("gpu"))], none, 2),
        (vec![("--orbit-radius", Some("0.9"))], none, 2),
        (vec![("--orbit-elevation", Some("30"))], none, 2),
        (vec![("--eye", Some("0.3,0.2,0.9"))], none, 2),
        (vec![], move_a_wall, 2),
        (vec![], move_a_vertex, 2),
        (vec![], forget_a_record, 1),
    ];
    for (k, (changes, edit, again)) in cases.into_iter().enumerate() {
        let case = dir.path().join(format!("case{k}"));
        let scene = own_bunny(&case);
        let out = case.join("out");
        let base: Options = vec![
            (scene.to_str().unwrap(), None),
            ("--orbit", Some("2")),
            ("--size", Some("16x9")),
            ("--device", Some("cpu")),
            ("--format", Some("png,depth16")),
        ];
        resumes(&base, &out, [2, 0, 2]);
        if k == 0 {
            resumes(&base, &out, [0, 0, 2]);
        }
        edit(&scene);
        let options = changed(&base, &changes);
        resumes(&options, &out, [again, again, 2]);
        resumes(&options, &out, [0, 0, 2]);
        as_fresh(&options, &out, &case);
        // --force renders every view again, stale or not.
        if k == 0 {
            let forced = changed(&options, &vec![("--force", None)]);
            resumes(&forced, &out, [2, 0, 2]);
            // A shard of the first options again: the manifest calls the other shard's view,
            // of other options, stale.
            let shard = changed(&base, &vec![("--shard", Some("0/2"))]);
            resumes(&shard, &out, [1, 1, 1]);
            let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
            let status: Vec<String> = manifest
                .lines()
                .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
                .map(|l| l["status"].as_str().unwrap().to_owned())
                .collect();
            assert_eq!(status, ["done", "stale"]);
        }
    }
}

/// The options that change a GPU render's files beyond the CPU's: the shade hook's and the
/// kernel file's text, bands. Each changed renders both views again; the same skips them.
#[test]
fn a_changed_hook_kernel_or_band_renders_the_views_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let hook = dir.path().join("hook.wgsl");
    let kernel = dir.path().join("kernel.wgsl");
    let shade = |rgb: &str| {
        let source =
            format!("fn shade(hit: ShadeHit) -> vec4<f32> {{ return vec4<f32>({rgb}, 1.0); }}\n");
        std::fs::write(&hook, source).unwrap();
    };
    let base: Options = vec![
        (BUNNY, None),
        ("--orbit", Some("2")),
        ("--size", Some("16x9")),
        ("--precision", Some("f32")),
    ];
    // The kernel a view of this job assembles, as the single render of the scene writes it.
    let single = dir.path().join("single");
    succeeds(&[
        BUNNY,
        "--size",
        "16x9",
        "--precision",
        "f32",
        "-o",
        single.to_str().unwrap(),
        "--emit-shader",
        kernel.to_str().unwrap(),
    ]);
    resumes(&base, &out, [2, 0, 2]);
    let banded = changed(&base, &vec![("--band-rows", Some("4"))]);
    resumes(&banded, &out, [2, 2, 2]);
    resumes(&banded, &out, [0, 0, 2]);
    let shaded = changed(&base, &vec![("--shader", Some(hook.to_str().unwrap()))]);
    shade("1.0, 0.0, 0.0");
    resumes(&shaded, &out, [2, 2, 2]);
    resumes(&shaded, &out, [0, 0, 2]);
    shade("0.0, 1.0, 0.0");
    resumes(&shaded, &out, [2, 2, 2]);
    resumes(&shaded, &out, [0, 0, 2]);
    let own_kernel = changed(&base, &vec![("--kernel", Some(kernel.to_str().unwrap()))]);
    resumes(&own_kernel, &out, [2, 2, 2]);
    resumes(&own_kernel, &out, [0, 0, 2]);
    let mut text = std::fs::read_to_string(&kernel).unwrap();
    text.push_str("// edited\n");
    std::fs::write(&kernel, text).unwrap();
    resumes(&own_kernel, &out, [2, 2, 2]);
    resumes(&own_kernel, &out, [0, 0, 2]);
}

/// `--split` changes a mesh file's ids: an OBJ of two objects split otherwise renders every
/// view again, and the same skips them.
#[test]
fn a_changed_split_renders_a_meshs_views_again() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("two.obj");
    std::fs::write(
        &mesh,
        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 2 0 0\nv 3 0 0\nv 2 1 0\nf 4 5 6\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let base: Options = vec![
        (mesh.to_str().unwrap(), None),
        ("--orbit", Some("2")),
        ("--size", Some("16x9")),
        ("--device", Some("cpu")),
    ];
    resumes(&base, &out, [2, 0, 2]);
    let whole = changed(&base, &vec![("--split", Some("none"))]);
    resumes(&whole, &out, [2, 2, 2]);
    resumes(&whole, &out, [0, 0, 2]);
    as_fresh(&whole, &out, dir.path());
}

/// With a views file, only the views whose camera changed are rendered again.
#[test]
fn a_changed_camera_renders_that_view_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let views = dir.path().join("views.json");
    let write = |eye: &str| {
        let text = format!(
            r#"[{{"name": "a", "eye": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40}},
                {{"name": "b", "eye": {eye}, "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40}}]"#
        );
        std::fs::write(&views, text).unwrap();
    };
    let options: Options = vec![
        (BUNNY, None),
        ("--views", Some(views.to_str().unwrap())),
        ("--size", Some("16x9")),
        ("--device", Some("cpu")),
    ];
    write("[1, 0.5, 2]");
    resumes(&options, &out, [2, 0, 2]);
    let a = std::fs::metadata(out.join("bunny/a/id.png"))
        .unwrap()
        .modified()
        .unwrap();
    write("[1, 0.75, 2]");
    resumes(&options, &out, [1, 1, 2]);
    resumes(&options, &out, [0, 0, 2]);
    let after = std::fs::metadata(out.join("bunny/a/id.png"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(a, after, "view a kept");
    as_fresh(&options, &out, dir.path());
}

#[test]
fn bad_views_are_one_line_errors_before_anything_renders() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let camera = r#""eye": [0, 0, 2], "look": [0, 0, -1], "up": [0, 1, 0], "fov": 40"#;
    let cases = [
        (
            format!(r#"[{{"name": "a", {camera}, "fow": 3}}]"#),
            "[0].fow: unknown field `fow`, did you mean `fov`?",
        ),
        (
            format!(r#"[{{"name": "../up", {camera}}}]"#),
            "[0].name: `../up` is not a folder name",
        ),
        (
            format!(r#"[{{"name": "a", {camera}}}, {{"name": "A", {camera}}}]"#),
            "[1].name: `A` repeats the name of view 0",
        ),
        (format!(r#"[{{{camera}}}]"#), "[0]: needs a `name`"),
        (
            r#"[{"name": "a", "eye": [0, 0, 2], "look": [0, 0, -1], "up": [0, 0, 1], "fov": 40}]"#
                .into(),
            "[0].up: is parallel to [0].look",
        ),
        ("[]".into(), "no views"),
        (
            r#"{"name": "a"}"#.into(),
            ":1:1: a views file is a JSON list of cameras, got an object (is it a scene file?)",
        ),
        (
            std::fs::read_to_string(common::repo_path(BUNNY)).unwrap(),
            "a views file is a JSON list of cameras, got an object (is it a scene file?)",
        ),
        (
            "\n  \"views\"".into(),
            ":2:3: a views file is a JSON list of cameras, got a string",
        ),
    ];
    for (k, (text, expected)) in cases.iter().enumerate() {
        let views = dir.path().join(format!("views{k}.json"));
        std::fs::write(&views, text).unwrap();
        let result = run(&[
            BUNNY,
            "--views",
            views.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{text}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains(expected) && stderr.contains(&format!("views{k}.json")),
            "{text}: {stderr}"
        );
        assert!(!out.exists(), "{text}: nothing written");
    }
    let views = dir.path().join("views.json");
    std::fs::write(&views, format!(r#"[{{"name": "a", {camera}}}]"#)).unwrap();
    for (args, expected) in [
        (
            vec![BUNNY, "--orbit", "0"],
            "--orbit: needs at least 1 view, got 0",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--shard", "2/2"],
            "--shard: expected I/N",
        ),
        (vec![BUNNY, "--force"], "--force: renders many views"),
        (vec![BUNNY, SPHERES], "2 scene files given"),
        (
            vec![BUNNY, "scenes/course/bunny.stl", "--orbit", "2"],
            "would share the folder `bunny`",
        ),
        (
            vec![BUNNY, "--views", views.to_str().unwrap(), "--eye", "1,2,3"],
            "--eye: sets one camera, and every view of --views has its own",
        ),
        (
            vec![BUNNY, "--views", views.to_str().unwrap(), "--watch"],
            "--watch: watches one render; not with --views",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--watch"],
            "--watch: watches one render; not with --orbit",
        ),
        (
            vec![BUNNY, "--orbit-radius", "2"],
            "--orbit-radius: sets an orbit's views: give --orbit",
        ),
        (
            vec![
                BUNNY,
                "--views",
                views.to_str().unwrap(),
                "--orbit-elevation",
                "2",
            ],
            "--orbit-elevation: sets an orbit's views: give --orbit",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--orbit-radius", "0"],
            "--orbit-radius: must be a positive distance",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--orbit-radius", "-1"],
            "--orbit-radius: must be a positive distance",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--orbit-radius", "far"],
            "'--orbit-radius <R>'",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--orbit-elevation", "90"],
            "--orbit-elevation: must be between -90 and 90 degrees",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--orbit-elevation", "nan"],
            "--orbit-elevation: must be between -90 and 90 degrees",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--up", "0,0,0"],
            "--up: must be a non-zero vector",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--fov", "180"],
            "--fov: must be between 0 and 180",
        ),
        (
            vec![BUNNY, "--orbit", "2", "--shard", "auto"],
            "neither a Slurm array task",
        ),
    ] {
        let mut args = args.clone();
        args.extend(["-o", out.to_str().unwrap()]);
        let result = raycast()
            .arg("render")
            .args(&args)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?}: nothing written");
    }
}

/// Ctrl-C or SIGTERM during a dataset: exit 130, every view's folder complete, and no hidden
/// folder of a view being written left behind.
#[cfg(unix)]
#[test]
fn a_signal_leaves_only_complete_views() {
    for signal in ["-INT", "-TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let scene = out.join("bunny");
        let mut child = raycast()
            .args(["render", BUNNY, "--orbit", "400", "--size", "320x180", "-o"])
            .arg(&out)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let views = || std::fs::read_dir(&scene).map_or(0, |d| d.count());
        common::wait_until(&mut child, "three views", || views() >= 3);
        let pid = child.id().to_string();
        assert!(
            std::process::Command::new("kill")
                .args([signal, &pid])
                .status()
                .unwrap()
                .success()
        );
        let output = child.wait_with_output().unwrap();
        assert_eq!(output.status.code(), Some(130), "{signal}");
        let names = common::file_names(&scene);
        assert!(
            names.len() < 400 && names.iter().all(|n| n.starts_with("orbit-")),
            "{names:?}"
        );
        for name in names {
            assert_eq!(common::file_names(&scene.join(&name)).len(), 6, "{name}");
        }
    }
}

/// The `scene_camera` of each view's camera.json under `scene`, by view name.
fn scene_cameras(scene: &Path) -> Vec<serde_json::Value> {
    common::file_names(scene)
        .iter()
        .map(|name| {
            let text = std::fs::read_to_string(scene.join(name).join("camera.json")).unwrap();
            let json: serde_json::Value = serde_json::from_str(&text).unwrap();
            json["scene_camera"].clone()
        })
        .collect()
}

fn vector(value: &serde_json::Value) -> glam::DVec3 {
    glam::DVec3::from(serde_json::from_value::<[f64; 3]>(value.clone()).unwrap())
}

/// The columns of the pixels in the two highest rows that hit something, of an `id.npy`
/// (int32, version 1 header) `width` pixels wide.
fn highest_hits(path: &Path, width: usize) -> Vec<usize> {
    let bytes = std::fs::read(path).unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let ids = bytes[10 + header..].chunks_exact(4);
    let hits: Vec<usize> = (ids.enumerate())
        .filter(|(_, id)| i32::from_le_bytes((*id).try_into().unwrap()) >= 0)
        .map(|(p, _)| p)
        .collect();
    let top = hits.first().map_or(0, |p| p / width);
    let highest = hits.iter().filter(|p| *p / width <= top + 1);
    highest.map(|p| p % width).collect()
}

/// A square pyramid standing on z = 0 with its apex at z = 2: a z-up mesh.
const PYRAMID: &str = "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nv 0 0 2\n\
    f 1 3 2\nf 1 4 3\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n";

/// A z-up mesh orbited with `--up 0,0,1` (#66: refused before, and on its side without
/// `--up`): every view keeps that up, the eyes turn about the z axis through the mesh's
/// centre at one height and distance, an eighth of a turn apart, and each sees the pyramid
/// upright: its apex the highest point, on the image's vertical centre line.
#[test]
fn a_z_up_mesh_orbits_upright_about_the_up_given() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("pyramid.obj");
    std::fs::write(&mesh, PYRAMID).unwrap();
    let out = dir.path().join("out");
    let (mesh, folder) = (mesh.to_str().unwrap(), out.to_str().unwrap());
    succeeds(&[
        mesh,
        "--orbit",
        "8",
        "--up",
        "0,0,1",
        "--device",
        "cpu",
        "--size",
        "48x48",
        "--format",
        "npy",
        "--outputs",
        "id",
        "-o",
        folder,
    ]);
    let scene = out.join("pyramid");
    let cameras = scene_cameras(&scene);
    assert_eq!(cameras.len(), 8);
    let centre = glam::DVec3::new(0.0, 0.0, 1.0);
    let first = vector(&cameras[0]["eye"]) - centre;
    for (k, camera) in cameras.iter().enumerate() {
        assert_eq!(vector(&camera["up"]), glam::DVec3::Z, "view {k}");
        let eye = vector(&camera["eye"]);
        let offset = eye - centre;
        assert!((eye + vector(&camera["look"]) - centre).length() < 1e-9);
        assert!((offset.z - first.z).abs() < 1e-9, "view {k}: {offset}");
        let (a, b) = (first.truncate(), offset.truncate());
        assert!((a.length() - b.length()).abs() < 1e-9, "view {k}: {offset}");
        let turn = (b.y.atan2(b.x) - a.y.atan2(a.x)).rem_euclid(std::f64::consts::TAU);
        assert!((turn / std::f64::consts::FRAC_PI_4 - k as f64).abs() < 1e-9);
        let apex = highest_hits(&scene.join(format!("orbit-00{k}/id.npy")), 48);
        let column = apex.iter().sum::<usize>() as f64 / apex.len() as f64;
        assert!(
            apex.len() <= 6 && (column - 23.5).abs() <= 1.0,
            "view {k}: the two highest rows hit at columns {apex:?}, not an apex at the centre"
        );
    }
}

/// `--eye` gives the first view's direction from the centre, `--look-at` the centre, `--fov`
/// the lens, `--orbit-radius` and `--orbit-elevation` the eye's distance and height.
#[test]
fn an_orbit_starts_where_eye_look_at_fov_radius_and_elevation_say() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    succeeds(&[
        "scenes/course/sphere-and-plane.json",
        "--orbit",
        "4",
        "--eye",
        "3,1,0",
        "--look-at",
        "0,0.25,0",
        "--fov",
        "30",
        "--orbit-radius",
        "6",
        "--orbit-elevation",
        "20",
        "--device",
        "cpu",
        "--size",
        "32x18",
        "--outputs",
        "id",
        "-o",
        out.to_str().unwrap(),
    ]);
    let cameras = scene_cameras(&out.join("sphere-and-plane"));
    let centre = glam::DVec3::new(0.0, 0.25, 0.0);
    let (rise, level) = 20f64.to_radians().sin_cos();
    for (k, camera) in cameras.iter().enumerate() {
        assert_eq!(camera["fov"], 30.0, "view {k}");
        let eye = vector(&camera["eye"]);
        assert!((eye + vector(&camera["look"]) - centre).length() < 1e-9);
        // A quarter turn about +y each view, from +x (where --eye stands).
        let (sin, cos) = (std::f64::consts::FRAC_PI_2 * k as f64).sin_cos();
        let expected = centre + 6.0 * glam::DVec3::new(level * cos, rise, -level * sin);
        assert!(
            (eye - expected).length() < 1e-9,
            "view {k}: {eye} against {expected}"
        );
    }
}
