//! User shade hooks: a WGSL file that defines `fn shade(hit: ShadeHit) -> vec4<f32>`
//! (`shaders/hooks.wgsl` declares `ShadeHit`), called by the kernel once per pixel to colour
//! `color.png` (`raycast render --shader FILE`; `raycast check-shader FILE` checks only).
//!
//! [`ShadeHook::check`] runs before any pipeline is made, in this order:
//! 1. naga parses and validates the user's text on its own, with the `ShadeHit` prelude
//!    appended after it (WGSL allows use before declaration at module scope), so the lines and
//!    columns naga reports are the user's;
//! 2. on that naga module: `shade` exists, takes one `ShadeHit` and returns `vec4<f32>`; the
//!    file declares no entry point, resource binding or pipeline override;
//! 3. no global name of the file's naga module clashes with one the kernel declares in any
//!    variant (read from the shader files, `kernel_names`);
//! 4. the general kernel with the hook appended (`#if USER_SHADE`) validates, its errors mapped
//!    back to the user's lines (this catches what the naga modules do not show, such as an
//!    `alias` named like the kernel's `real`).
//!
//! Every error is an [`Error::Shader`]: `FILE:LINE:COLUMN: error: MESSAGE`, then the source line
//! and a caret under the column (columns count characters, from 1).
//!
//! A checked hook is registered under a `SourceKey`, a hash of its source, which the kernel
//! [`Variant`] carries (so it stays `Copy` and a cache key); the assembler takes the source from
//! the registry. Sources stay registered for the life of the process.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use super::shader::{self, Variant};
use super::source::{SourceKey, error_chain, register, shader_error, span_range, with_hint};
use crate::algorithm::Algorithm;
use crate::error::{Error, Result};
use crate::math::Float;

/// The function a hook file defines.
pub(crate) const HOOK_FUNCTION: &str = "shade";
/// The struct `shade` takes.
pub(crate) const HOOK_INPUT: &str = "ShadeHit";
/// `shaders/hooks.wgsl`: the declaration of [`HOOK_INPUT`], of the scene's materials and lights
/// and their accessors, appended to the user's text.
pub(crate) const PRELUDE: &str = include_str!("../../shaders/hooks.wgsl");
/// The functions that cast rays from a hook, which the kernel defines in shaders/shade.wgsl
/// (`HOOK_RAYS`) from its own internals: declared here with empty bodies for checking a hook on
/// its own, after [`PRELUDE`] (a test holds their signatures to the kernel's).
const RAY_STUBS: &str = "\
fn trace(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> ShadeHit { return ShadeHit(); }
fn occluded(origin: vec3<f32>, direction: vec3<f32>, t_min: f32, t_max: f32) -> bool { return false; }
";
/// The names of the functions in [`RAY_STUBS`].
pub(crate) const RAY_FUNCTIONS: [&str; 2] = ["trace", "occluded"];

/// A checked user shader.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadeHook {
    /// The file it came from, as given (for messages).
    pub file: PathBuf,
    /// Its text.
    pub source: Arc<str>,
    /// Its key in the registry of sources, which kernel variants carry.
    pub(crate) key: SourceKey,
    /// `shade` casts rays of its own, directly or through the file's other functions
    /// (`trace`, `occluded`): its kernel compiles them in (`Variant::hook_rays`).
    pub traces: bool,
}

/// The course's ray tracer as a hook, as shipped (shaders/examples/raytrace.wgsl): what
/// `--lit` runs, and the one hook the CPU reference mirrors (src/cpu/raytrace.rs).
pub(crate) const RAYTRACE: &str = include_str!("../../shaders/examples/raytrace.wgsl");
/// Where [`RAYTRACE`] lives, for messages.
pub(crate) const RAYTRACE_FILE: &str = "shaders/examples/raytrace.wgsl";

impl ShadeHook {
    /// The course's ray tracer as shipped (shaders/examples/raytrace.wgsl), the one hook the
    /// CPU reference mirrors (src/cpu/raytrace.rs): what `--lit` runs.
    pub fn raytrace() -> Result<ShadeHook> {
        ShadeHook::check(RAYTRACE, Path::new(RAYTRACE_FILE))
    }

