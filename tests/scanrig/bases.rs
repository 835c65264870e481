//! Issue 22: the base of a scan standing on the platter, and trimming made-up surface. Measured against
//! the simulator's truth on the shared two-view demo, whose mesh `process` cut flat by default.

use crate::run::scanrig;
use process::mesh_distance::MeshDistance;
use rig::TriMesh;
use std::path::Path;

fn ok(o: std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// RMS distance to the truth of the mesh's vertices above the bottom 3 mm, and the largest below.
fn against_truth(mesh: &TriMesh, truth: &MeshDistance) -> (f64, f64) {
    let (mut sum, mut n, mut low) = (0.0, 0, 0.0f64);
    for v in &mesh.vertices {
        let d = truth.distance_up_to(v, 50.0);
        if v.z > 3.0 {
            sum += d * d;
            n += 1;
        } else {
            low = low.max(d);
        }
    }
    ((sum / n as f64).sqrt(), low)
}

fn read(p: &Path) -> TriMesh {
    rig::read_mesh(p).unwrap().triangulate()
}

#[test]
fn a_flat_base_lies_on_the_platter_closed_and_costs_nothing_above_it() {
    let d = tempfile::tempdir().unwrap();
    let demo = crate::shared_demo::copy_demo(d.path());
    let p = demo.join("processed");
    let truth_mesh = read(&demo.join("scan/truth/object.ply"));
    let diag = truth_mesh.bounding_box().unwrap().diagonal();
    let truth = MeshDistance::new(&truth_mesh, 2.0);

    // process's default: flat, exactly on the platter plane, closed.
    let flat = read(&p.join("mesh.ply"));
    let t = rig::topology::topology(&flat);
    assert_eq!(t.genus(), Some(0), "closed: {t:?}");
    let low = flat.vertices.iter().map(|v| v.z).fold(f64::INFINITY, f64::min);
    assert_eq!(low, 0.0);
    let on_base = flat.vertices.iter().filter(|v| v.z == 0.0).count();
    assert!(on_base > 100, "{on_base} vertices on the base");
    assert!(flat.vertices.iter().all(|v| v.z >= 0.0), "nothing below the platter");

    // The same cloud, the base as reconstructed: above 3 mm the two are the same surface.
    let closed_cloud = p.join("closed.ply");
    let kept = d.path().join("kept.ply");
    ok(scanrig(&[&"reconstruct", &closed_cloud, &"-o", &kept, &"--base", &"closed"]));
    let (rms_flat, low_flat) = against_truth(&flat, &truth);
    let (rms_kept, low_kept) = against_truth(&read(&kept), &truth);
    eprintln!(
        "base: flat RMS above 3 mm {:.4} % of the diagonal (kept: {:.4} %), largest error below 3 mm {low_flat:.3} mm \
         (kept: {low_kept:.3} mm), {on_base} vertices on z = 0",
        100.0 * rms_flat / diag,
        100.0 * rms_kept / diag
    );
    assert!(rms_flat <= 1.01 * rms_kept, "flat {rms_flat} against kept {rms_kept}");
    assert!(low_flat <= low_kept + 1e-9, "the flat base is no worse at the bottom: {low_flat} vs {low_kept}");

    // Open: nothing below the platter either, and the base left open.
    let open = d.path().join("open.ply");
    let said = ok(scanrig(&[&"reconstruct", &closed_cloud, &"-o", &open, &"--base", &"open"]));
    assert!(said.contains("base: cut at z = 0 (Open"), "{said}");
    let t = rig::topology::topology(&read(&open));
    assert!(t.genus().is_none() && t.boundary_edges > 0, "open at the base: {t:?}");

    // A base needs the platter: a cloud that does not say it is in a turntable frame is refused.
    let bare = d.path().join("bare.obj");
    ok(scanrig(&[&"convert", &p.join("fused.ply"), &bare]));
    let o = scanrig(&[&"reconstruct", &bare, &"-o", &d.path().join("x.ply"), &"--base", &"flat"]);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("give --close if it is"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );

    // Trimming what no view saw: two views leave much made up. Open holes, manifold; filled, closed.
    let trimmed = d.path().join("trimmed.ply");
    ok(scanrig(&[&"reconstruct", &closed_cloud, &"-o", &trimmed, &"--trim", &"1.5"]));
    let t = rig::topology::topology(&read(&trimmed));
    assert!(t.boundary_edges > 0 && t.non_manifold_edges == 0 && t.non_manifold_vertices == 0, "{t:?}");
    let filled = d.path().join("filled.ply");
    ok(scanrig(&[&"reconstruct", &closed_cloud, &"-o", &filled, &"--trim", &"1.5", &"--trim-fill"]));
    let t = rig::topology::topology(&read(&filled));
    assert!(t.genus().is_some(), "closed again: {t:?}");
}
