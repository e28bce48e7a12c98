//! Kernel assembly: the WGSL files of `shaders/` are stitched together by `#import NAME` lines,
//! each module included once, dependencies first, and `#if NAME` / `#else` / `#endif` blocks
//! are kept or dropped by the kernel's [`Variant`]. The result is one WGSL source that naga
//! validates before any pipeline is made.

use super::super::source::{self, SourceKey};
use super::variant::Variant;
use crate::algorithm::Algorithm;
use crate::error::{Error, Result};
use crate::math::Float;

pub(crate) const MODULES: &[(&str, &str)] = &[
    ("types", include_str!("../../../shaders/types.wgsl")),
    ("bindings", include_str!("../../../shaders/bindings.wgsl")),
    ("frame", include_str!("../../../shaders/frame.wgsl")),
    ("sphere", include_str!("../../../shaders/sphere.wgsl")),
    ("plane", include_str!("../../../shaders/plane.wgsl")),
    ("triangle", include_str!("../../../shaders/triangle.wgsl")),
    ("hit", include_str!("../../../shaders/hit.wgsl")),
    ("traverse", include_str!("../../../shaders/traverse.wgsl")),
    (
        "traverse_packet",
        include_str!("../../../shaders/traverse_packet.wgsl"),
    ),
    (
        "traverse_lanes",
        include_str!("../../../shaders/traverse_lanes.wgsl"),
    ),
    (
        "traverse_ray",
        include_str!("../../../shaders/traverse_ray.wgsl"),
    ),
    ("certainty", include_str!("../../../shaders/certainty.wgsl")),
    ("nearest", include_str!("../../../shaders/nearest.wgsl")),
    ("count", include_str!("../../../shaders/count.wgsl")),
    ("closest", include_str!("../../../shaders/closest.wgsl")),
    ("hooks", include_str!("../../../shaders/hooks.wgsl")),
    ("shade", include_str!("../../../shaders/shade.wgsl")),
    ("entry", include_str!("../../../shaders/entry.wgsl")),
];

/// The module holding the kernel's entry point.
pub(crate) const ENTRY_MODULE: &str = "entry";
/// The kernel's entry point function.
pub(crate) const ENTRY_POINT: &str = "main";

/// The generated module that fixes the kernel's scalar type.
const PRECISION_MODULE: &str = "precision";
/// The generated module holding the user's shade hook.
const USER_MODULE: &str = "user";

fn module_source(name: &str, variant: &Variant) -> Option<String> {
    let precision = variant.precision;
    if name == USER_MODULE {
        return source::registered_source(variant.shade?).map(|s| s.to_string());
    }
    if name == PRECISION_MODULE {
        // Written as literals: naga's constant evaluator does no f64 arithmetic.
        let (eps, t_tolerance) = match precision {
            Float::F32 => (f32::EPSILON as f64, 16.0 * f32::EPSILON as f64),
            Float::F64 => (f64::EPSILON, 16.0 * f64::EPSILON),
        };
        let text = format!(
            "alias real = {};\n\
             // Machine epsilon of real.\n\
             const EPS: real = {eps:e};\n\
             // Relative error bound of a computed t (robust set): 16 EPS.\n\
             const T_TOLERANCE: real = {t_tolerance:e};\n\
             // log2 of the triangles (and BVH nodes) per storage binding.\n\
             const CHUNK_BITS: u32 = {}u;\n\
             // Entries of the BVH traversal's stack: at least the tree's depth, one pending\n\
             // node per level at most (Bvh::stack_entries in src/prepare/bvh.rs).\n\
             const BVH_STACK: u32 = {}u;\n\
             // Rays each invocation casts (Variant::lane_rays).\n\
             const LANE_RAYS: u32 = {}u;\n\
             // The scene's planes, where the kernel is compiled for their number\n\
             // (CONSTANT_PLANES: Variant::planes).\n\
             const PLANE_COUNT: u32 = {}u;\n\
             // A u32 in the space of one real (Plane.object).\n\
             alias id_word = {};\n",
            precision.name(),
            variant.chunk_bits,
            variant.bvh_stack,
            variant.lane_rays(),
            variant.planes,
            match precision {
                Float::F32 => "u32",
                Float::F64 => "vec2<u32>",
            }
        );
        return Some(text);
    }
    MODULES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| s.to_string())
}

