//! An OBJ file and its MTL file through `scene::load`: the input is split at
//! the first NUL byte (OBJ before, MTL after, written as `fuzz.mtl`, the name
//! the seeds' `mtllib` lines use).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = rlt_fuzz::split_obj_mtl(data);
    rlt_fuzz::write_input(rlt_fuzz::MTL_NAME, mtl);
    let path = rlt_fuzz::write_input("input.obj", obj);
    let _ = rlt_fuzz::load(&path);
});