    /// Reads and checks the hook file at `path`, and registers it. The file defines
    /// `fn shade(hit: ShadeHit) -> vec4<f32>` (shaders/hooks.wgsl declares `ShadeHit`), and may
    /// cast rays with `trace` and `occluded`; errors name it (`FILE:LINE:COLUMN`).
    pub fn load(path: &Path) -> Result<ShadeHook> {
        let source = std::fs::read_to_string(path)
            .map_err(|e| Error::io(path, format!("cannot read: {e}")))?;
        ShadeHook::check(&source, path)
    }

    /// Checks a hook's `source` (read from `file`, which labels errors: `FILE:LINE:COLUMN`) and
    /// registers it. The file defines `fn shade(hit: ShadeHit) -> vec4<f32>`
    /// (shaders/hooks.wgsl declares `ShadeHit`), and may cast rays with `trace` and `occluded`.
    pub(crate) fn check(source: &str, file: &Path) -> Result<ShadeHook> {
        check(source, file)
    }

    /// Whether the CPU reference mirrors this hook: it is [`RAYTRACE`], text for text.
    pub(crate) fn has_cpu_mirror(&self) -> bool {
        &*self.source == RAYTRACE
    }
}

/// Checks a hook's `source` (read from `file`, which labels errors) and registers it (module
/// docs).
fn check(source: &str, file: &Path) -> Result<ShadeHook> {
    let located = |offset: usize, len: usize, message: String| {
        shader_error(file, source, offset, len, message)
    };
    // 1. On its own, with the prelude after it.
    let mut text = source.to_owned();
    if !text.is_empty() && !text.ends_with('\n') {
        text.push('\n');
    }
    let prelude_start = text.len();
    text.push_str(PRELUDE);
    text.push_str(RAY_STUBS);
    let in_user = |offset: usize| offset.min(source.len());
    let module = naga::front::wgsl::parse_str(&text).map_err(|e| {
        let spans: Vec<(usize, usize)> = e
            .labels()
            .map(|(span, _)| span)
            .filter(|span| span.is_defined())
            .map(span_range)
            .collect();
        let mut message = e.message().to_owned();
        if message.ends_with("is recursive") {
            message += " (WGSL has no recursion: cast rays in a loop, as shaders/examples/raytrace.wgsl does)";
        }
        if spans.iter().any(|&(at, _)| at >= prelude_start) {
            message += &format!(
                " (`{HOOK_INPUT}`, the scene's materials and lights and `trace` and `occluded` are declared for the hook: shaders/hooks.wgsl)"
            );
        }
        let (offset, len) = spans
            .iter()
            .copied()
            .find(|&(at, _)| at < prelude_start)
            .unwrap_or((source.len(), 0));
        located(in_user(offset), len, message)
    })?;
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    validator.validate(&module).map_err(|e| {
        // The innermost span (naga adds outer ones as the error climbs) is the most precise.
        let (offset, len) = e
            .spans()
            .map(|(span, _)| *span)
            .filter(|span| span.is_defined() && span_range(*span).0 < prelude_start)
            .last()
            .map_or((0, 0), span_range);
        located(in_user(offset), len, error_chain(&e))
    })?;
    // 2. The hook's signature and what a hook may not declare.
    let shade = check_signature(&module, &located)?;
    let casting = ray_casting_functions(&module);
    check_declarations(&module, prelude_start, &casting, &located)?;
    // 3. Names the kernel uses.
    check_names(&module, &located)?;
    // 4. The kernel with the hook.
    let traces = casting.contains(&shade);
    let (key, source) = register(source);
    check_in_kernel(key, traces, &source, file)?;
    Ok(ShadeHook {
        file: file.to_owned(),
        source,
        key,
        traces,
    })
}

/// The functions of `module` that cast rays: [`RAY_FUNCTIONS`] and every function that calls
/// one of them, directly or not. (naga's arena holds a function after those it calls: WGSL
/// has no recursion.)
fn ray_casting_functions(module: &naga::Module) -> Vec<naga::Handle<naga::Function>> {
    let mut casting = Vec::new();
    for (handle, function) in module.functions.iter() {
        let is_ray_function = function
            .name
            .as_deref()
            .is_some_and(|n| RAY_FUNCTIONS.contains(&n));
        let mut calls_one = false;
        visit_calls(&function.body, &mut |callee| {
            calls_one |= casting.contains(&callee)
        });
        if is_ray_function || calls_one {
            casting.push(handle);
        }
    }
    casting
}

