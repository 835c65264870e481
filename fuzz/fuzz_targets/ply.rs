#![no_main]
//! PLY: header, body in every encoding, and the conversions to clouds, meshes, range grids and sparse views.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(p) = rig::ply::parse(bytes) {
        let _ = rig::ply::cloud_from_ply(&p);
        let _ = rig::ply::mesh_from_ply(&p);
        let _ = rig::ply::range_grid_from_ply(&p);
        let _ = rig::ply::sparse_view_from_ply(&p);
        let _ = p.header.units();
    }
});
