//! Issue 10, acceptance 1: the plate of the thesis's fig. 6.2 — a rectangle held at 0 along its bottom
//! and 1 along its top, insulated sides, and an inner square whose conductivity is 1, 0, 1e-3 or 1e3
//! times the rest. Contour images go to the test target folder; the numbers check the physics.

use process::remesh::harmonic::{face_gradients, harmonic_field};
use rig::TriMesh;
use rig::image::Image8;
use rig::math::{Point3, Real};

const W: usize = 60;
const H: usize = 40;

fn plate() -> TriMesh {
    fixtures::plate(W, H, false)
}

/// Whether a face's centroid lies in the inner square (the middle third of each side).
fn inner(m: &TriMesh, f: usize) -> bool {
    let c = m.faces[f].iter().fold(Point3::origin().coords, |a, &v| a + m.vertices[v as usize].coords) / 3.0;
    (20.0..40.0).contains(&c.x) && (13.0..27.0).contains(&c.y)
}

/// The field as a picture: 8 px per cell, black contours every 0.05, the inner square outlined in grey.
fn contour_image(u: &[Real]) -> Image8 {
    let s = 8usize;
    let (pw, ph) = (W * s, H * s);
    let at = |x: usize, y: usize| {
        let (fx, fy) = (x as Real / s as Real, y as Real / s as Real);
        let (i, j) = ((fx as usize).min(W - 1), (fy as usize).min(H - 1));
        let (tx, ty) = (fx - i as Real, fy - j as Real);
        let v = |i: usize, j: usize| u[j * (W + 1) + i];
        (v(i, j) * (1.0 - tx) + v(i + 1, j) * tx) * (1.0 - ty) + (v(i, j + 1) * (1.0 - tx) + v(i + 1, j + 1) * tx) * ty
    };
    let band = |x: usize, y: usize| (at(x, y) / 0.05).floor() as i64;
    let mut data = vec![255u8; pw * ph];
    for y in 0..ph {
        for x in 0..pw {
            let row = ph - 1 - y; // y up
            let (cx, cy) = (x as Real / s as Real, y as Real / s as Real);
            let edge = |a: Real, lo: Real, hi: Real| (a - lo).abs() < 0.07 || (a - hi).abs() < 0.07;
            if ((20.0..=40.0).contains(&cx) && edge(cy, 13.0, 27.0))
                || ((13.0..=27.0).contains(&cy) && edge(cx, 20.0, 40.0))
            {
                data[row * pw + x] = 150;
            }
            if x + 1 < pw && y + 1 < ph && (band(x, y) != band(x + 1, y) || band(x, y) != band(x, y + 1)) {
                data[row * pw + x] = 0;
            }
        }
    }
    Image8::gray(pw as u32, ph as u32, data)
}

#[test]
fn plate_flux_follows_the_inner_conductivity() {
    let m = plate();
    let fixed: Vec<(usize, Real)> = (0..=W).flat_map(|i| [(i, 0.0), (H * (W + 1) + i, 1.0)]).collect();
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let mut results = Vec::new();
    for ratio in [1.0, 0.0, 1e-3, 1e3] {
        let c: Vec<Real> = (0..m.faces.len()).map(|f| if inner(&m, f) { ratio } else { 1.0 }).collect();
        let u = harmonic_field(&m, Some(&c), &fixed).unwrap();
        let g = face_gradients(&m, &u);
        // Flux through the inner square: mean of c·|∇u| over its faces (all faces have equal area);
        // the field's steepness inside: mean |∇u|.
        let faces: Vec<usize> = (0..m.faces.len()).filter(|&f| inner(&m, f)).collect();
        let flux = faces.iter().map(|&f| c[f] * g[f].norm()).sum::<Real>() / faces.len() as Real;
        let steep = faces.iter().map(|&f| g[f].norm()).sum::<Real>() / faces.len() as Real;
        // Total current from bottom to top: the flux through the middle row of faces.
        let total = (0..m.faces.len())
            .filter(|&f| {
                let y = m.faces[f].iter().map(|&v| m.vertices[v as usize].y).sum::<Real>() / 3.0;
                (y - 5.5).abs() < 0.5
            })
            .map(|f| c[f] * g[f].y * 0.5)
            .sum::<Real>();
        // Current entering the square from below: ∂u/∂y on the row of faces just under its bottom edge.
        let under: Vec<usize> = (0..m.faces.len())
            .filter(|&f| {
                let (x, y) = m.faces[f].iter().fold((0.0, 0.0), |(x, y), &v| {
                    (x + m.vertices[v as usize].x / 3.0, y + m.vertices[v as usize].y / 3.0)
                });
                (21.0..39.0).contains(&x) && (12.0..13.0).contains(&y)
            })
            .collect();
        let entering = under.iter().map(|&f| g[f].y).sum::<Real>() / under.len() as Real;
        let path = out.join(format!("plate_conductivity_{ratio}.png"));
        rig::image::write_png(&path, &contour_image(&u), false).unwrap();
        eprintln!(
            "ratio {ratio:>6}: flux through the inner square {flux:.3e}, |∇u| inside {steep:.4}, ∂u/∂y under it {entering:.2e}, current through the plate {total:.4}; {}",
            path.display()
        );
        assert!(path.is_file());
        results.push((ratio, flux, steep, total, entering));
    }
    let (_, flux1, steep1, total1, entering1) = results[0];
    // Homogeneous: a uniform field of slope 1/H everywhere and a current W/H.
    assert!((steep1 - 1.0 / H as Real).abs() < 1e-9 && (total1 - W as Real / H as Real).abs() < 1e-6);
    let (_, flux0, _, total0, entering0) = results[1];
    assert!(flux0 < 1e-6 * flux1, "an insulator passes {flux0}");
    // No current crosses into an insulator: the contours meet its edge at right angles (measured 0.08 ×
    // the homogeneous slope half a cell away, the linear elements' O(h) there).
    assert!(entering0.abs() < 0.1 * entering1, "∂u/∂y under the insulator {entering0} vs {entering1}");
    assert!(total0 < total1, "an insulating block must lower the current");
    let (_, flux_low, _, _, _) = results[2];
    assert!(flux_low < 0.01 * flux1, "conductivity 1e-3 passes {flux_low}");
    let (_, flux_high, steep_high, total_high, _) = results[3];
    // A good conductor draws current in (more flux than the same square in a homogeneous plate) while
    // its own field flattens: the contours avoid it.
    assert!(flux_high > 1.5 * flux1 && steep_high < 0.01 * steep1, "flux {flux_high}, |∇u| {steep_high}");
    assert!(total_high > total1);
}
