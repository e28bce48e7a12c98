//! User kernels: `raycast render SCENE --kernel FILE` runs a complete WGSL kernel, as
//! `--emit-shader` writes it (possibly edited), instead of the assembled one.
//!
//! The kernel [`Variant`] is chosen as usual, from the scene and the request; the file only
//! replaces its source. So that what the host binds fits the file:
//! 1. `check` parses and validates the file with naga (errors at `FILE:LINE:COLUMN`, as for
//!    shade hooks) and finds its compute entry point `main`;
//! 2. [`UserKernel::for_variant`] compares, on the naga modules, the file's resource bindings
//!    with those of the assembled kernel of that variant: the same binding numbers, each with
//!    the same address space, access and size, and each used by `main` (wgpu derives the
//!    pipeline layout from the bindings the entry point uses, and refuses a bind group with
//!    more); and the same workgroup size, which the host's dispatch counts assume.
//!
//! A mismatch, such as a kernel emitted for a scene with other primitive kinds, precision or
//! outputs, is a one-line [`Error::Argument`] naming `--kernel FILE`. The variant that passes
//! carries the file's `SourceKey`, a hash of its text in the source registry, so the
//! pipeline cache never gives one file's pipeline to another.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::shader::{self, Variant};
use super::source::{self, SourceKey};
use crate::error::{Error, Result};

/// A checked user kernel.
#[derive(Clone, Debug, PartialEq)]
pub struct UserKernel {
    /// The file it came from, as given (for messages).
    pub file: PathBuf,
    /// Its text.
    pub source: Arc<str>,
    /// Its key in the registry of sources, which kernel variants carry.
    pub(crate) key: SourceKey,
    interface: Interface,
}

/// What the host must match: the kernel's resource bindings and its workgroup size.
#[derive(Clone, Debug, PartialEq)]
struct Interface {
    bindings: Vec<source::Binding>,
    workgroup_size: [u32; 3],
}

impl UserKernel {
    /// Reads and checks the kernel file at `path`: a complete kernel, run instead of the
    /// assembled one, that declares the assembled kernel's bindings (`raycast render
    /// --emit-shader` writes one to start from).
    pub fn load(path: &Path) -> Result<UserKernel> {
        let source = std::fs::read_to_string(path)
            .map_err(|e| Error::io(path, format!("cannot read: {e}")))?;
        check(&source, path)
    }
}

/// Validates a kernel's `source` (read from `file`, which labels errors) with naga, finds its
/// entry point and registers it.
pub(crate) fn check(source: &str, file: &Path) -> Result<UserKernel> {
    let (module, info) = shader::validate(source, file)?;
    let interface = interface(&module, &info).ok_or_else(|| {
        let error = source::shader_error(file, source, 0, 0, no_entry_point());
        source::with_hint(error, WHOLE_KERNEL.into())
    })?;
    let (key, source) = source::register(source);
    Ok(UserKernel {
        file: file.to_owned(),
        source,
        key,
        interface,
    })
}

fn no_entry_point() -> String {
    format!(
        "no `@compute fn {}`: a kernel file is a whole kernel",
        shader::ENTRY_POINT
    )
}

/// What [`no_entry_point`] advises.
const WHOLE_KERNEL: &str = ", as `emit_shader` writes it";

/// The bindings and workgroup size of `module`'s compute entry point `main`, `None` without
/// one.
fn interface(module: &naga::Module, info: &naga::valid::ModuleInfo) -> Option<Interface> {
    let entry = module
        .entry_points
        .iter()
        .find(|e| e.name == shader::ENTRY_POINT && e.stage == naga::ShaderStage::Compute)?;
    let mut bindings = source::bindings(module, info, shader::ENTRY_POINT);
    bindings.sort_by_key(|b| (b.group, b.binding));
    Some(Interface {
        bindings,
        workgroup_size: entry.workgroup_size,
    })
}

/// The interface of the assembled kernel for `variant`.
fn assembled_interface(variant: &Variant) -> Result<Interface> {
    let assembled = Variant {
        kernel: None,
        ..*variant
    };
    let source = shader::kernel_source(&assembled)?;
    let (module, info) = shader::validate(&source, Path::new("kernel"))?;
    interface(&module, &info)
        .ok_or_else(|| Error::Device(format!("kernel: {}{WHOLE_KERNEL}", no_entry_point())))
}

/// Why a kernel with `ours` does not fit a host that binds `theirs`, if it does not.
fn mismatch(theirs: &Interface, ours: &Interface) -> Option<String> {
    for t in &theirs.bindings {
        let Some(o) = ours
            .bindings
            .iter()
            .find(|o| (o.group, o.binding) == (t.group, t.binding))
        else {
            return Some(format!(
                "this scene and request bind @group({}) @binding({}) ({}), which the kernel does not declare",
                t.group,
                t.binding,
                t.describe()
            ));
        };
        if (&o.space, o.size) != (&t.space, t.size) {
            return Some(format!(
                "@group({}) @binding({}) is {} in the kernel, but this scene and request bind {}",
                t.group,
                t.binding,
                o.describe(),
                t.describe()
            ));
        }
        if !o.used {
            return Some(format!(
                "@group({}) @binding({}) ({}) is declared but never used by `{}`; the host binds it for this scene and request, so the kernel must use it",
                o.group,
                o.binding,
                o.describe(),
                shader::ENTRY_POINT
            ));
        }
    }
    if let Some(o) = ours.bindings.iter().find(|o| {
        !theirs
            .bindings
            .iter()
            .any(|t| (t.group, t.binding) == (o.group, o.binding))
    }) {
        return Some(format!(
            "the kernel declares @group({}) @binding({}) ({}), which this scene and request do not bind",
            o.group,
            o.binding,
            o.describe()
        ));
    }
    if ours.workgroup_size != theirs.workgroup_size {
        return Some(format!(
            "`{}` has @workgroup_size{:?}; the host dispatches for {:?}",
            shader::ENTRY_POINT,
            ours.workgroup_size,
            theirs.workgroup_size
        ));
    }
    None
}

