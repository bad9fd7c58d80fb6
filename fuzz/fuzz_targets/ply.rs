//! PLY bytes through `scene::mitsuba::ply::read`; a mesh it returns must
//! keep the reader's promises (finite positions, indices in range,
//! attributes one per vertex or none).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = scene::mitsuba::ply::read(data) {
        rlt_fuzz::check_mesh(&mesh);
    }
});
