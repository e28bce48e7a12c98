//! WGSL sources as the host handles them: one registry of the user's sources (shade hooks and
//! kernel files), keyed by a hash of their text so a kernel variant stays
//! `Copy` and a cache key; one validation with naga whose errors point at the file's line and
//! column; and the reflection of a kernel's resource bindings, by which the host binds buffers
//! by name. Sources stay registered for the life of the process.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use crate::error::{Error, Result};

/// Which registered source a kernel includes (a shade hook) or is (a kernel file): a hash of
/// the text, unique within the process (a colliding different text gets the next free value).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct SourceKey(pub u64);

fn registry() -> &'static Mutex<HashMap<SourceKey, Arc<str>>> {
    static SOURCES: OnceLock<Mutex<HashMap<SourceKey, Arc<str>>>> = OnceLock::new();
    SOURCES.get_or_init(Mutex::default)
}

/// Registers `source`, returning its key (the same key for the same text).
pub(crate) fn register(source: &str) -> (SourceKey, Arc<str>) {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    source.hash(&mut hasher);
    let mut key = SourceKey(hasher.finish());
    let mut sources = registry().lock().expect("source registry lock");
    loop {
        match sources.get(&key) {
            Some(s) if **s == *source => return (key, s.clone()),
            Some(_) => key.0 = key.0.wrapping_add(1),
            None => {
                let s: Arc<str> = source.into();
                sources.insert(key, s.clone());
                return (key, s);
            }
        }
    }
}

/// The source registered under `key`.
pub(crate) fn registered_source(key: SourceKey) -> Option<Arc<str>> {
    registry()
        .lock()
        .expect("source registry lock")
        .get(&key)
        .cloned()
}

/// Parses and validates WGSL `source` (read from `file`, which labels errors) with naga; an
/// error is an [`Error::Shader`] at the file's line and column.
pub(crate) fn validate(
    source: &str,
    file: impl AsRef<Path>,
) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    let file = file.as_ref();
    validate_located(source, &|offset, len, message| {
        shader_error(file, source, offset, len, message)
    })
}

/// [`validate`], turning an error at byte `offset` of `source` (`len` bytes underlined) into an
/// [`Error`] with `locate` (which may map it into another file, as for a shade hook inside the
/// kernel).
pub(crate) fn validate_located(
    source: &str,
    locate: &dyn Fn(usize, usize, String) -> Error,
) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        let (offset, len) = e
            .labels()
            .map(|(span, _)| span)
            .find(|span| span.is_defined())
            .map_or((0, 0), span_range);
        locate(offset, len, e.message().to_owned())
    })?;
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    let info = validator.validate(&module).map_err(|e| {
        // The innermost span (naga adds outer ones as the error climbs) is the most precise.
        let (offset, len) = e
            .spans()
            .map(|(span, _)| *span)
            .filter(|span| span.is_defined())
            .last()
            .map_or((0, 0), span_range);
        locate(offset, len, error_chain(&e))
    })?;
    Ok((module, info))
}

/// One resource binding of a kernel.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Binding {
    pub group: u32,
    pub binding: u32,
    pub name: String,
    /// `uniform`, `storage, read` or `storage, read_write`.
    pub space: String,
    /// Bytes of its type (of one element for a runtime-sized array).
    pub size: u32,
    /// Whether the entry point uses it.
    pub used: bool,
}

impl Binding {
    pub(crate) fn describe(&self) -> String {
        format!("`{}`: {}, {} bytes", self.name, self.space, self.size)
    }
}

/// The resource bindings `module` declares, and whether its compute entry point `entry` uses
/// each (none is used without one).
pub(crate) fn bindings(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
) -> Vec<Binding> {
    let entry = module
        .entry_points
        .iter()
        .position(|e| e.name == entry && e.stage == naga::ShaderStage::Compute);
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .expect("a validated module has a layout");
    module
        .global_variables
        .iter()
        .filter_map(|(handle, g)| {
            let at = g.binding.as_ref()?;
            Some(Binding {
                group: at.group,
                binding: at.binding,
                name: g.name.clone().unwrap_or_default(),
                space: space_name(g.space),
                size: layouter[g.ty].size,
                used: entry.is_some_and(|k| !info.get_entry_point(k)[handle].is_empty()),
            })
        })
        .collect()
}

fn space_name(space: naga::AddressSpace) -> String {
    match space {
        naga::AddressSpace::Uniform => "uniform".into(),
        naga::AddressSpace::Storage { access } if access.contains(naga::StorageAccess::STORE) => {
            "storage, read_write".into()
        }
        naga::AddressSpace::Storage { .. } => "storage, read".into(),
        other => format!("{other:?}"),
    }
}

pub(crate) fn span_range(span: naga::Span) -> (usize, usize) {
    let r = span.to_range().unwrap_or(0..0);
    (r.start, r.end - r.start)
}

/// An error's message followed by its causes, `: `-separated, without repeats.
pub(crate) fn error_chain(e: &dyn std::error::Error) -> String {
    let mut parts = vec![e.to_string()];
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if parts.last() != Some(&text) {
            parts.push(text);
        }
        cause = c.source();
    }
    parts.join(": ")
}

/// `error`, a shader error, with the library's advice `hint` after its message.
pub(crate) fn with_hint(mut error: Error, advice: String) -> Error {
    if let Error::Shader { hint, .. } = &mut error {
        *hint = advice;
    }
    error
}

/// An [`Error::Shader`] at byte `offset` of `source` (clamped to it), underlining `len` bytes.
pub(crate) fn shader_error(
    file: &Path,
    source: &str,
    offset: usize,
    len: usize,
    message: String,
) -> Error {
    let mut offset = offset.min(source.len());
    while !source.is_char_boundary(offset) {
        offset -= 1;
    }
    let line_start = source[..offset].rfind('\n').map_or(0, |k| k + 1);
    let line_end = source[offset..]
        .find('\n')
        .map_or(source.len(), |k| offset + k);
    let line_text = source[line_start..line_end].trim_end_matches('\r');
    let before = &source[line_start..offset];
    let column = before.chars().count() + 1;
    let underlined = source[offset..line_end.max(offset)]
        .char_indices()
        .take_while(|(k, _)| *k < len)
        .count()
        .max(1);
    let pad: String = before
        .chars()
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    Error::Shader {
        file: file.to_owned(),
        line: source[..offset].matches('\n').count() + 1,
        column,
        message,
        hint: String::new(),
        excerpt: format!("{line_text}\n{pad}{}", "^".repeat(underlined)),
    }
}
