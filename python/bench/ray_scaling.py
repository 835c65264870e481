"""scanrig.distributed against the single process, with 1, 2 and 4 Ray workers on this machine:
a batch of simulated scans (per-view tasks, then per-scan tasks) and AdFFT of the fused bunny
(leaf tasks). Prints a Markdown table for docs/scaling.md, with each worker's peak memory.

    pip install ./python ray
    python3 python/bench/ray_scaling.py [--scans 4] [--views 8] [--depth 9]
"""

import os

# One machine: every Ray server on the loopback (see python/tests/test_distributed.py); read when
# Ray is imported.
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
os.environ.setdefault("RAY_AUTH_MODE", "disabled")

import argparse  # noqa: E402
import pathlib
import shutil
import tempfile
import time

import numpy as np

import scanrig
from scanrig import distributed

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUNNY = ROOT.parent / "shared/data/stanford-bunny/reconstruction/bun_zipper.ply"


def worker_peaks_mb():
    """Peak resident memory (VmHWM) of each live Ray worker process, MB."""
    peaks = []
    for entry in pathlib.Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if not (entry / "cmdline").read_bytes().startswith(b"ray::"):
                continue
            for line in (entry / "status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    peaks.append(int(line.split()[1]) / 1024)
        except OSError:
            pass
    return peaks


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scans", type=int, default=4)
    ap.add_argument("--views", type=int, default=8)
    ap.add_argument("--depth", type=int, default=9)
    args = ap.parse_args()
    import ray

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        scans = []
        for k in range(args.scans):
            scanrig.simulate_scan(tmp / f"scan{k}", views=args.views, resolution=(320, 256), seed=20 + k)
            scans.append(tmp / f"scan{k}")
        t = time.perf_counter()
        for k, s in enumerate(scans):
            scanrig.process(s, tmp / f"single{k}")
        single_batch = time.perf_counter() - t
        cloud = scanrig.read_cloud(BUNNY)
        fused, _, _ = scanrig.fuse(cloud["points"])
        p, n = fused["points"], fused["normals"]
        t = time.perf_counter()
        # The full 2^depth grid, as this bench has measured since the first tranche (the fused bunny's
        # samples alone would stop the grid at depth 7).
        v1, f1, r1 = scanrig.reconstruct(p, n, method="adfft", depth=args.depth, samples_per_cell=0)
        single_adfft = time.perf_counter() - t
        leaves = sum(r1["leaves_by_depth"])
        rows.append(("single process (2 rayon threads)", single_batch, single_adfft, "", ""))
        for workers in [1, 2, 4]:
            distributed.connect(workers=workers)
            try:
                outs = [tmp / f"ray{workers}_{k}" for k in range(len(scans))]
                t = time.perf_counter()
                distributed.process_scans(scans, outs)
                batch = time.perf_counter() - t
                for k, o in enumerate(outs):
                    for name in ["fused.ply", "mesh.ply"]:
                        same = (o / name).read_bytes() == (tmp / f"single{k}" / name).read_bytes()
                        assert same, f"{o / name} differs from the single-process run"
                t = time.perf_counter()
                v2, f2, _ = distributed.reconstruct(p, n, depth=args.depth, samples_per_cell=0)
                adfft = time.perf_counter() - t
                assert np.array_equal(v1, v2) and np.array_equal(f1, f2), "AdFFT differs"
                peaks = worker_peaks_mb()
                mem = f"{max(peaks):.0f}" if peaks else "?"
                rows.append((f"Ray, {workers} worker(s)", batch, adfft, mem, len(peaks)))
            finally:
                ray.shutdown()
            for o in outs:
                shutil.rmtree(o, ignore_errors=True)
    print(
        f"{args.scans} scans × {args.views} views at 320×256; AdFFT depth {args.depth} "
        f"({1 << args.depth}³) of the fused bunny, {len(p)} points, {leaves} leaves\n"
    )
    print("| run | scan batch (s) | AdFFT (s) | peak per worker (MB) | worker processes |")
    print("|---|---|---|---|---|")
    for name, b, a, m, w in rows:
        print(f"| {name} | {b:.1f} | {a:.1f} | {m} | {w} |")


if __name__ == "__main__":
    main()
