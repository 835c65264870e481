//! Issue 40, global registration: the Stanford bunny's overlapping scan pairs, each moving scan put
//! in a random pose (any rotation, up to ±100 mm a side), aligned with no pose to start from and
//! judged against `bun.conf`; and shapes that cannot be aligned (a sphere, a cylinder) refused.

use process::register::global::{GlobalParams, align_global};
use rig::math::{Point3, Real};

#[test]
fn bunny_pairs_align_from_any_pose_and_say_when_they_do_not() {
    let Some(poses) = fixtures::bunny_poses_mm() else {
        eprintln!("SKIPPED: ../shared/data/stanford-bunny is absent");
        return;
    };
    let params = GlobalParams::default();
    let (mut ok, mut wrong_but_aligned, mut tries) = (0, Vec::new(), 0);
    let mut angles = Vec::new();
    let mut rng = fixtures::Rng::new(0x91_0b41);
    for (moving, fixed) in fixtures::BUNNY_PAIRS {
        let (Some((m, _)), Some((f, _))) = (fixtures::bunny_scan_mm(moving), fixtures::bunny_scan_mm(fixed)) else {
            eprintln!("SKIPPED: a bunny scan is absent");
            return;
        };
        // One start a pair here; the bench (`cargo bench -p process --bench global`) runs ten.
        for _ in 0..1 {
            tries += 1;
            let start = fixtures::random_pose(&mut rng);
            let moved: Vec<Point3> = m.iter().map(|p| start * p).collect();
            // The truth: moved → moving's frame → world → fixed's frame.
            let truth = poses[fixed].inverse() * poses[moving] * start.inverse();
            let t0 = std::time::Instant::now();
            let a = align_global(&moved, &f, &params).unwrap();
            let (angle, rms) = fixtures::pose_error(&a.pose, &truth, &moved);
            let good = angle < 2.0 && rms < 2.0;
            eprintln!(
                "{moving} → {fixed}: {} ({}) {angle:.2}° {rms:.2} mm; {} matches, {} agree, overlap {:.2}, rival {:.2}, \
                 scale {:.4}, {} triples, {:.2} s",
                if good { "right" } else { "WRONG" },
                if a.aligned { "aligned" } else { a.why.as_str() },
                a.matches,
                a.inliers,
                a.overlap,
                a.rival_share,
                a.scale,
                a.iterations,
                t0.elapsed().as_secs_f64()
            );
            if good {
                ok += 1;
                angles.push(angle);
                // Real scans of one object are never mirror images of each other, nor at two scales.
                assert!(
                    !a.why.contains("mirror image") && !a.why.contains("differ in scale"),
                    "{moving} → {fixed}: {}",
                    a.why
                );
            } else if a.aligned {
                wrong_but_aligned.push(format!("{moving} → {fixed}: {angle:.1}°, {rms:.1} mm"));
            }
        }
    }
    angles.sort_by(Real::total_cmp);
    eprintln!(
        "{ok} of {tries} aligned right; median rotation error {:.3}°",
        angles.get(angles.len() / 2).copied().unwrap_or(Real::NAN)
    );
    assert!(wrong_but_aligned.is_empty(), "wrong alignments called aligned: {wrong_but_aligned:?}");
    assert!(ok + 1 >= tries, "only {ok} of {tries} aligned");
}

#[test]
fn a_sphere_and_a_cylinder_are_refused_as_ambiguous() {
    let mut rng = fixtures::Rng::new(7);
    let sphere: Vec<Point3> = (0..6000).map(|_| Point3::from(rng.direction() * 50.0)).collect();
    let cylinder: Vec<Point3> = (0..6000)
        .map(|_| {
            let a = rng.uniform() * std::f64::consts::TAU;
            Point3::new(30.0 * a.cos(), 30.0 * a.sin(), 120.0 * rng.uniform())
        })
        .collect();
    for (name, shape) in [("sphere", sphere), ("cylinder", cylinder)] {
        let start = fixtures::random_pose(&mut rng);
        let moved: Vec<Point3> = shape.iter().map(|p| start * p).collect();
        let a = align_global(&moved, &shape, &GlobalParams::default()).unwrap();
        eprintln!("{name}: aligned {} ({}), overlap {:.2}, rival {:.2}", a.aligned, a.why, a.overlap, a.rival_share);
        assert!(!a.aligned, "{name} called aligned: {a:?}");
    }
}

