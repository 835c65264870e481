"""Every function given arguments of the wrong kind — wrong shapes, dtypes, orders, types, sizes —
answers with a Python exception naming what is wrong, never a crash of the interpreter: a property
test over a fixed, seeded sample of bad arguments in every position."""

import itertools
import random

import numpy as np
import pytest

import scanrig

GOOD3 = np.random.default_rng(0).normal(size=(64, 3))
BAD = [
    None,
    "points.ply",
    3,
    [[0.0, 1.0, 2.0]],
    np.zeros((64, 2)),
    np.zeros((64, 3), dtype=np.float32),
    np.zeros((64, 3), dtype=np.int64),
    np.zeros((0, 3)),
    np.zeros((4, 4, 3)),
    np.full((64, 3), np.nan),
    np.asfortranarray(np.zeros((3, 64))).T,
    GOOD3[::2],
    np.zeros((8, 8), dtype=np.uint8),
    [np.zeros((8, 8), dtype=np.uint8)] * 3,
    {"points": np.zeros((4, 4, 3))},
    [{"points": np.zeros((4, 4, 3), dtype=np.float32)}],
]
GRID = {"points": np.random.default_rng(1).normal(size=(6, 6, 3)) + [0, 0, 100]}

# (function, a valid call's positional arguments, keyword arguments)
CALLS = [
    (scanrig.fuse, [GOOD3], {}),
    (scanrig.reconstruct, [GOOD3, GOOD3], {"depth": 4}),
    (scanrig.remesh, [GOOD3, np.array([[0, 1, 2]])], {}),
    (scanrig.icp, [GOOD3, GOOD3, GOOD3, GOOD3], {"max_iterations": 1}),
    (scanrig.align, [GOOD3, GOOD3], {}),
    (scanrig.denoise, [GRID], {}),
    (scanrig.decode, [[np.zeros((8, 8), dtype=np.uint8)] * 42], {"projector": (1024, 768)}),
    (scanrig.triangulate, [np.zeros((8, 8, 3)), "no-such-rig.toml"], {}),
    (scanrig.laser_line, [np.zeros((8, 8), dtype=np.uint8), "no-such-rig.toml"], {}),
    (scanrig.register, [[GRID, GRID], [0.0, 90.0], "no-such-rig.toml"], {}),
    (scanrig.write_cloud, ["/nonexistent/dir/x.ply", GOOD3], {}),
    (scanrig.write_mesh, ["/nonexistent/dir/x.ply", GOOD3, np.array([[0, 1, 2]])], {}),
    (scanrig.write_image, ["/nonexistent/dir/x.png", np.zeros((8, 8), dtype=np.uint8)], {}),
    (scanrig.write_range_grid, ["/nonexistent/dir/x.ply", GRID], {}),
]
EXPECTED = (TypeError, ValueError, OverflowError, scanrig.ScanrigError)


@pytest.mark.parametrize("fn,args,kwargs", CALLS, ids=[c[0].__name__ for c in CALLS])
def test_bad_arguments_raise_exceptions_that_name_them(fn, args, kwargs, tmp_path, monkeypatch):
    # A string in a path's place is a path: whatever gets written lands in a scratch folder.
    monkeypatch.chdir(tmp_path)
    rng = random.Random(fn.__name__)
    cases = [(i, b) for i, b in itertools.product(range(len(args)), BAD)]
    # Pairs of positions too, sampled: two wrong arguments at once.
    pairs = [((i, a), (j, b)) for (i, a), (j, b) in itertools.combinations(cases, 2) if i != j]
    cases = [[c] for c in cases] + [list(p) for p in rng.sample(pairs, min(60, len(pairs)))]
    for changes in cases:
        call = list(args)
        for i, value in changes:
            call[i] = value
        try:
            fn(*call, **kwargs)
        except EXPECTED as e:
            assert str(e), f"{fn.__name__}: an exception without a message for {changes}"
        except BaseException as e:  # noqa: BLE001 - anything else is the finding
            pytest.fail(f"{fn.__name__} with {changes}: {type(e).__name__}: {e}")


def test_the_mesh_keywords_are_checked_by_name():
    pts = np.random.default_rng(2).normal(size=(400, 3))
    with pytest.raises(ValueError, match="base"):
        scanrig.reconstruct(pts, pts, depth=5, base="poisson")
    with pytest.raises(scanrig.ScanrigError, match="trim"):
        scanrig.reconstruct(pts, pts, depth=5, trim=-1.0)
    for name in ("platter_z", "top_z"):
        with pytest.raises(scanrig.ScanrigError, match=name):
            scanrig.reconstruct(pts, pts, depth=5, **{name: float("nan")})
    for bad in (-1.0, float("nan"), 1e9):
        # Said as this function spells it (`samples_per_cell=-1`), not as the command line does.
        with pytest.raises(scanrig.ScanrigError, match="samples_per_cell") as refused:
            scanrig.reconstruct(pts, pts, method="adfft", depth=6, samples_per_cell=bad)
        assert "--" not in str(refused.value), refused.value
        if bad == -1.0:
            assert "samples_per_cell=-1:" in str(refused.value), refused.value
    with pytest.raises(ValueError, match="samples_per_cell adapts AdFFT"):
        scanrig.reconstruct(pts, pts, depth=5, samples_per_cell=1.0)


def test_messages_name_the_argument_and_what_was_given():
    with pytest.raises(TypeError, match=r"points: expected a 2-D numpy array of float64 .* float32"):
        scanrig.fuse(np.zeros((64, 3), dtype=np.float32))
    with pytest.raises(ValueError, match=r"points: expected N×3 .* 64×2"):
        scanrig.fuse(np.zeros((64, 2)))
    with pytest.raises(ValueError, match=r"normals: 32 rows, but points has 64"):
        scanrig.reconstruct(GOOD3, GOOD3[:32])
    with pytest.raises(ValueError, match=r"map: expected H×W×3"):
        scanrig.triangulate(np.zeros((8, 8, 2)), "rig.toml")
    with pytest.raises(scanrig.FileError, match="no-such-rig.toml"):
        scanrig.triangulate(np.zeros((8, 8, 3)), "no-such-rig.toml")
