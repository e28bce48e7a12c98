//! The library's top-level modules import one another in one direction only: no two modules,
//! directly or through others, import each other (docs/architecture.md draws the layers). Read
//! from the sources: `crate::NAME` and `super::NAME` paths outside comments and test modules.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `text` without comments and without what follows `#[cfg(test)]` (test modules close files).
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap();
    text.lines()
        .map(|line| match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules named after `crate::` in `code`.
fn imports(code: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if modules.contains(&name) {
            found.insert(name);
        }
        // `crate::{a, b::c}`
        if rest.starts_with('{') {
            let group = &rest[1..rest.find('}').unwrap_or(rest.len())];
            for item in group.split(',') {
                let name = item.trim().split("::").next().unwrap().trim();
                if modules.contains(name) {
                    found.insert(name.to_owned());
                }
            }
        }
    }
    found
}

/// The top-level module graph: which modules each imports.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut modules = BTreeSet::new();
    for entry in std::fs::read_dir(&src).unwrap() {
        let path = entry.unwrap().path();
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        if stem != "lib"
            && stem != "tests"
            && (path.is_dir() || path.extension().is_some_and(|e| e == "rs"))
        {
            modules.insert(stem);
        }
    }
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = modules
        .iter()
        .map(|m| (m.clone(), BTreeSet::new()))
        .collect();
    for file in files {
        let relative = file.strip_prefix(&src).unwrap();
        let top = relative.iter().next().unwrap().to_string_lossy();
        let top = top.trim_end_matches(".rs").to_owned();
        if top == "lib" || top == "tests" {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let mut used = imports(&code(&text), &modules);
        used.remove(&top);
        graph.get_mut(&top).unwrap().extend(used);
    }
    graph
}

/// A path of imports from `from` back to `to`, if there is one.
fn path_back(
    graph: &BTreeMap<String, BTreeSet<String>>,
    from: &str,
    to: &str,
    seen: &mut BTreeSet<String>,
) -> Option<Vec<String>> {
    if from == to {
        return Some(vec![to.to_owned()]);
    }
    if !seen.insert(from.to_owned()) {
        return None;
    }
    for next in &graph[from] {
        if let Some(mut path) = path_back(graph, next, to, seen) {
            path.insert(0, from.to_owned());
            return Some(path);
        }
    }
    None
}

#[test]
fn no_two_top_level_modules_import_each_other() {
    let graph = graph();
    assert!(graph.len() >= 8, "{graph:?}");
    let mut cycles = Vec::new();
    for (module, used) in &graph {
        for other in used {
            if let Some(back) = path_back(&graph, other, module, &mut BTreeSet::new()) {
                cycles.push(format!("{module} -> {}", back.join(" -> ")));
            }
        }
    }
    assert!(cycles.is_empty(), "import cycles:\n{}", cycles.join("\n"));
}

/// Each top-level module's layer, lowest first (docs/architecture.md): a module imports only
/// from its own layer or those below.
const RANKS: &[(&str, u32)] = &[
    // Numbers, errors, and the names of what a render asks for (algorithm, device, precision).
    ("math", 0),
    ("error", 0),
    ("algorithm", 0),
    ("mode", 0),
    // Data: scenes, images, a caller's rays and their hits.
    ("scene", 1),
    ("images", 1),
    ("rays", 2),
    // The kernel's contract: what the WGSL and its CPU mirror share (types, the frame and its
    // rays, the byte layouts).
    ("kernel", 3),
    // The image formats, and the BVH and camera-relative data a device is given.
    ("output", 4),
    ("prepare", 4),
    // The devices.
    ("cpu", 5),
    ("gpu", 5),
    // The GPU cost model's traces (feature `model`): the CPU mirror replayed as a GPU runs it.
    ("model", 5),
    // Render policy (adaptive precision, samples, bands, views), then queries on committed
    // geometry.
    ("render", 6),
    ("query", 7),
];

/// The imports from a module to a higher layer than its own, and the modules with no layer.
fn upward_imports(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let rank = |m: &str| RANKS.iter().find(|(name, _)| *name == m).map(|&(_, r)| r);
    let mut wrong = Vec::new();
    for (module, used) in graph {
        let Some(own) = rank(module) else {
            wrong.push(format!("{module} has no layer in RANKS"));
            continue;
        };
        for other in used {
            match rank(other) {
                Some(r) if r > own => wrong.push(format!("{module} ({own}) imports {other} ({r})")),
                _ => {}
            }
        }
    }
    wrong
}

