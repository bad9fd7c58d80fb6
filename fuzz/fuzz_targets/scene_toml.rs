//! `scene.toml` manifest text through `scene::load`. The scratch folder holds
//! no model file a manifest could name (only the fixed glTF buffers), so the
//! target exercises the analytic shapes, materials, lights, camera and render
//! settings; model references end in an error.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = rlt_fuzz::write_input("scene.toml", data);
    let _ = rlt_fuzz::load(&path);
});
