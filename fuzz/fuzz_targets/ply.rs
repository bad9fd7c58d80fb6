//! PLY bytes through `scene::mitsuba::ply::read`; a mesh it returns must
//! keep the reader's promises (finite positions, indices in range,
//! attributes one per vertex or none).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = scene::mitsuba::ply::read(data) {
        check_mesh(&mesh);
    }
});

/// Panics if `mesh` breaks a promise of the mesh readers.
fn check_mesh(mesh: &scene::mitsuba::MeshData) {
    let n = mesh.positions.len();
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
    assert!(mesh.normals.is_empty() || mesh.normals.len() == n);
    assert!(mesh.uvs.is_empty() || mesh.uvs.len() == n);
    assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
}
