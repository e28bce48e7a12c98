//! The kernel's WGSL: a [`Variant`] says what a kernel is specialized for and which names its
//! `#if` blocks test (variant.rs); the preprocessor assembles the files of `shaders/` into one
//! source for it (preprocess.rs), which naga validates before any pipeline is made.

mod preprocess;
mod variant;

pub(crate) use preprocess::*;
pub(crate) use variant::*;