/// Calls `each` with every function `block` calls, in nested blocks too.
fn visit_calls(block: &naga::Block, each: &mut dyn FnMut(naga::Handle<naga::Function>)) {
    use naga::Statement as S;
    for statement in block.iter() {
        match statement {
            S::Call { function, .. } => each(*function),
            S::Block(inner) => visit_calls(inner, each),
            S::If { accept, reject, .. } => {
                visit_calls(accept, each);
                visit_calls(reject, each);
            }
            S::Switch { cases, .. } => cases.iter().for_each(|c| visit_calls(&c.body, each)),
            S::Loop {
                body, continuing, ..
            } => {
                visit_calls(body, each);
                visit_calls(continuing, each);
            }
            _ => {}
        }
    }
}

type Locate<'a> = dyn Fn(usize, usize, String) -> Error + 'a;

/// `shade` exists, takes exactly one `ShadeHit` and returns `vec4<f32>`; its handle.
fn check_signature(
    module: &naga::Module,
    located: &Locate,
) -> Result<naga::Handle<naga::Function>> {
    let wanted = format!("fn {HOOK_FUNCTION}(hit: {HOOK_INPUT}) -> vec4<f32>");
    let Some((handle, function)) = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some(HOOK_FUNCTION))
    else {
        return Err(located(
            0,
            0,
            format!("no function `{HOOK_FUNCTION}`: a hook file defines `{wanted}`"),
        ));
    };
    let (offset, len) = span_range(module.functions.get_span(handle));
    let argument_ok = function.arguments.len() == 1
        && module.types[function.arguments[0].ty].name.as_deref() == Some(HOOK_INPUT);
    let result_ok = function.result.as_ref().is_some_and(|r| {
        module.types[r.ty].inner
            == naga::TypeInner::Vector {
                size: naga::VectorSize::Quad,
                scalar: naga::Scalar::F32,
            }
    });
    if argument_ok && result_ok {
        return Ok(handle);
    }
    let arguments: Vec<String> = function
        .arguments
        .iter()
        .map(|a| type_name(module, a.ty))
        .collect();
    let result = function.result.as_ref().map_or(String::new(), |r| {
        format!(" -> {}", type_name(module, r.ty))
    });
    Err(located(
        offset,
        len.min(2),
        format!(
            "`{HOOK_FUNCTION}` must be `{wanted}`, found `fn {HOOK_FUNCTION}({}){result}`",
            arguments.join(", ")
        ),
    ))
}

/// A WGSL-like name of a type, for messages.
fn type_name(module: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    let t = &module.types[ty];
    if let Some(name) = &t.name {
        return name.clone();
    }
    let scalar = |s: naga::Scalar| match (s.kind, s.width) {
        (naga::ScalarKind::Float, 4) => "f32".to_owned(),
        (naga::ScalarKind::Float, 8) => "f64".to_owned(),
        (naga::ScalarKind::Float, 2) => "f16".to_owned(),
        (naga::ScalarKind::Sint, 4) => "i32".to_owned(),
        (naga::ScalarKind::Uint, 4) => "u32".to_owned(),
        (naga::ScalarKind::Bool, _) => "bool".to_owned(),
        (kind, width) => format!("{kind:?}{}", 8 * width),
    };
    match &t.inner {
        naga::TypeInner::Scalar(s) => scalar(*s),
        naga::TypeInner::Vector { size, scalar: s } => {
            format!("vec{}<{}>", *size as u8, scalar(*s))
        }
        naga::TypeInner::Matrix {
            columns,
            rows,
            scalar: s,
        } => format!("mat{}x{}<{}>", *columns as u8, *rows as u8, scalar(*s)),
        naga::TypeInner::Array { base, .. } => format!("array<{}>", type_name(module, *base)),
        naga::TypeInner::Pointer { base, .. } => format!("ptr<{}>", type_name(module, *base)),
        other => format!("{other:?}"),
    }
}

