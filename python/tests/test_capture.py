"""Frames to range grids, the simulator and the calibrations from Python: against the simulator's
truth, and against the command line on the same inputs."""

import json
import tomllib

import numpy as np
import pytest

import scanrig

from helpers import run

PROJECTOR = (1024, 768)  # the built-in structured-light rig's projector


@pytest.fixture(scope="module")
def view():
    """One noiseless view of the built-in vase at 320×256, with its truth."""
    return scanrig.simulate_view(0.0, resolution=(320, 256), noiseless=True)


def test_a_simulated_view_decodes_and_triangulates_onto_its_truth(view, tmp_path):
    frames, truth = view["frames"], view["truth"]
    assert all(f.shape[:2] == (256, 320) and f.dtype == np.uint8 for f in frames)
    # Grey pattern frames; the colour texture frame last, H×W×3.
    assert view["patterns"][-1]["kind"] == "texture" and frames[-1].shape == (256, 320, 3)
    assert len(frames) == len(view["patterns"])
    pmap, report = scanrig.decode(frames, projector=PROJECTOR, patterns=view["patterns"])
    assert pmap.shape == (256, 320, 3)
    lit = np.isfinite(truth["projector"][..., 0])
    decoded = np.isfinite(pmap[..., 0])
    assert report["decoded"] == int(decoded.sum()) and decoded.sum() > 0.9 * lit.sum()
    # The decoder's columns against the projector pixel geometry says lit each camera pixel.
    both = decoded & lit
    du = np.abs(pmap[..., 0][both] - truth["projector"][..., 0][both])
    assert np.median(du) < 0.1, f"median column error {np.median(du)} px"
    rig = tmp_path / "rig.toml"
    rig.write_text(view["rig"])
    grid, tri = scanrig.triangulate(pmap, rig)
    pts = grid["points"]
    ok = np.isfinite(pts[..., 0]) & np.isfinite(truth["points"][..., 0])
    err = np.linalg.norm(pts[ok] - truth["points"][ok], axis=1)
    assert tri["points"] == int(np.isfinite(pts[..., 0]).sum())
    # The rig is exact and the view noiseless: what is left is the decoder's sub-pixel error.
    assert ok.sum() > 10_000 and np.median(err) < 0.05, f"median {np.median(err)} mm over {ok.sum()} points"


def test_decode_and_triangulate_equal_the_cli_on_opencv_order_frames(view, tmp_path):
    # Re-file the Gray-code frames as OpenCV's GrayCodePattern captures them: pairs, white, black.
    kinds = [p["kind"] for p in view["patterns"]]
    order = [i for i, k in enumerate(kinds) if k == "gray"] + [kinds.index("white"), kinds.index("black")]
    folder = tmp_path / "opencv"
    folder.mkdir()
    frames = [view["frames"][i] for i in order]
    for k, f in enumerate(frames):
        scanrig.write_image(folder / f"pattern_{k:02}.png", f)
    ours, _ = scanrig.decode([scanrig.read_image(folder / f"pattern_{k:02}.png") for k in range(len(frames))], projector=PROJECTOR)
    run("decode", folder, "--projector", "x".join(map(str, PROJECTOR)), "--out", tmp_path / "map.npy")
    assert np.array_equal(ours, np.load(tmp_path / "map.npy"), equal_nan=True)
    rig = tmp_path / "rig.toml"
    rig.write_text(view["rig"])
    grid, _ = scanrig.triangulate(ours, rig)
    run("decode", folder, "--rig", rig, "--out", tmp_path / "grid.ply")
    theirs = scanrig.read_range_grid(tmp_path / "grid.ply")["points"]
    valid = np.isfinite(grid["points"][..., 0])
    assert np.array_equal(valid, np.isfinite(theirs[..., 0]))
    # The file holds float32 millimetres.
    assert np.abs(grid["points"][valid] - theirs[valid]).max() < 1e-3
    # A frame too few is refused, saying what OpenCV's order needs.
    with pytest.raises(ValueError, match="frames: 41 images, but the patterns name 42"):
        scanrig.decode(frames[:-1], projector=PROJECTOR)
    with pytest.raises(TypeError, match=r"frames\[3\]: expected a numpy array of uint8"):
        scanrig.decode(frames[:3] + [frames[3].astype(np.float32)] + frames[4:], projector=PROJECTOR)


def test_simulate_scan_writes_the_frames_the_cli_writes(tmp_path):
    report = scanrig.simulate_scan(tmp_path / "py", views=2, resolution=(160, 128))
    run("sim", "--views", "2", "--resolution", "160x128", "--out", tmp_path / "cli")
    assert report["views"] == 2
    manifest = json.loads((tmp_path / "cli/scan.json").read_text())
    files = [f["file"] for v in manifest["views"] for f in v["frames"]]
    assert len(files) > 40
    for f in files:
        assert (tmp_path / "py" / f).read_bytes() == (tmp_path / "cli" / f).read_bytes(), f


