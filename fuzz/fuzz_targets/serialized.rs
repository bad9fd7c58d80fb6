//! A `.serialized` file through `scene::mitsuba::serialized::read`: the
//! first input byte is the `shape_index`, the rest is the file. A mesh it
//! returns must keep the reader's promises (finite positions, indices in
//! range, attributes one per vertex or none).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&shape_index, file)) = data.split_first() else {
        return;
    };
    if let Ok(mesh) = scene::mitsuba::serialized::read(file, u32::from(shape_index)) {
        rlt_fuzz::check_mesh(&mesh);
    }
    let _ = scene::mitsuba::serialized::mesh_count(file);
});