/// A hook is a function for the kernel to call: it declares no entry point, no resource
/// (the kernel owns the bindings; the prelude's, from `prelude_start` on, are the kernel's) and
/// no pipeline override. `casting`: the functions that cast rays.
fn check_declarations(
    module: &naga::Module,
    prelude_start: usize,
    casting: &[naga::Handle<naga::Function>],
    located: &Locate,
) -> Result<()> {
    if let Some(entry) = module.entry_points.first() {
        let mut casts = false;
        visit_calls(&entry.function.body, &mut |f| casts |= casting.contains(&f));
        // An entry point has no span of its own; its body's first statement is nearest.
        let offset = entry
            .function
            .body
            .span_iter()
            .map(|(_, span)| *span)
            .find(|span| span.is_defined())
            .map_or((0, 0), span_range);
        let what = match casts {
            true => {
                "an entry point that casts rays (`trace` and `occluded` are for `shade` and the functions it calls)"
            }
            false => "an entry point",
        };
        return Err(located(
            offset.0,
            offset.1,
            format!(
                "`{}` is {what}: a hook file declares no @compute, @vertex or @fragment function (the kernel has its own)",
                entry.name
            ),
        ));
    }
    for (handle, g) in module.global_variables.iter() {
        if span_range(module.global_variables.get_span(handle)).0 >= prelude_start {
            continue;
        }
        let private = matches!(
            g.space,
            naga::AddressSpace::Private | naga::AddressSpace::WorkGroup
        );
        if g.binding.is_some() || !private {
            let (offset, len) = span_range(module.global_variables.get_span(handle));
            let name = g.name.as_deref().unwrap_or("?");
            return Err(located(
                offset,
                len,
                format!(
                    "`{name}` is a resource: a hook reads only its `{HOOK_INPUT}` argument (the kernel owns the bindings); use var<private> for mutable globals"
                ),
            ));
        }
    }
    if let Some((handle, o)) = module.overrides.iter().next() {
        let (offset, len) = span_range(module.overrides.get_span(handle));
        return Err(located(
            offset,
            len,
            format!(
                "`{}` is a pipeline override, which hooks cannot set; use const",
                o.name.as_deref().unwrap_or("?")
            ),
        ));
    }
    Ok(())
}

/// A global name of a naga module: what it names, and the name.
fn global_names(module: &naga::Module) -> Vec<(&'static str, String, naga::Span)> {
    let mut names = Vec::new();
    for (h, f) in module.functions.iter() {
        if let Some(n) = &f.name {
            names.push(("function", n.clone(), module.functions.get_span(h)));
        }
    }
    for e in &module.entry_points {
        names.push(("entry point", e.name.clone(), naga::Span::default()));
    }
    for (h, t) in module.types.iter() {
        if let (Some(n), naga::TypeInner::Struct { .. }) = (&t.name, &t.inner) {
            names.push(("struct", n.clone(), module.types.get_span(h)));
        }
    }
    for (h, c) in module.constants.iter() {
        if let Some(n) = &c.name {
            names.push(("constant", n.clone(), module.constants.get_span(h)));
        }
    }
    for (h, g) in module.global_variables.iter() {
        if let Some(n) = &g.name {
            names.push(("variable", n.clone(), module.global_variables.get_span(h)));
        }
    }
    for (h, o) in module.overrides.iter() {
        if let Some(n) = &o.name {
            names.push(("override", n.clone(), module.overrides.get_span(h)));
        }
    }
    names
}

/// The kernel's global names (any variant; the hook's own two left out) and what each names,
/// read from the declarations at the top level of every shader file whatever its `#if`s (and
/// of the host's generated module), so that a hook's check assembles and parses no kernel:
/// parsing every variant with naga would dominate it. A test checks that they
/// hold every name, of the same kind, that naga finds in every variant a device may build.
fn kernel_names() -> &'static HashMap<String, &'static str> {
    static NAMES: OnceLock<HashMap<String, &'static str>> = OnceLock::new();
    NAMES.get_or_init(|| {
        let generated = shader::generated_module();
        let sources = shader::MODULES.iter().map(|(_, text)| *text);
        let mut names = HashMap::new();
        for text in sources.chain([generated.as_str()]) {
            for (what, name) in top_level_names(text) {
                if name != HOOK_FUNCTION && name != HOOK_INPUT {
                    names.entry(name).or_insert(what);
                }
            }
        }
        names
    })
}

