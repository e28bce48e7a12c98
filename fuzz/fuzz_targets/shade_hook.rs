//! The shade-hook checker on any text: an error or a hook, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(source) = std::str::from_utf8(data) {
        let _ = raycast::ShadeHook::check(source, "fuzz.wgsl".as_ref());
    }
});
