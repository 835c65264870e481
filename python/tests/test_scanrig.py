"""The Python bindings against ground truth and against the command line on the same inputs.

Real data from ../shared/data (the Stanford bunny, fandisk); a simulated scan from `scanrig sim`.
The CLI binary is SCANRIG_CLI, else target/debug/scanrig or target/release/scanrig beside this
checkout; tests that need it or the data skip, saying so.
"""

import json

import numpy as np
import pytest

import scanrig

from helpers import BUNNY, DATA, need, run


@pytest.fixture(scope="module")
def bunny_fused(tmp_path_factory):
    """The bunny's zippered vertices fused by the bindings (points with normals)."""
    src = need(BUNNY / "reconstruction/bun_zipper_res2.ply")
    cloud = scanrig.read_cloud(src)
    # Everything the file holds, as the CLI reads it: the zippered bunny has confidences.
    fused, kept, report = scanrig.fuse(cloud["points"], cloud["normals"], cloud["colors"], cloud["confidence"])
    return fused, kept, report


def test_clouds_and_meshes_round_trip_through_files(tmp_path):
    mesh = scanrig.read_mesh(need(BUNNY / "reconstruction/bun_zipper.ply"))
    # bun_zipper.ply: 35947 vertices, 69451 triangles (its header).
    assert mesh["vertices"].shape == (35947, 3) and mesh["vertices"].dtype == np.float64
    assert mesh["triangles"].shape == (69451, 3)
    for ext in ["ply", "obj", "stl", "glb"]:
        out = tmp_path / f"bunny.{ext}"
        scanrig.write_mesh(out, mesh["vertices"], mesh["triangles"])
        back = scanrig.read_mesh(out)
        assert back["triangles"].shape[0] == 69451, ext
        # Written as float32: within its rounding of the bunny's 0.1 m extent.
        bb = lambda v: (v.min(axis=0), v.max(axis=0))
        assert np.allclose(bb(back["vertices"])[0], bb(mesh["vertices"])[0], atol=1e-6), ext
    cloud = scanrig.read_cloud(need(BUNNY / "data/bun000.ply"))
    colours = (np.arange(len(cloud["points"]) * 3) % 256).astype(np.uint8).reshape(-1, 3)
    scanrig.write_cloud(tmp_path / "c.ply", cloud["points"], colors=colours)
    back = scanrig.read_cloud(tmp_path / "c.ply")
    assert np.array_equal(back["colors"], colours)
    assert np.allclose(back["points"], cloud["points"], atol=1e-6)


