//! `render --emit-shader FILE` end to end (src/tests/specialized_kernels.rs checks that the
//! specialized kernels render as the general one).

use crate::common;

/// `render --emit-shader FILE` writes the kernel that ran: valid WGSL, specialized for the
/// scene (no triangle code for spheres and a plane), and refuses the CPU device.
#[test]
fn emit_shader_writes_the_specialized_kernel() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("kernel.wgsl");
    let scene = common::repo_path("scenes/course/sphere-and-plane.json");
    let run = |out: &str, extra: &[&str]| {
        common::raycast()
            .args([
                "render",
                scene.to_str().unwrap(),
                "--size",
                "32x18",
                "--emit-shader",
            ])
            .arg(&file)
            .arg("-o")
            .arg(dir.path().join(out))
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run("out", &[]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let source = std::fs::read_to_string(&file).unwrap();
    let module = naga::front::wgsl::parse_str(&source).unwrap();
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    validator.validate(&module).unwrap();
    let names: Vec<&str> = module
        .functions
        .iter()
        .filter_map(|(_, f)| f.name.as_deref())
        .collect();
    assert!(names.contains(&"intersect_sphere") && names.contains(&"intersect_plane"));
    assert!(!names.contains(&"intersect_triangle"), "{names:?}");
    std::fs::remove_file(&file).unwrap();
    let cpu = run("cpu-out", &["--device", "cpu"]);
    assert_eq!(cpu.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&cpu.stderr).contains("--emit-shader"));
    assert!(!file.exists() && !dir.path().join("cpu-out").exists());
}