#[test]
fn two_unrelated_objects_are_not_called_aligned() {
    let Some((bunny, _)) = fixtures::bunny_scan_mm("bun000") else {
        eprintln!("SKIPPED: ../shared/data/stanford-bunny is absent");
        return;
    };
    // The simulator's fluted vase, as tall as the bunny scan is wide, against the bunny.
    let vase = sim::fluted_vase(150.0).vertices;
    let mut rng = fixtures::Rng::new(11);
    {
        let start = fixtures::random_pose(&mut rng);
        let moved: Vec<Point3> = vase.iter().map(|p| start * p).collect();
        let a = align_global(&moved, &bunny, &GlobalParams::default()).unwrap();
        eprintln!(
            "vase → bunny: aligned {} ({}), overlap {:.2}, {} of {} agree",
            a.aligned, a.why, a.overlap, a.inliers, a.matches
        );
        assert!(!a.aligned, "a vase called aligned onto a bunny: {a:?}");
    }
}

/// Found by a hostile user's probe (2026-12-07): a scan written with one axis flipped (a mirror image,
/// which no rotation turns right) was called aligned, 79 % of it landing within two spacings at 2.4
/// times the RMS of the true fit, 14.5 mm off at its 90th percentile. Mirrored back it fits far
/// better, which is now said; the same scan turned, not mirrored, aligns as before.
#[test]
fn a_mirror_image_is_not_called_aligned() {
    let Some((bunny, _)) = fixtures::bunny_scan_mm("bun000") else {
        eprintln!("SKIPPED: ../shared/data/stanford-bunny is absent");
        return;
    };
    let mut rng = fixtures::Rng::new(23);
    let start = fixtures::random_pose(&mut rng);
    let turned: Vec<Point3> = bunny.iter().map(|p| start * p).collect();
    let mirrored: Vec<Point3> = bunny.iter().map(|p| start * Point3::new(p.x, -p.y, p.z)).collect();
    let params = GlobalParams::default();
    let right = align_global(&turned, &bunny, &params).unwrap();
    assert!(right.aligned, "{right:?}");
    let a = align_global(&mirrored, &bunny, &params).unwrap();
    eprintln!("mirrored bun000: aligned {} ({}), overlap {:.2}, rms {:.3}", a.aligned, a.why, a.overlap, a.rms);
    assert!(!a.aligned && a.why.contains("mirror image"), "{a:?}");
}

/// Found by a hostile user's probe (2026-12-07): the bunny at 1.05 times its size (a file in another
/// unit's fraction, a scanner calibrated apart) landed 81 % of itself and was called aligned, 4.8 mm
/// off at its median; at 1.2 times, 37 %. Distances between matched points say the scale: 1 for the
/// scan turned, and the copies are refused, saying so.
#[test]
fn a_copy_at_another_scale_is_not_called_aligned() {
    let Some((bunny, _)) = fixtures::bunny_scan_mm("bun000") else {
        eprintln!("SKIPPED: ../shared/data/stanford-bunny is absent");
        return;
    };
    let mut rng = fixtures::Rng::new(29);
    let start = fixtures::random_pose(&mut rng);
    let params = GlobalParams::default();
    for k in [1.0, 1.05, 1.2] {
        let scaled: Vec<Point3> = bunny.iter().map(|p| start * Point3::from(p.coords * k)).collect();
        let a = align_global(&scaled, &bunny, &params).unwrap();
        eprintln!("bun000 × {k}: aligned {} ({}), scale {:.4}, overlap {:.2}", a.aligned, a.why, a.scale, a.overlap);
        if k == 1.0 {
            assert!(a.aligned && (a.scale - 1.0).abs() < 0.005, "{a:?}");
        } else {
            assert!(!a.aligned && a.why.contains("differ in scale"), "{k}: {a:?}");
        }
    }
}