def test_a_cloud_in_metres_keeps_its_unit_through_every_writer(tmp_path):
    # The Stanford scans are in metres (their Cyberware header says so). Before, read_cloud gave no
    # unit and the writers took millimetres: the E57 and glTF other tools open held a 0.16 mm bunny,
    # and a PLY written back lost the unit.
    cloud = scanrig.read_cloud(need(BUNNY / "data/bun000.ply"))
    assert cloud["units"] == "m"
    p = cloud["points"]
    scanrig.write_cloud(tmp_path / "c.ply", p, units=cloud["units"])
    back = scanrig.read_cloud(tmp_path / "c.ply")
    assert back["units"] == "m" and np.allclose(back["points"], p, atol=1e-6)
    scanrig.write_cloud(tmp_path / "c.obj", p, units=cloud["units"])
    assert scanrig.read_cloud(tmp_path / "c.obj")["units"] == "m"
    for ext in ["e57", "glb"]:
        scanrig.write_cloud(tmp_path / f"c.{ext}", p, units=cloud["units"])
        back = scanrig.read_cloud(tmp_path / f"c.{ext}")
        # Read back in millimetres, as every E57 and glTF is: the bunny 156 mm wide, not 0.156.
        assert back["units"] == "mm", ext
        assert np.allclose(back["points"], 1000.0 * p, atol=1e-3), ext
        assert 150.0 < np.ptp(back["points"][:, 0]) < 160.0, ext
    mesh = scanrig.read_mesh(need(BUNNY / "reconstruction/bun_zipper_res2.ply"))
    scanrig.write_mesh(tmp_path / "m.stl", mesh["vertices"], mesh["triangles"], units="m")
    back = scanrig.read_mesh(tmp_path / "m.stl")
    # STL welds its corners again on reading: the box, not the vertex list, is compared.
    box = lambda v: np.concatenate([v.min(axis=0), v.max(axis=0)])
    assert back["units"] is None and np.allclose(box(back["vertices"]), 1000.0 * box(mesh["vertices"]), atol=1e-3)
    grid = scanrig.read_range_grid(need(BUNNY / "data/bun000.ply"))
    assert grid["units"] == "m"
    scanrig.write_range_grid(tmp_path / "g.ply", grid)
    assert scanrig.read_range_grid(tmp_path / "g.ply")["units"] == "m"
    # A unit scanrig cannot convert is kept in PLY and OBJ, as said (the command line keeps it too),
    # and refused by name for the formats that convert, before anything is written; what is not a
    # unit's name at all is refused for every format.
    scanrig.write_cloud(tmp_path / "ft.ply", p, units="ft")
    assert scanrig.read_cloud(tmp_path / "ft.ply")["units"] == "ft"
    with pytest.raises(scanrig.FileError, match="ft"):
        scanrig.write_cloud(tmp_path / "ft.e57", p, units="ft")
    assert not (tmp_path / "ft.e57").exists()
    for bad, error in [("two words", ValueError), ("", ValueError), (3, TypeError)]:
        with pytest.raises(error, match="units"):
            scanrig.write_cloud(tmp_path / "bad.ply", p, units=bad)
        assert not (tmp_path / "bad.ply").exists()
        with pytest.raises(error, match="units"):
            scanrig.write_range_grid(tmp_path / "bad.ply", {**grid, "units": bad})


def test_what_a_format_cannot_hold_is_a_python_warning_naming_the_file(tmp_path):
    # As `scanrig convert` says it: quads written to STL become triangles, OBJ has no confidence.
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    with pytest.warns(UserWarning, match=r"q.stl: its faces of four or more corners \(1\)"):
        scanrig.write_mesh(tmp_path / "q.stl", v, np.array([[0, 1, 2, 3]]))
    with pytest.warns(UserWarning, match="c.obj: the points' confidence"):
        scanrig.write_cloud(tmp_path / "c.obj", v, confidence=np.ones(4, dtype=np.float32))
    assert scanrig.read_mesh(tmp_path / "q.stl")["triangles"].shape == (2, 3)