/// The names declared at the top level of the WGSL `source` and what each declares, as
/// [`global_names`] calls them (and `alias`). Read line by line, as the shader files are
/// written: a declaration starts a line outside braces, after its attributes, and the lines of
/// every `#if` branch are read, each from the depth of braces at its `#if` (two branches may
/// open one function differently).
fn top_level_names(source: &str) -> Vec<(&'static str, String)> {
    let mut names = Vec::new();
    let mut depth = 0usize;
    // For each open `#if`: the depth at it, and where its first branch ended once `#else` is met.
    let mut branches: Vec<(usize, Option<usize>)> = Vec::new();
    let mut entry_point = false;
    for line in source.lines() {
        let code = line.split("//").next().unwrap_or_default().trim();
        if code.starts_with("#if ") {
            branches.push((depth, None));
        } else if code == "#else" {
            if let Some((at_if, first_end)) = branches.last_mut() {
                *first_end = Some(depth);
                depth = *at_if;
            }
        } else if code == "#endif"
            && let Some((_, Some(first_end))) = branches.pop()
        {
            depth = first_end;
        }
        if depth == 0 && !code.starts_with('#') {
            let (attributes, rest) = strip_attributes(code);
            entry_point |= attributes.contains(&"compute");
            if let Some((keyword, name)) = declared(rest) {
                let what = match keyword {
                    "fn" if entry_point => "entry point",
                    "fn" => "function",
                    "struct" => "struct",
                    "const" => "constant",
                    "var" => "variable",
                    "override" => "override",
                    _ => "alias",
                };
                names.push((what, name.to_owned()));
                entry_point = false;
            }
        }
        let opened = code.matches('{').count();
        let closed = code.matches('}').count();
        depth = (depth + opened).saturating_sub(closed);
    }
    names
}

/// The names of the attributes (`@compute`, `@group(0)`) that begin `code`, and what follows them.
fn strip_attributes(mut code: &str) -> (Vec<&str>, &str) {
    let mut attributes = Vec::new();
    while let Some(rest) = code.strip_prefix('@') {
        let (name, mut rest) = split_identifier(rest);
        attributes.push(name);
        if let Some(arguments) = rest.trim_start().strip_prefix('(') {
            rest = arguments.split_once(')').map_or("", |(_, after)| after);
        }
        code = rest.trim_start();
    }
    (attributes, code)
}

/// The keyword and name of a module-scope declaration that `code` begins, if it begins one.
fn declared(code: &str) -> Option<(&str, &str)> {
    let (keyword, rest) = split_identifier(code);
    if !["fn", "struct", "const", "var", "override", "alias"].contains(&keyword) {
        return None;
    }
    let mut rest = rest.trim_start();
    if keyword == "var" && rest.starts_with('<') {
        rest = rest.split_once('>')?.1.trim_start();
    }
    let (name, _) = split_identifier(rest);
    (!name.is_empty()).then_some((keyword, name))
}

/// The identifier that `text` begins with (maybe empty) and the rest.
fn split_identifier(text: &str) -> (&str, &str) {
    let end = text
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(text.len());
    text.split_at(end)
}

/// The names the prelude and the ray functions declare for the hook.
fn hook_api_names() -> &'static Vec<String> {
    static NAMES: OnceLock<Vec<String>> = OnceLock::new();
    NAMES.get_or_init(|| {
        top_level_names(&format!("{PRELUDE}{RAY_STUBS}"))
            .into_iter()
            .map(|(_, name)| name)
            .collect()
    })
}

/// No global name of the hook's module is one of the kernel's (those declared for the hook
/// aside: declaring one again is naga's error).
fn check_names(module: &naga::Module, located: &Locate) -> Result<()> {
    let kernel = kernel_names();
    for (what, name, span) in global_names(module) {
        if hook_api_names().contains(&name) {
            continue;
        }
        if let Some(theirs) = kernel.get(&name) {
            let (offset, _) = span_range(span);
            return Err(located(
                offset,
                1,
                format!(
                    "the {what} `{name}` clashes with the kernel's {theirs} `{name}`; rename it"
                ),
            ));
        }
    }
    Ok(())
}

