//! The STL reader on any bytes: an error or triangles, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = raycast::parse_mesh(data, "fuzz.stl".as_ref(), raycast::Split::None);
});
