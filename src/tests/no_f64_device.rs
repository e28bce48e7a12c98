//! A device without `SHADER_F64` builds the robust f32 kernel without its f64 edge recheck
//! (cli/tests/suite/no_f64_device.rs renders with it).

use super::common::gpu_without_f64;
use raycast::Algorithm::Robust;
use raycast::math::Float;

#[test]
fn the_robust_f32_kernel_leaves_out_the_f64_recheck() {
    let gpu = gpu_without_f64();
    let defines = gpu.variant(Float::F32, Robust).defines();
    assert!(!defines.contains(&"RECHECK_F64"), "{defines:?}");
    let with = super::common::gpu().variant(Float::F32, Robust).defines();
    assert!(with.contains(&"RECHECK_F64"), "{with:?}");
}