/// The general kernel (f32 robust, every kind and output) with the hook registered under
/// `key` validates; an error inside the hook's lines is reported at the user's line.
fn check_in_kernel(key: SourceKey, traces: bool, source: &str, file: &Path) -> Result<()> {
    let variant = Variant::new(Float::F32, Algorithm::Robust).with_shade(key, traces);
    let kernel = shader::kernel_source(&variant)?;
    let start = hook_offset(&kernel, key).expect("the kernel includes the hook");
    let fail = |offset: usize, len: usize, message: String| {
        if (start..start + source.len()).contains(&offset) {
            shader_error(file, source, offset - start, len, message)
        } else {
            let line = kernel[..offset.min(kernel.len())].matches('\n').count() + 1;
            let hint = format!(" (line {line} of the kernel it is appended to; see `emit_shader`)");
            with_hint(shader_error(file, source, 0, 0, message), hint)
        }
    };
    super::source::validate_located(&kernel, &fail)?;
    Ok(())
}

/// Where the hook's source begins in an assembled `kernel`.
pub(crate) fn hook_offset(kernel: &str, key: SourceKey) -> Option<usize> {
    let banner = shader::banner(key);
    kernel.find(&banner).map(|at| at + banner.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::images::Outputs;

    /// [`kernel_names`], read from the shader files, holds every name naga finds in every
    /// variant a device may build (with a hook too), as the same kind of thing.
    #[test]
    fn the_scanned_names_cover_every_variant() {
        let (placeholder, _) =
            register("fn shade(hit: ShadeHit) -> vec4<f32> { return vec4<f32>(0.0); }\n");
        let (tracing, _) = register(TRACING);
        // The tracing hook's own helper.
        let own = top_level_names(TRACING);
        let scanned = kernel_names();
        let mut wrong = std::collections::BTreeSet::new();
        for variant in shader::all_variants() {
            for variant in [
                variant.with_outputs(Outputs::GEOMETRY),
                variant.with_shade(placeholder, false),
                variant.with_shade(tracing, true),
            ] {
                let source = shader::kernel_source(&variant).unwrap();
                let module = naga::front::wgsl::parse_str(&source).unwrap();
                for (what, name, _) in global_names(&module) {
                    if name != HOOK_FUNCTION
                        && name != HOOK_INPUT
                        && !own.iter().any(|(_, n)| *n == name)
                        && scanned.get(&name) != Some(&what)
                    {
                        wrong.insert(format!("{what} {name} (scanned: {:?})", scanned.get(&name)));
                    }
                }
            }
        }
        assert!(
            wrong.is_empty(),
            "names naga finds but the scan does not: {wrong:?}"
        );
    }

    #[test]
    fn top_level_names_are_read_past_attributes_and_bodies() {
        let source = "// fn commented()\n@group(0) @binding(3) var<storage, read> nodes: array<u32>;\n\
                      struct Pair {\n    a: u32,\n}\nconst N: u32 = 4u;\n#if X\nfn f() {\n    let inner = 1u;\n\
                      #else\nfn f(k: u32) {\n#endif\n    var local = 2u;\n}\nalias real = f32;\n\
                      @compute @workgroup_size(8, 8)\nfn main() {}\nvar<private> lane: u32;\n";
        let names = top_level_names(source);
        let expected = [
            ("variable", "nodes"),
            ("struct", "Pair"),
            ("constant", "N"),
            ("function", "f"),
            ("function", "f"),
            ("alias", "real"),
            ("entry point", "main"),
            ("variable", "lane"),
        ];
        let found: Vec<(&str, &str)> = names.iter().map(|(w, n)| (*w, n.as_str())).collect();
        assert_eq!(found, expected);
    }

    /// A hook that casts rays through a function of its own.
    const TRACING: &str = "fn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(vec3<f32>(f32(lit(hit))), 1.0);\n}\n\
                           fn lit(hit: ShadeHit) -> bool {\n    let m = object_material(hit.id);\n    \
                           return !occluded(hit.position, vec3<f32>(0.0, 1.0, 0.0), 1e-4, 1e30) && trace(hit.position, m.kd, 1e-4).id < 0;\n}\n";

    const GOOD: &str = "fn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(hit.normal * 0.5 + 0.5, 1.0);\n}\n";

    fn err(source: &str) -> (usize, usize, String, String) {
        match check(source, Path::new("hook.wgsl")) {
            Err(Error::Shader {
                line,
                column,
                message,
                excerpt,
                ..
            }) => (line, column, message, excerpt),
            other => panic!("expected a shader error, got {other:?}"),
        }
    }

    #[test]
    fn a_good_hook_passes_and_is_keyed_by_its_source() {
        let a = check(GOOD, Path::new("a.wgsl")).unwrap();
        let b = check(GOOD, Path::new("b.wgsl")).unwrap();
        assert_eq!(a.key, b.key);
        assert_eq!(
            super::super::source::registered_source(a.key).as_deref(),
            Some(GOOD)
        );
        let other = GOOD.replace("0.5 + 0.5", "0.25 + 0.5");
        let c = check(&other, Path::new("c.wgsl")).unwrap();
        assert_ne!(a.key, c.key);
        // The kernel variants of the two differ, and each kernel holds its own source.
        let base = Variant::new(Float::F32, Algorithm::Robust);
        let (va, vc) = (base.with_shade(a.key, false), base.with_shade(c.key, false));
        assert_ne!(va, vc);
        assert!(shader::kernel_source(&va).unwrap().contains(GOOD));
        assert!(shader::kernel_source(&vc).unwrap().contains(&other));
    }

    /// The stubs a hook is checked with declare `trace` and `occluded` as the kernels of both
    /// precisions define them (shaders/shade.wgsl).
    #[test]
    fn ray_stubs_have_the_kernels_signatures() {
        let hook = check(TRACING, Path::new("tracing.wgsl")).unwrap();
        assert!(hook.traces);
        let signature = |m: &naga::Module, name: &str| {
            let (_, f) = (m.functions.iter())
                .find(|(_, f)| f.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("no `{name}`"));
            let arguments: Vec<(Option<String>, String)> = (f.arguments.iter())
                .map(|a| (a.name.clone(), type_name(m, a.ty)))
                .collect();
            (arguments, f.result.as_ref().map(|r| type_name(m, r.ty)))
        };
        let stubs = naga::front::wgsl::parse_str(&format!("{PRELUDE}{RAY_STUBS}")).unwrap();
        for precision in [Float::F32, Float::F64] {
            let variant = Variant::new(precision, Algorithm::Robust).with_shade(hook.key, true);
            let source = shader::kernel_source(&variant).unwrap();
            let kernel = naga::front::wgsl::parse_str(&source).unwrap();
            for name in RAY_FUNCTIONS {
                assert_eq!(signature(&kernel, name), signature(&stubs, name), "{name}");
            }
        }
    }

    /// Every example in shaders/examples/ passes the checks (naga only, no adapter).
    #[test]
    fn every_example_validates() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders/examples");
        let mut names = Vec::new();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "wgsl") {
                if let Err(e) = ShadeHook::load(&path) {
                    panic!("{e}");
                }
                names.push(path.file_stem().unwrap().to_string_lossy().into_owned());
            }
        }
        names.sort();
        assert_eq!(
            names,
            ["ambient-occlusion", "checker", "fog", "raytrace", "toon"]
        );
    }

    /// The hook compiles into every plain variant: both precisions and algorithms, any outputs.
    #[test]
    fn hooked_kernels_validate() {
        let hook = check(GOOD, Path::new("a.wgsl")).unwrap();
        for variant in shader::all_variants() {
            if variant.certainty || variant.casts != shader::Casts::Camera {
                continue;
            }
            let variant = variant.with_shade(hook.key, hook.traces);
            assert!(variant.defines().contains(&"USER_SHADE"));
            let source = shader::kernel_source(&variant).unwrap();
            if let Err(e) = shader::validate(&source, format!("{variant:?}")) {
                panic!("{e}");
            }
        }
    }

    #[test]
    fn errors_point_at_the_users_line_and_column() {
        // Type error found by the parser, line 2: `1u` is no f32; naga points at `x`.
        let (line, column, message, excerpt) = err(
            "fn shade(hit: ShadeHit) -> vec4<f32> {\n    let x: f32 = 1u;\n    return vec4<f32>(x);\n}\n",
        );
        assert_eq!((line, column), (2, 9), "{message}");
        assert!(
            message.contains("f32") && message.contains("u32"),
            "{message}"
        );
        assert_eq!(excerpt, "    let x: f32 = 1u;\n        ^");
        // Type error found by the validator, at the innermost span: the returned expression.
        let (line, column, message, excerpt) =
            err("fn shade(hit: ShadeHit) -> vec4<f32> {\n\treturn hit.normal;\n}\n");
        assert_eq!((line, column), (2, 9), "{message}");
        assert!(message.contains("return"), "{message}");
        assert_eq!(excerpt, "\treturn hit.normal;\n\t       ^^^^^^^^^^");
        // Unknown identifier, line 3.
        let (line, column, message, _) = err(
            "// fog\nfn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(fog_colour, 1.0);\n}\n",
        );
        assert_eq!((line, column), (3, 22), "{message}");
        assert!(message.contains("fog_colour"), "{message}");
    }

    #[test]
    fn the_signature_is_checked_on_the_module() {
        for (source, found) in [
            (
                "\nfn shade(hit: ShadeHit, k: f32) -> vec4<f32> { return vec4<f32>(k); }\n",
                "fn shade(ShadeHit, f32) -> vec4<f32>",
            ),
            (
                "\nfn shade(hit: ShadeHit) -> vec3<f32> { return hit.normal; }\n",
                "fn shade(ShadeHit) -> vec3<f32>",
            ),
            (
                "\nfn shade(p: vec3<f32>) -> vec4<f32> { return vec4<f32>(p, 1.0); }\n",
                "fn shade(vec3<f32>) -> vec4<f32>",
            ),
        ] {
            let (line, column, message, _) = err(source);
            assert_eq!((line, column), (2, 1), "{message}");
            assert!(message.contains(found), "{message}");
        }
        let (line, _, message, _) =
            err("fn paint(hit: ShadeHit) -> vec4<f32> { return vec4<f32>(1.0); }\n");
        assert_eq!(line, 1);
        assert!(message.contains("no function `shade`"), "{message}");
    }

    #[test]
    fn names_of_the_kernel_and_resources_are_refused() {
        let (line, column, message, _) = err(&format!(
            "{GOOD}\nfn nearest_hit() -> f32 {{ return 1.0; }}\n"
        ));
        assert_eq!((line, column), (5, 1), "{message}");
        assert!(
            message.contains("function `nearest_hit` clashes"),
            "{message}"
        );
        let (line, _, message, _) = err(&format!("{GOOD}\nstruct Hit {{ t: f32 }}\n"));
        assert_eq!(line, 5, "{message}");
        assert!(message.contains("struct `Hit` clashes"), "{message}");
        // Names only a kernel with a hook has count too.
        let (line, _, message, _) = err(&format!("{GOOD}\nvar<private> out_color: u32;\n"));
        assert_eq!(line, 5, "{message}");
        assert!(
            message.contains("variable `out_color` clashes"),
            "{message}"
        );
        let (line, _, message, _) = err(&format!(
            "{GOOD}\n@group(0) @binding(8) var<storage, read> colours: array<u32>;\n"
        ));
        assert_eq!(line, 5, "{message}");
        assert!(message.contains("resource"), "{message}");
        // Declaring the prelude's struct again points at the user's declaration.
        let (line, _, message, _) = err(&format!("{GOOD}\nstruct ShadeHit {{ x: f32 }}\n"));
        assert_eq!(line, 5, "{message}");
        assert!(message.contains("shaders/hooks.wgsl"), "{message}");
        // An alias shows in no naga module; the kernel check finds it at the user's line.
        let (line, _, message, _) = err(&format!("{GOOD}\nalias real = f32;\n"));
        assert_eq!(line, 5, "{message}");
        assert!(message.contains("real"), "{message}");
    }
}