/// The module the host generates (`precision`) with every declaration it may hold.
pub(crate) fn generated_module() -> String {
    let variant = Variant::new(Float::F32, Algorithm::Robust);
    module_source(PRECISION_MODULE, &variant).expect("the precision module is generated")
}

/// Assembles `root` and everything it imports into one WGSL source specialized for `variant`.
///
/// Each module appears once, after its imports, under a `// ---- shaders/NAME.wgsl` banner so a
/// reader of the emitted shader can find the file it came from.
pub(crate) fn assemble(root: &str, variant: &Variant) -> Result<String> {
    let mut out = String::new();
    let mut done = Vec::new();
    include(root, variant, &mut done, &mut Vec::new(), &mut out)?;
    Ok(out)
}

/// Keeps the lines of `source` whose enclosing `#if NAME` / `#else` / `#endif` blocks hold
/// under `defines` (`#if !NAME` negates); blocks nest.
pub(crate) fn preprocess(source: &str, defines: &[&str], module: &str) -> Result<String> {
    let fail = |line: usize, m: &str| Error::Device(format!("shaders/{module}.wgsl:{line}: {m}"));
    // For each open block: (this branch is kept, some enclosing block drops it).
    let mut stack: Vec<(bool, bool)> = Vec::new();
    let mut out = String::new();
    for (k, line) in source.lines().enumerate() {
        let t = line.trim();
        let outer_off = stack.iter().any(|&(on, outer)| !on || outer);
        if let Some(cond) = t.strip_prefix("#if ") {
            let cond = cond.trim();
            let on = match cond.strip_prefix('!') {
                Some(name) => !defines.contains(&name.trim()),
                None => defines.contains(&cond),
            };
            stack.push((on, outer_off));
        } else if t == "#else" {
            let top = stack
                .last_mut()
                .ok_or_else(|| fail(k + 1, "#else without #if"))?;
            top.0 = !top.0;
        } else if t == "#endif" {
            stack
                .pop()
                .ok_or_else(|| fail(k + 1, "#endif without #if"))?;
        } else if !outer_off {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !stack.is_empty() {
        return Err(fail(source.lines().count(), "#if without #endif"));
    }
    Ok(out)
}

/// Writes the lines of each `#each_ray` ... `#end_each` block of `source` once per ray of a
/// lane (`rays`: Variant::lane_rays), `$r` in them replaced by the ray's number (0, 1, ...):
/// code for each of a lane's rays, written out because llvmpipe keeps arrays indexed in loops
/// in memory. Blocks do not nest; `#if` blocks inside are repeated with them.
pub(crate) fn each_ray(source: &str, rays: u32, module: &str) -> Result<String> {
    let fail = |line: usize, m: &str| Error::Device(format!("shaders/{module}.wgsl:{line}: {m}"));
    let mut out = String::new();
    let mut block: Option<Vec<&str>> = None;
    for (k, line) in source.lines().enumerate() {
        match (line.trim(), &mut block) {
            ("#each_ray", None) => block = Some(Vec::new()),
            ("#each_ray", Some(_)) => return Err(fail(k + 1, "#each_ray inside #each_ray")),
            ("#end_each", None) => return Err(fail(k + 1, "#end_each without #each_ray")),
            ("#end_each", Some(lines)) => {
                for r in 0..rays {
                    for l in lines.iter() {
                        out.push_str(&l.replace("$r", &r.to_string()));
                        out.push('\n');
                    }
                }
                block = None;
            }
            (_, Some(lines)) => lines.push(line),
            (_, None) => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    match block {
        Some(_) => Err(fail(source.lines().count(), "#each_ray without #end_each")),
        None => Ok(out),
    }
}

fn include(
    name: &str,
    variant: &Variant,
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
    let source = module_source(name, variant)
        .ok_or_else(|| Error::Device(format!("shaders: unknown module `{name}`")))?;
    if name == USER_MODULE {
        // The user's text is appended as it is, never preprocessed.
        let key = variant.shade.expect("a user module has a key");
        out.push_str(&banner(key));
        out.push_str(&source);
        if !source.ends_with('\n') {
            out.push('\n');
        }
        done.push(name.to_owned());
        return Ok(());
    }
    let source = preprocess(
        &each_ray(&source, variant.lane_rays(), name)?,
        &variant.defines(),
        name,
    )?;
    stack.push(name.to_owned());
    for import in imports(&source) {
        include(import, variant, done, stack, out)?;
    }
    stack.pop();
    if name == PRECISION_MODULE {
        out.push_str("// ---- precision (generated by the host)\n");
    } else {
        out.push_str(&format!("// ---- shaders/{name}.wgsl\n"));
    }
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
pub(crate) fn imports(source: &str) -> impl Iterator<Item = &str> {
    source.lines().filter_map(import_name)
}

pub(crate) use source::validate;

/// The banner line the assembler writes above a shade hook's source.
pub(crate) fn banner(key: SourceKey) -> String {
    format!("// ---- user shade hook {:016x}\n", key.0)
}

/// The full kernel source for `variant`: the user's kernel where it names one, else the
/// assembled one.
pub(crate) fn kernel_source(variant: &Variant) -> Result<String> {
    if let Some(key) = variant.kernel {
        return source::registered_source(key)
            .map(|s| s.to_string())
            .ok_or_else(|| Error::Device(format!("no user kernel registered as {key:?}")));
    }
    assemble(ENTRY_MODULE, variant)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shader::{Casts, MAX_CHUNKS, all_variants};

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
        use rayon::prelude::*;
        MODULES.par_iter().for_each(|(name, _)| {
            // The traversal modules need the BVH's bindings, the packets' their subgroups: each
            // is validated where the kernel may import it.
            let needs = match *name {
                "traverse" | "traverse_ray" => Some("BVH"),
                "traverse_packet" => Some("PACKETS"),
                "traverse_lanes" => Some("LANES"),
                _ => None,
            };
            let variants = all_variants().into_iter();
            for variant in variants.filter(|v| needs.is_none_or(|d| v.defines().contains(&d))) {
                let source = assemble(name, &variant).unwrap();
                let label = format!("shaders/{name}.wgsl ({variant:?})");
                if let Err(e) = validate(&source, &label) {
                    panic!("{e}");
                }
            }
        });
    }

    /// The host binds buffers by name, so nothing but naga and wgpu would notice two resources
    /// declared at one binding number: every variant, certainty and pixel list together too,
    /// has distinct numbers.
    #[test]
    fn no_two_resources_share_a_binding() {
        let both = Variant {
            certainty: true,
            casts: Casts::Rays,
            bvh: true,
            chunks: MAX_CHUNKS,
            ..Variant::new(Float::F32, Algorithm::Robust)
        };
        for variant in all_variants().into_iter().chain([both]) {
            let (module, info) = validate(&kernel_source(&variant).unwrap(), "kernel").unwrap();
            let mut seen = std::collections::HashMap::new();
            for b in source::bindings(&module, &info, ENTRY_POINT) {
                if let Some(other) = seen.insert((b.group, b.binding), b.name.clone()) {
                    panic!(
                        "{other} and {} share @binding({}) in {variant:?}",
                        b.name, b.binding
                    );
                }
            }
        }
    }

    /// Kernels assembled from shaders/ run without wgpu's index clamps
    /// (`Variant::is_ours`): the traversal's stacks must hold one waiting node per level of
    /// the tree, so the kernel's `BVH_STACK` is the variant's, which the dispatch sizes to the
    /// prepared tree (`Bvh::stack_entries`, at least its depth), and MAX_DEPTH before that.
    #[test]
    fn traversal_stack_is_the_variants() {
        let plain = Variant {
            bvh: true,
            ..Variant::new(Float::F32, Algorithm::Robust)
        };
        assert_eq!(plain.bvh_stack as usize, crate::prepare::bvh::MAX_DEPTH);
        for entries in [8, 24, plain.bvh_stack] {
            let variant = Variant {
                bvh_stack: entries,
                ..plain
            };
            let (module, _) = validate(&kernel_source(&variant).unwrap(), "kernel").unwrap();
            let (_, stack) = module
                .constants
                .iter()
                .find(|(_, c)| c.name.as_deref() == Some("BVH_STACK"))
                .expect("the kernel declares BVH_STACK");
            match module.global_expressions[stack.init] {
                naga::Expression::Literal(naga::Literal::U32(n)) => {
                    assert_eq!(n, entries as u32)
                }
                ref e => panic!("BVH_STACK is {e:?}"),
            }
        }
    }

    #[test]
    fn kernel_has_its_entry_point() {
        let variant = Variant::new(Float::F32, Algorithm::Textbook);
        let (module, _) = validate(&kernel_source(&variant).unwrap(), "kernel").unwrap();
        assert!(module.entry_points.iter().any(|e| e.name == ENTRY_POINT));
    }

    #[test]
    fn each_module_is_included_once() {
        let hook = "fn shade(hit: ShadeHit) -> vec4<f32> { return vec4<f32>(1.0); }\n";
        let hook =
            crate::gpu::hooks::ShadeHook::check(hook, std::path::Path::new("hook.wgsl")).unwrap();
        let variant = Variant {
            bvh: true,
            ..Variant::new(Float::F64, Algorithm::Robust)
        };
        let certainty = Variant {
            certainty: true,
            ..Variant::new(Float::F32, Algorithm::Robust)
        };
        let packets = Variant {
            bvh: true,
            packets: true,
            eight_lanes: true,
            ..Variant::new(Float::F32, Algorithm::Robust)
        };
        for (variant, with_hook) in [
            (variant, false),
            (variant.with_shade(hook.key, hook.traces), true),
            (packets, false),
            (
                Variant {
                    eight_lanes: false,
                    ..packets
                },
                false,
            ),
            (certainty, false),
            (
                Variant {
                    bvh: true,
                    ..certainty
                },
                false,
            ),
        ] {
            let source = kernel_source(&variant).unwrap();
            assert!(source.contains(&format!("alias real = {};", variant.precision.name())));
            for (name, _) in MODULES {
                let banner = format!("// ---- shaders/{name}.wgsl\n");
                let expected = usize::from(match *name {
                    "hooks" | "shade" => with_hook,
                    "certainty" => variant.certainty,
                    "traverse" => variant.bvh,
                    "traverse_packet" => variant.uses_packets(),
                    "traverse_lanes" => variant.lane_rays() > 1,
                    "traverse_ray" => variant.bvh && !variant.uses_packets(),
                    "count" => variant.count,
                    "closest" => variant.closest,
                    _ => true,
                });
                assert_eq!(source.matches(&banner).count(), expected, "{name}");
            }
            let hooks_in = source.matches(&banner(hook.key)).count();
            assert_eq!(hooks_in, usize::from(with_hook));
        }
    }

    #[test]
    fn preprocessor_keeps_the_branches_that_hold() {
        let src = "a\n#if X\nb\n#if !Y\nc\n#else\nd\n#endif\n#else\ne\n#endif\nf\n";
        assert_eq!(preprocess(src, &["X"], "t").unwrap(), "a\nb\nc\nf\n");
        assert_eq!(preprocess(src, &["X", "Y"], "t").unwrap(), "a\nb\nd\nf\n");
        assert_eq!(preprocess(src, &[], "t").unwrap(), "a\ne\nf\n");
        assert!(preprocess("#if X\n", &[], "t").is_err());
        assert!(preprocess("#endif\n", &[], "t").is_err());
    }

    #[test]
    fn each_ray_blocks_are_written_once_per_ray() {
        let src = "a\n#each_ray\nlet x$r = $ru;\n#if X\ny$r\n#endif\n#end_each\nb\n";
        let expected = "a\nlet x0 = 0u;\n#if X\ny0\n#endif\nlet x1 = 1u;\n#if X\ny1\n#endif\nb\n";
        assert_eq!(each_ray(src, 2, "t").unwrap(), expected);
        assert_eq!(
            each_ray(src, 1, "t").unwrap(),
            "a\nlet x0 = 0u;\n#if X\ny0\n#endif\nb\n"
        );
        assert!(each_ray("#each_ray\n", 2, "t").is_err());
        assert!(each_ray("#end_each\n", 2, "t").is_err());
        assert!(each_ray("#each_ray\n#each_ray\n#end_each\n", 2, "t").is_err());
    }

    #[test]
    fn a_shader_error_is_reported_with_its_location() {
        let err = validate("fn f() -> f32 { return 1u; }\n", "bad.wgsl").unwrap_err();
        let text = err.to_string();
        assert!(text.contains("bad.wgsl:1:"), "{text}");
    }
}
