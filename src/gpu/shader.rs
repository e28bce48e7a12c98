//! Kernel assembly: the WGSL files of `shaders/` are stitched together by `#import NAME` lines,
//! each module included once, dependencies first. The result is one WGSL source that naga
//! validates before any pipeline is made.

use crate::error::{Error, Result};
use crate::math::Precision;

/// Every WGSL module, by name (`shaders/NAME.wgsl`), embedded at build time. One more module,
/// `precision`, is generated: `alias real = f32;` or `alias real = f64;`.
pub const MODULES: &[(&str, &str)] = &[
    ("types", include_str!("../../shaders/types.wgsl")),
    ("bindings", include_str!("../../shaders/bindings.wgsl")),
    ("camera", include_str!("../../shaders/camera.wgsl")),
    ("sphere", include_str!("../../shaders/sphere.wgsl")),
    ("plane", include_str!("../../shaders/plane.wgsl")),
    ("triangle", include_str!("../../shaders/triangle.wgsl")),
    ("scene", include_str!("../../shaders/scene.wgsl")),
    ("main", include_str!("../../shaders/main.wgsl")),
];

/// The module holding the kernel's entry point.
pub const ENTRY_MODULE: &str = "main";
/// The kernel's entry point function.
pub const ENTRY_POINT: &str = "main";

/// The generated module that fixes the kernel's scalar type.
const PRECISION_MODULE: &str = "precision";

fn module_source(name: &str, precision: Precision) -> Option<String> {
    if name == PRECISION_MODULE {
        return Some(format!("alias real = {};\n", precision.name()));
    }
    MODULES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| s.to_string())
}

/// Assembles `root` and everything it imports into one WGSL source, with `real` = `precision`.
///
/// Each module appears once, after its imports, under a `// ---- shaders/NAME.wgsl` banner so a
/// reader of the emitted shader can find the file it came from.
pub fn assemble(root: &str, precision: Precision) -> Result<String> {
    let mut out = String::new();
    let mut done = Vec::new();
    include(root, precision, &mut done, &mut Vec::new(), &mut out)?;
    Ok(out)
}

fn include(
    name: &str,
    precision: Precision,
    done: &mut Vec<String>,
    stack: &mut Vec<String>,
    out: &mut String,
) -> Result<()> {
    if done.iter().any(|d| d == name) {
        return Ok(());
    }
    if stack.iter().any(|s| s == name) {
        return Err(Error::Device(format!(
            "shaders: import cycle {} -> {name}",
            stack.join(" -> ")
        )));
    }
    let source = module_source(name, precision)
        .ok_or_else(|| Error::Device(format!("shaders: unknown module `{name}`")))?;
    stack.push(name.to_owned());
    for import in imports(&source) {
        include(import, precision, done, stack, out)?;
    }
    stack.pop();
    out.push_str(&format!("// ---- shaders/{name}.wgsl\n"));
    for line in source.lines().filter(|l| import_name(l).is_none()) {
        out.push_str(line);
        out.push('\n');
    }
    done.push(name.to_owned());
    Ok(())
}

fn import_name(line: &str) -> Option<&str> {
    line.trim().strip_prefix("#import ").map(str::trim)
}

/// The modules `source` imports, in order.
pub fn imports(source: &str) -> impl Iterator<Item = &str> {
    source.lines().filter_map(import_name)
}

/// Parses and validates WGSL with naga, returning the module or an error that quotes naga's
/// report (with line and column in `label`'s source).
pub fn validate(source: &str, label: &str) -> Result<naga::Module> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        Error::Device(format!(
            "{label}: {}",
            e.emit_to_string_with_path(source, label).trim_end()
        ))
    })?;
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    validator.validate(&module).map_err(|e| {
        Error::Device(format!(
            "{label}: {}",
            e.emit_to_string_with_path(source, label).trim_end()
        ))
    })?;
    Ok(module)
}

/// The full kernel source in `precision`.
pub fn kernel_source(precision: Precision) -> Result<String> {
    assemble(ENTRY_MODULE, precision)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every file in shaders/ is listed in MODULES (so none is silently left out) and every
    /// module, assembled with its imports, passes naga validation on its own.
    #[test]
    fn every_shader_file_validates_with_naga() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
        let mut on_disk: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| {
                let name = e.unwrap().file_name().into_string().unwrap();
                name.strip_suffix(".wgsl").map(str::to_owned)
            })
            .collect();
        on_disk.sort();
        let mut listed: Vec<String> = MODULES.iter().map(|(n, _)| n.to_string()).collect();
        listed.sort();
        assert_eq!(on_disk, listed, "shaders/ and MODULES differ");
        for (name, _) in MODULES {
            for precision in [Precision::F32, Precision::F64] {
                let source = assemble(name, precision).unwrap();
                let label = format!("shaders/{name}.wgsl ({precision})");
                if let Err(e) = validate(&source, &label) {
                    panic!("{e}");
                }
            }
        }
    }

    #[test]
    fn kernel_has_its_entry_point() {
        let module = validate(&kernel_source(Precision::F32).unwrap(), "kernel").unwrap();
        assert!(module.entry_points.iter().any(|e| e.name == ENTRY_POINT));
    }

    #[test]
    fn each_module_is_included_once() {
        let source = kernel_source(Precision::F64).unwrap();
        assert!(source.contains("alias real = f64;"));
        for (name, _) in MODULES {
            let banner = format!("// ---- shaders/{name}.wgsl\n");
            assert_eq!(source.matches(&banner).count(), 1, "{name}");
        }
    }

    #[test]
    fn a_shader_error_is_reported_with_its_location() {
        let err = validate("fn f() -> f32 { return 1u; }\n", "bad.wgsl").unwrap_err();
        let text = err.to_string();
        assert!(text.contains("bad.wgsl:1:"), "{text}");
    }
}