def test_register_equals_the_cli_and_keeps_the_exact_turntable_poses(tmp_path):
    scan = tmp_path / "scan"
    run("sim", "--views", "6", "--resolution", "320x256", "--out", scan)
    run("process", scan, "--until", "denoise")
    run("register", scan)
    manifest = json.loads((scan / "scan.json").read_text())
    grids, angles = [], []
    for v, view in enumerate(manifest["views"]):
        grids.append(scanrig.read_range_grid(scan / f"processed/denoised/view_{v:03}.ply"))
        angles.append(view["angle_deg"])
    cloud, poses, report = scanrig.register(grids, angles, scan / "rig.toml")
    theirs = scanrig.read_cloud(scan / "processed/registered.ply")
    assert cloud["points"].shape == theirs["points"].shape
    assert np.abs(cloud["points"] - theirs["points"]).max() < 1e-3
    # The simulated turntable is exact: registration has almost nothing to correct.
    assert report["views"] == 6 and report["max_rotation_change_deg"] < 0.05 and report["max_shift_mm"] < 0.05
    assert len(poses) == 6 and np.array(poses[0]["object_from_camera"]).shape == (4, 4)
    with pytest.raises(ValueError, match="angles_deg: 5 angles for 6 grids"):
        scanrig.register(grids, angles[:5], scan / "rig.toml")


def test_calibrate_camera_equals_the_cli_and_finds_the_true_lens(tmp_path):
    caps = tmp_path / "caps"
    run("sim", "--board", "9x6", "--square", "11", "--resolution", "640x512", "--poses", "6", "--no-truth", "--out", caps)
    exact = tomllib.loads((caps / "rig.toml").read_text())["camera"]
    text, report = scanrig.calibrate_camera(caps, square=11)
    run("calibrate", "camera", caps, "-o", tmp_path / "cli.toml", "--square", "11")
    ours, theirs = tomllib.loads(text)["camera"], tomllib.loads((tmp_path / "cli.toml").read_text())["camera"]
    assert ours == theirs
    fx, true_fx = ours["fx_px"], exact["fx_px"]
    assert abs(fx - true_fx) / true_fx < 0.005, (fx, true_fx)
    assert report["camera"]["rms_px"] < 0.5
    with pytest.raises(ValueError, match="square must be a positive length"):
        scanrig.calibrate_camera(caps, square=0)
    # The lens model the views support is reported (issue 39), and a model no one has is refused.
    assert report["camera"]["model"]["estimated"][:2] == ["k1", "k2"]
    with pytest.raises(ValueError, match="lens_model"):
        scanrig.calibrate_camera(caps, square=11, lens_model="fancy")
    # A ChArUco board's description goes through the command line's parser.
    with pytest.raises(ValueError, match="board: .*dict=4x4_5"):
        scanrig.calibrate_camera(caps, board="charuco:11x9:square=10:marker=7:dict=4x4_5")


def test_a_charuco_board_calibrates_as_the_cli_does(tmp_path):
    caps = tmp_path / "caps"
    board = "charuco:11x9:square=12:marker=9:dict=4x4_50"
    run("sim", "--config", "laser", "--board", board, "--poses", "6", "--no-truth", "--out", caps)
    exact = tomllib.loads((caps / "rig.toml").read_text())["camera"]
    text, report = scanrig.calibrate_camera(caps, board=board)
    run("calibrate", "camera", caps, "-o", tmp_path / "cli.toml", "--board", board)
    ours, theirs = tomllib.loads(text)["camera"], tomllib.loads((tmp_path / "cli.toml").read_text())["camera"]
    assert ours == theirs
    assert abs(ours["fx_px"] - exact["fx_px"]) / exact["fx_px"] < 0.005, (ours, exact)
    assert report["board"]["charuco"].startswith("markers 9 mm")


def test_calibrate_rig_equals_the_cli_and_finds_the_true_projector(tmp_path):
    caps = tmp_path / "caps"
    run("sim", "--board", "9x6", "--square", "11", "--resolution", "640x512", "--poses", "5", "--no-truth", "--out", caps)
    exact = tomllib.loads((caps / "rig.toml").read_text())["projector"]
    text, report = scanrig.calibrate_rig(caps, square=11, projector=PROJECTOR, out=tmp_path / "py.toml")
    run("calibrate", "all", caps, "-o", tmp_path / "cli.toml", "--square", "11", "--projector", "1024x768")
    ours, theirs = tomllib.loads(text), tomllib.loads((tmp_path / "cli.toml").read_text())
    assert (ours["camera"], ours["projector"]) == (theirs["camera"], theirs["projector"])
    assert (tmp_path / "py.toml").read_text() == text and report["rig"] == str(tmp_path / "py.toml")
    shift = np.subtract(ours["projector"]["translation_mm"], exact["translation_mm"])
    assert np.linalg.norm(shift) < 0.02 * np.linalg.norm(exact["translation_mm"]), shift
