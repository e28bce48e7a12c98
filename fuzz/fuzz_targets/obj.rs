//! The OBJ reader on any bytes, in each way of splitting it: an error or parts, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use raycast::{Split, parse_mesh};

fuzz_target!(|data: &[u8]| {
    for split in [Split::None, Split::Objects, Split::Groups] {
        let _ = parse_mesh(data, "fuzz.obj".as_ref(), split);
    }
});
