//! `.gltf` text through `scene::load`. Buffers are data: URIs in the input
//! or the fixed `.bin` files the scratch folder holds (see `rlt_fuzz`).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = rlt_fuzz::write_input("input.gltf", data);
    let _ = rlt_fuzz::load(&path);
});