def test_what_a_reader_cannot_keep_is_a_python_warning_naming_the_file(tmp_path):
    # Two vertices with colours, one without: the colours cannot be kept per vertex.
    obj = tmp_path / "partly-coloured.obj"
    obj.write_text("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.warns(UserWarning, match="partly-coloured.obj: its vertex colours are not kept: 2 of 3"):
        mesh = scanrig.read_mesh(obj)
    assert mesh["vertices"].shape == (3, 3) and mesh["colors"] is None
    with pytest.warns(UserWarning, match="partly-coloured.obj"):
        cloud = scanrig.read_cloud(obj)
    assert cloud["points"].shape == (3, 3)


def test_fuse_equals_the_cli(tmp_path, bunny_fused):
    fused, kept, report = bunny_fused
    src = BUNNY / "reconstruction/bun_zipper_res2.ply"
    run("fuse", src, "-o", tmp_path / "f.ply")
    theirs = scanrig.read_cloud(tmp_path / "f.ply")
    assert report["points_out"] == len(fused["points"]) == len(theirs["points"])
    assert kept.dtype == np.bool_ and kept.sum() <= len(kept)
    # The CLI's file holds float32: the same points to its rounding.
    assert np.abs(fused["points"] - theirs["points"]).max() < 1e-6
    assert fused["normals"].shape == fused["points"].shape


def test_reconstruct_equals_the_cli_and_is_near_the_zippered_surface(tmp_path, bunny_fused):
    fused, _, _ = bunny_fused
    # The coarse bunny fused without normals: the spanning tree turns an ear's thin tip the wrong way
    # and the global FFT loses it, leaving out 2.6 % of the samples, up to 45 mm off. Both the
    # function and the command line refuse it unless forced, and then say so.
    with pytest.raises(scanrig.StageError, match="leaves out .* of the cloud's samples.*force=True"):
        scanrig.reconstruct(fused["points"], fused["normals"], depth=7)
    with pytest.warns(UserWarning, match="leaves out"):
        v, f, report = scanrig.reconstruct(fused["points"], fused["normals"], depth=7, force=True)
    assert report["method"] == "fft" and report["n"] == 128
    scanrig.write_cloud(tmp_path / "in.ply", fused["points"], fused["normals"])
    run("reconstruct", tmp_path / "in.ply", "-o", tmp_path / "m.ply", "--depth", "7", "--force")
    theirs = scanrig.read_mesh(tmp_path / "m.ply")
    # The CLI reads the float32 file: the same mesh up to that rounding.
    assert abs(len(theirs["vertices"]) - len(v)) <= len(v) // 1000
    # Against the truth: every zippered-bunny vertex within two grid cells of the mesh's vertices.
    truth = scanrig.read_mesh(need(BUNNY / "reconstruction/bun_zipper.ply"))["vertices"]
    cell = report["cell"]
    sample = truth[:: max(1, len(truth) // 2000)]
    d = np.sqrt(((sample[:, None, :] - v[None, :: max(1, len(v) // 4000), :]) ** 2).sum(-1)).min(axis=1)
    assert np.median(d) < 2 * cell, (np.median(d), cell)
    # A refusal names this function's arguments where the command line's names its options.
    with pytest.raises(scanrig.StageError, match="over the") as refused:
        scanrig.reconstruct(fused["points"], fused["normals"], depth=9, memory_budget_gb=0.05)
    said = str(refused.value)
    assert "(memory_budget_gb)" in said and "lower depth" in said and "method='adfft'" in said, said
    assert "--" not in said, said


def test_remesh_equals_the_cli(tmp_path):
    src = need(DATA / "common-3d-test-models/fandisk.obj")
    mesh = scanrig.read_mesh(src)
    v, faces, report = scanrig.remesh(mesh["vertices"], mesh["triangles"])
    run("remesh", src, "-o", tmp_path / "q.obj")
    theirs = scanrig.read_mesh(tmp_path / "q.obj")
    assert len(faces) == len(theirs["faces"]), (len(faces), len(theirs["faces"]))
    assert report["streamlines"] > 0
    quads = sum(1 for f in faces if len(f) == 4) / len(faces)
    assert quads > 0.9, quads


def test_a_remesh_that_cannot_be_right_raises_unless_forced():
    # A ring whose tube (radius 0.4) is thinner than the default quads (1.43 apart): the remesh joins
    # the tube's sides in edges of three faces, which the ring has none of.
    around, across = 256, 12
    a = np.repeat(np.arange(around) * 2 * np.pi / around, across)
    b = np.tile(np.arange(across) * 2 * np.pi / across, around)
    r = 50 + 0.4 * np.cos(b)
    vertices = np.stack([r * np.cos(a), r * np.sin(a), 0.4 * np.sin(b)], axis=1)
    i, j = np.divmod(np.arange(around * across), across)
    v = lambda i, j: (i % around) * across + j % across  # noqa: E731
    faces = np.concatenate([np.stack([v(i, j), v(i + 1, j), v(i + 1, j + 1)], axis=1),
                            np.stack([v(i, j), v(i + 1, j + 1), v(i, j + 1)], axis=1)]).astype(np.int64)
    with pytest.raises(scanrig.StageError, match="three or more faces where the input has none") as refused:
        scanrig.remesh(vertices, faces)
    # The hint names this function's arguments, not the command line's options.
    said = str(refused.value)
    assert "give a smaller spacing" in said and "force=True keeps" in said and "--" not in said, said
    with pytest.warns(UserWarning, match=r"three or more faces.*\(force=True\)"):
        _, quads, report = scanrig.remesh(vertices, faces, force=True)
    assert len(quads) == report["quality"]["faces"] > 0
    _, _, fine = scanrig.remesh(vertices, faces, spacing=0.3)
    assert fine["quality"]["non_manifold_edges"] == 0


def test_icp_recovers_a_known_motion(bunny_fused):
    fused, _, _ = bunny_fused
    p, n = fused["points"], fused["normals"]
    angle = np.radians(2.0)
    r = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    t = np.array([0.002, -0.001, 0.001])
    moving = np.ascontiguousarray(p @ r.T + t)
    moving_n = np.ascontiguousarray(n @ r.T)
    pose, report = scanrig.icp(moving, moving_n, p, n)
    # The pose maps moving back onto the target: the inverse motion.
    back = moving @ pose[:3, :3].T + pose[:3, 3]
    assert np.abs(back - p).max() < 1e-4, (np.abs(back - p).max(), report)
    assert report["iterations"] >= 1


def test_align_finds_a_bunny_scan_from_any_pose_equal_to_the_cli_and_refuses_a_sphere(tmp_path):
    a, b = need(BUNNY / "data/bun045.ply"), need(BUNNY / "data/bun000.ply")
    moving, fixed = scanrig.read_cloud(a)["points"], scanrig.read_cloud(b)["points"]
    # The moving scan turned half a turn and moved: no pose to start from.
    turn = np.array([[-1.0, 0, 0], [0, 1, 0], [0, 0, -1]])
    moved = np.ascontiguousarray(moving @ turn.T + [0.05, -0.02, 0.1])
    pose, report = scanrig.align(moved, fixed)
    assert report["aligned"] and report["overlap"] > 0.5, report
    # Back where the file's own alignment puts it: the CLI on the unmoved files.
    r = run("align", a, b, "--json")
    expected = np.array(json.loads(r.stdout)["pose"])
    undone = pose @ np.block([[turn, np.array([[0.05], [-0.02], [0.1]])], [np.zeros((1, 3)), np.ones((1, 1))]])
    back, want = moving @ undone[:3, :3].T + undone[:3, 3], moving @ expected[:3, :3].T + expected[:3, 3]
    assert np.sqrt(((back - want) ** 2).sum(axis=1).mean()) < 5e-4, report
    # A sphere fits itself turned any way: refused, or returned with a warning when forced.
    rng = np.random.default_rng(3)
    sphere = rng.normal(size=(3000, 3))
    sphere = 50 * sphere / np.linalg.norm(sphere, axis=1, keepdims=True)
    with pytest.raises(scanrig.StageError, match="ambiguous"):
        scanrig.align(np.ascontiguousarray(sphere[:, [1, 0, 2]]), sphere)
    with pytest.warns(UserWarning, match="ambiguous"):
        scanrig.align(np.ascontiguousarray(sphere[:, [1, 0, 2]]), sphere, force=True)
    # One object in metres and in mm (arrays carry no unit): the failure names the sizes' ratio.
    with pytest.raises(scanrig.StageError, match="1000.0× apart in size"):
        scanrig.align(np.ascontiguousarray(sphere[:, [1, 0, 2]]) * 1e-3, sphere)
    with pytest.raises(ValueError, match="voxel=0"):
        scanrig.align(sphere, sphere, voxel=0.0)
    with pytest.raises(scanrig.ScanrigError, match="point 0 of the moving cloud is not finite"):
        scanrig.align(np.full((100, 3), np.nan), sphere)


def test_wrong_arrays_are_python_errors_never_crashes():
    good = np.zeros((10, 3))
    with pytest.raises(ValueError, match="points: expected N×3"):
        scanrig.fuse(np.zeros((10, 2)))
    with pytest.raises(TypeError, match="points: expected a 2-D numpy array of float64"):
        scanrig.fuse(np.zeros((10, 3), dtype=np.float32))
    with pytest.raises(TypeError, match="points"):
        scanrig.fuse([[0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="normals: 9 rows, but points has 10"):
        scanrig.reconstruct(good, np.zeros((9, 3)))
    with pytest.raises(ValueError, match="method must be"):
        scanrig.reconstruct(good, good, method="poisson")
    with pytest.raises(ValueError, match="faces: face 0 names vertex 10"):
        scanrig.write_mesh("/nonexistent/x.ply", good, np.array([[0, 1, 10]]))
    with pytest.raises(ValueError, match="--k 3: must be from 6"):
        scanrig.fuse(good, k=3)
    # A strided (Fortran-order) array is accepted, read as its values.
    fortran = np.asfortranarray(np.random.default_rng(1).normal(size=(200, 3)))
    fused, _, _ = scanrig.fuse(fortran)
    assert fused["points"].shape[1] == 3
    # The library's refusals are ScanrigErrors with its message.
    with pytest.raises(scanrig.StageError, match="points"):
        scanrig.fuse(np.zeros((3, 3)))
    with pytest.raises(scanrig.FileError, match="nothing-here.ply"):
        scanrig.read_cloud("/nothing-here.ply")
    with pytest.raises(scanrig.StageError, match="not finite|NaN|finite"):
        scanrig.reconstruct(np.full((100, 3), np.nan), np.ones((100, 3)))


def test_process_equals_the_cli_on_a_simulated_scan(tmp_path):
    scan = tmp_path / "scan"
    run("sim", "--views", "4", "--resolution", "160x128", "--out", scan)
    # To the mesh, which is compared; the quads are not (their remesh was most of the time).
    report = scanrig.process(scan, tmp_path / "py", until="reconstruct")
    run("process", scan, "-o", tmp_path / "cli", "--until", "reconstruct")
    assert [s["stage"] for s in report["stages"]][:2] == ["views", "merge"]
    for name in ["merged.ply", "fused.ply", "mesh.ply"]:
        ours, theirs = (tmp_path / "py" / name), (tmp_path / "cli" / name)
        if theirs.exists():
            assert ours.read_bytes() == theirs.read_bytes(), name


def test_the_laser_path_and_the_mesh_through_python_are_process_s_own(tmp_path):
    """Issue 38: Python's laser line and mesh call the stage functions `process` calls, so they give
    exactly what its files hold (float32 as written), from the same frames and the same cloud."""
    import json

    scan = tmp_path / "scan"
    run("sim", "--config", "laser", "--views", "12", "--resolution", "320x240", "--out", scan)
    processed = tmp_path / "cli"
    # To the mesh (the quads are not compared); forced: 12 views leave lines 30° apart, a mesh the
    # support check refuses unforced.
    # At depth 6: the comparison is of the same call's output, at any size (CI time).
    run("process", scan, "-o", processed, "--force", "--until", "reconstruct", "--depth", "6")
    rig = scan / "rig.toml"
    view = json.loads((scan / "scan.json").read_text())["views"][3]
    frames = {json.dumps(f["pattern"], sort_keys=True): scan / f["file"] for f in view["frames"]}
    image = lambda pattern: scanrig.read_image(frames[json.dumps(pattern, sort_keys=True)])  # noqa: E731
    for k in (0, 1):
        line, report = scanrig.laser_line(
            image({"kind": "laser", "index": k}),
            rig,
            laser=k,
            off=image({"kind": "laser_off"}),
            texture=image({"kind": "texture"}),
        )
        written = scanrig.read_cloud(processed / "views" / f"view_003_laser{k}.ply")
        assert report["points"] == len(written["points"]) > 50, report
        assert np.array_equal(line["points"].astype(np.float32), written["points"].astype(np.float32)), k
        assert np.array_equal(line["colors"], written["colors"]), k
    # The mesh: from the closed cloud, with the platter plane and the working volume's top process used.
    records = json.loads((processed / "stages.json").read_text())["outputs"]
    made_with = records["mesh.ply"]["fingerprint"]["params"]
    assert made_with["platter_z"] == 0.0 and made_with["top_z"] is not None, made_with
    closed = scanrig.read_cloud(processed / "closed.ply")
    # Two warnings, as process gave them: the coarse mesh is far from the cloud (forced), and it rose
    # past the working volume's top and was cut there.
    with pytest.warns(UserWarning) as said:
        v, f, report = scanrig.reconstruct(
            closed["points"], closed["normals"], depth=6, platter_z=0.0, top_z=made_with["top_z"], force=True
        )
    said = [str(w.message) for w in said]
    assert any("lies far from its cloud" in w for w in said), said
    assert any("above the working volume's top" in w for w in said), said
    mesh = scanrig.read_mesh(processed / "mesh.ply")
    assert np.array_equal(v.astype(np.float32), mesh["vertices"].astype(np.float32))
    assert np.array_equal(f, np.asarray(mesh["faces"]))
    assert report["finish"]["base"]["z"] == 0.0, report["finish"]


def test_the_views_ray_processes_are_those_every_command_reads_as_complete(tmp_path):
    import json

    from scanrig import _scanrig

    scan = tmp_path / "scan"
    run("sim", "--views", "3", "--resolution", "64x48", "--no-truth", "--out", scan)
    assert _scanrig._complete_views(str(scan)) == [0, 1, 2]
    manifest = json.loads((scan / "scan.json").read_text())
    # A scan stopped after view 0: views 1 and 2 incomplete; its journal then completes view 2.
    for v in manifest["views"][1:]:
        v["complete"] = False
    (scan / "scan.json").write_text(json.dumps(manifest))
    assert _scanrig._complete_views(str(scan)) == [0]
    (scan / "scan.progress").write_text("2\n")
    assert _scanrig._complete_views(str(scan)) == [0, 2]
    # A view that does not say whether it is complete is refused, not taken as complete.
    del manifest["views"][0]["complete"]
    (scan / "scan.json").write_text(json.dumps(manifest))
    with pytest.raises(Exception, match="scan.json"):
        _scanrig._complete_views(str(scan))


def test_contiguous_float64_is_read_in_place_and_strided_arrays_are_gathered():
    from scanrig import _scanrig

    # A 3 M-point cloud, C-ordered float64: read where it lies (fuse, reconstruct and icp hand these
    # rows to the library as they are; fusion's Morton-ordered working copy is made from them).
    big = np.random.default_rng(2).normal(size=(3_000_000, 3))
    assert _scanrig._read_address(big) == big.ctypes.data
    a = big[:3000].copy()
    f = np.asfortranarray(a)
    assert _scanrig._read_address(f) != f.ctypes.data
    # Read as its values, not its buffer: the same fused result as the C-ordered copy.
    c_fused, _, _ = scanrig.fuse(a)
    f_fused, _, _ = scanrig.fuse(f)
    assert np.array_equal(c_fused["points"], f_fused["points"])


def test_a_long_call_stops_at_ctrl_c(bunny_fused):
    import signal
    import time

    fused, _, _ = bunny_fused
    pts = np.ascontiguousarray(np.tile(fused["points"], (40, 1)) + np.repeat(np.arange(40), len(fused["points"]))[:, None] * 1e-5)

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.3)
        start = time.monotonic()
        with pytest.raises(KeyboardInterrupt):
            scanrig.fuse(pts, k=64)
        waited = time.monotonic() - start
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    # The fusion of 240 K points takes seconds; the call gave up within a poll of the signal.
    assert waited < 1.5, waited


def test_denoise_equals_the_cli_and_moves_the_scan_toward_the_surface(tmp_path):
    src = need(BUNNY / "data/bun000.ply")
    grid = scanrig.read_range_grid(src)
    h, w, three = grid["points"].shape
    assert three == 3 and np.isnan(grid["points"]).any(), "holes are NaN"
    clean, report = scanrig.denoise(grid)
    assert clean["points"].shape == grid["points"].shape
    run("denoise", src, "-o", tmp_path / "d.ply")
    theirs = scanrig.read_range_grid(tmp_path / "d.ply")
    valid = ~np.isnan(clean["points"][..., 0])
    assert np.array_equal(valid, ~np.isnan(theirs["points"][..., 0]))
    # The CLI's file holds float32 (metres: 1e-8 of rounding).
    assert np.abs(clean["points"][valid] - theirs["points"][valid]).max() < 1e-6
    assert report["points"] == int(valid.sum())
    # A sequence of one frame, temporal reaching past it, is refused by name.
    with pytest.raises(ValueError, match="temporal = 3 reaches past the 1 frames"):
        scanrig.denoise([grid], temporal=3)
    with pytest.raises(TypeError, match=r"frames\[0\]\[\"points\"\]"):
        scanrig.denoise([{"points": np.zeros((4, 4, 3), dtype=np.float32)}])
