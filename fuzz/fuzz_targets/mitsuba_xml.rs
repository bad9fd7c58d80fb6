//! A Mitsuba 3 scene file through `scene::load` (with the fixed meshes of
//! `rlt_fuzz::write_mitsuba` beside it).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = rlt_fuzz::write_mitsuba(data);
    let _ = rlt_fuzz::load(&path);
});