impl UserKernel {
    /// `variant`, running this kernel: an error when its bindings or workgroup size differ from
    /// those of the assembled kernel for `variant` (module docs).
    pub(crate) fn for_variant(&self, variant: Variant) -> Result<Variant> {
        let theirs = assembled_interface(&variant)?;
        if let Some(why) = mismatch(&theirs, &self.interface) {
            return Err(Error::Argument {
                option: format!("kernel {}", self.file.display()),
                message: format!(
                    "{why} (a kernel emitted for another scene, precision or `outputs`? write one for this render with `emit_shader`)"
                ),
            });
        }
        Ok(Variant {
            kernel: Some(self.key),
            ..variant
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Algorithm;
    use crate::math::Float;

    fn assembled(variant: &Variant) -> String {
        shader::kernel_source(variant).unwrap()
    }

    #[test]
    fn an_assembled_kernel_fits_its_own_variant_and_runs_as_itself() {
        let variant = Variant::new(Float::F32, Algorithm::Robust);
        let source = assembled(&variant);
        let kernel = check(&source, Path::new("k.wgsl")).unwrap();
        let with = kernel.for_variant(variant).unwrap();
        assert_eq!(with.kernel, Some(kernel.key));
        assert_eq!(shader::kernel_source(&with).unwrap(), source);
        // Another text is another key, so another pipeline.
        let edited = check(&format!("{source}\n// edited\n"), Path::new("k.wgsl")).unwrap();
        assert_ne!(edited.key, kernel.key);
    }

    #[test]
    fn a_kernel_of_other_kinds_precision_or_outputs_does_not_fit() {
        let base = Variant::new(Float::F32, Algorithm::Robust);
        let spheres_only = base.with_kinds(shader::Kinds {
            spheres: true,
            planes: false,
            triangles: false,
        });
        let kernel = check(&assembled(&spheres_only), Path::new("s.wgsl")).unwrap();
        let Err(Error::Argument { option, message }) = kernel.for_variant(base) else {
            panic!("a spheres-only kernel fits every kind");
        };
        assert_eq!(option, "kernel s.wgsl");
        assert!(message.contains("@binding(2)"), "{message}");
        assert!(!message.contains('\n'), "{message}");
        let f64 = Variant::new(Float::F64, Algorithm::Robust);
        // f64 changes the size of everything real, Params first.
        let message = kernel.for_variant(f64.with_kinds(spheres_only.kinds));
        assert!(format!("{message:?}").contains("224 bytes"), "{message:?}");
        let distance = base.with_outputs(crate::images::Outputs {
            distance: true,
            ..crate::images::Outputs::NONE
        });
        let kernel = check(&assembled(&distance), Path::new("d.wgsl")).unwrap();
        // A distance-only kernel declares `out_distance` where the base binds `out_surface`.
        let message = format!("{:?}", kernel.for_variant(base));
        assert!(message.contains("@binding(5) (`out_surface`"), "{message}");
    }

    #[test]
    fn an_unused_binding_or_another_workgroup_size_does_not_fit() {
        let base = Variant::new(Float::F32, Algorithm::Robust);
        let source = assembled(&base);
        let unused = source.replace(
            "out_id[index] = select(hit.object, -1, hit.object < 0);",
            "",
        );
        assert_ne!(unused, source);
        let kernel = check(&unused, Path::new("u.wgsl")).unwrap();
        let message = format!("{:?}", kernel.for_variant(base));
        assert!(message.contains("never used"), "{message}");
        let wide = source.replace("@workgroup_size(8, 8)", "@workgroup_size(16, 4)");
        let kernel = check(&wide, Path::new("w.wgsl")).unwrap();
        let message = format!("{:?}", kernel.for_variant(base));
        assert!(message.contains("workgroup_size"), "{message}");
    }

    #[test]
    fn errors_point_at_the_files_line_and_column() {
        let source = "fn f() -> f32 {\n    return 1.0;\n}\n\n@compute @workgroup_size(8, 8)\nfn main() {\n    let x: f32 = 1u;\n}\n";
        match check(source, Path::new("bad.wgsl")) {
            Err(Error::Shader { line, column, .. }) => assert_eq!((line, column), (7, 9)),
            other => panic!("{other:?}"),
        }
        match check("fn f() {}\n", Path::new("none.wgsl")) {
            Err(Error::Shader { message, .. }) => assert!(message.contains("@compute fn main")),
            other => panic!("{other:?}"),
        }
    }
}
