//! `.glb` bytes through `scene::load`.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = rlt_fuzz::write_input("input.glb", data);
    let _ = rlt_fuzz::load(&path);
});
