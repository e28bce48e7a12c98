//! The kernel's contract: what the WGSL kernel and its CPU mirror share. The value types and
//! their primitives (`types`, mirror of shaders/types.wgsl), the camera frame they cast from
//! (`frame`), and the byte layout of every struct the host hands the GPU (`layout`, checked
//! against naga's layout of the WGSL structs).

pub(crate) mod frame;
pub(crate) mod layout;
pub(crate) mod types;