#[test]
fn every_module_imports_only_from_its_layer_or_below() {
    let graph = graph();
    let wrong = upward_imports(&graph);
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn an_upward_import_is_found() {
    let mut graph = graph();
    graph.get_mut("kernel").unwrap().insert("gpu".into());
    graph.insert("newcomer".into(), BTreeSet::new());
    assert_eq!(
        upward_imports(&graph),
        [
            "kernel (3) imports gpu (5)",
            "newcomer has no layer in RANKS"
        ]
    );
}

#[test]
fn the_reader_finds_imports_in_code_only() {
    let modules: BTreeSet<String> = ["gpu", "cpu", "scene"].map(String::from).into();
    let text = "use crate::gpu::Gpu;\n/// [`crate::cpu::render`]\nlet s = crate::{scene, x};\n\
                #[cfg(test)]\nmod tests { use crate::cpu; }";
    let found = imports(&code(text), &modules);
    assert_eq!(found, ["gpu", "scene"].map(String::from).into());
}

/// The Python package's dependency tree holds none of the command line's crates: the library
/// depends on none of them (`cli/` does).
#[test]
fn the_python_package_depends_on_no_command_line_crate() {
    let out = std::process::Command::new(env!("CARGO"))
        .args(["tree", "--offline", "-p", "raycast-python", "-e", "normal"])
        .args(["--prefix", "none", "--format", "{p}"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let tree = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let has = |name: &str| tree.lines().any(|l| l.starts_with(&format!("{name} v")));
    assert!(has("raycast") && has("wgpu"), "{tree}");
    for name in ["clap", "indicatif", "ctrlc", "font8x8"] {
        assert!(
            !has(name),
            "{name} is in the Python package's tree:\n{tree}"
        );
    }
}

/// The library's crate-private top-level modules, as `src/lib.rs` declares them (`mod NAME;`).
/// No client can name them: the compiler keeps the command line, the Python package and the
/// measurement programs to the API.
fn internal_modules() -> BTreeSet<String> {
    let lib =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    lib.lines()
        .filter_map(|l| l.strip_prefix("mod ")?.strip_suffix(';'))
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_inner_layers_are_private() {
    let internal = internal_modules();
    assert!(
        ["cpu", "gpu", "kernel", "prepare", "render"]
            .iter()
            .all(|m| internal.contains(*m)),
        "{internal:?}"
    );
}

#[test]
fn the_public_api_reader_sees_grouped_imports() {
    let internal = internal_modules();
    let text =
        code("use raycast::{Gpu, gpu::Job};\nuse raycast::Scene;").replace("raycast::", "crate::");
    assert_eq!(imports(&text, &internal), ["gpu"].map(String::from).into());
}

/// At most 132 public declarations: every `pub` declaration in src/ is part of the API
/// (everything else is `pub(crate)` or private), counted as lines that open one: the 122
/// items `scripts/public-items.py` counts (#63's cap) as declared, a ratchet that fails when a
/// new one is added without another leaving. The cap is on the default API, so a module that
/// only a cargo feature compiles (declared in lib.rs under `#[cfg(feature = ...)]`, such as
/// `model`, benches/gpu_model's traces) is not counted, nor its declaration.
#[test]
fn at_most_132_items_are_declared_public() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let featured = feature_modules(&std::fs::read_to_string(src.join("lib.rs")).unwrap());
    assert!(featured.contains("model"), "{featured:?}");
    files.retain(|f| {
        let top = f.strip_prefix(&src).unwrap().components().next().unwrap();
        let name = top.as_os_str().to_str().unwrap().trim_end_matches(".rs");
        !featured.contains(name)
    });
    let featured_lines = featured.len();
    let kinds = [
        "fn", "struct", "enum", "trait", "const", "static", "type", "mod", "use",
    ];
    let opens_public = |line: &str| {
        let rest = line.trim_start().strip_prefix("pub ").unwrap_or("");
        kinds.iter().any(|k| rest.starts_with(&format!("{k} ")))
    };
    let declared: usize = files
        .iter()
        .map(|f| {
            std::fs::read_to_string(f)
                .unwrap()
                .lines()
                .filter(|l| opens_public(l))
                .count()
        })
        .sum::<usize>()
        - featured_lines;
    assert!(declared <= 132, "{declared} public declarations in src/");
}

/// The modules lib.rs declares under `#[cfg(feature = ...)]` (attributes may follow the cfg).
fn feature_modules(lib: &str) -> BTreeSet<String> {
    let mut featured = BTreeSet::new();
    let mut gated = false;
    for line in lib.lines().map(str::trim) {
        if line.starts_with("#[cfg(feature") {
            gated = true;
        } else if line.starts_with("#[") {
            continue;
        } else if gated && let Some(name) = line.strip_prefix("pub mod ") {
            featured.insert(name.trim_end_matches(';').to_owned());
            gated = false;
        } else {
            gated = false;
        }
    }
    featured
}
