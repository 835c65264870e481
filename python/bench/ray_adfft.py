"""AdFFT on a local Ray cluster of 1 and 2 workers against the single process (issue 42, part 2):
the same oriented points, each run in a fresh Python process of its own, so the driver's peak
resident memory (its own VmHWM, the Ray client included) is that run's alone. Every distributed
mesh is checked equal to the single-process one, vertex for vertex. Prints a Markdown table for
docs/scaling.md.

    pip install ./python ray
    python3 python/bench/ray_adfft.py [--depth 9] [--cloud PLY] [--repeat 2]
        [--baseline-path DIR]   # another scanrig package (its python/ folder built in place),
                                # run the same way for a before/after in one run

The cloud defaults to the Stanford bunny's bun_zipper.ply fused (31,814 points), the input
docs/scaling.md has measured since the first tranche; it is reconstructed on the full 2^depth grid
(samples_per_cell=0), though its samples alone would stop the grid sooner. Each Ray task runs the
library single-threaded (RAYON_NUM_THREADS=1, as scanrig.distributed sets it); the single process
and the driver use both cores. The workers are started and have imported scanrig before the clock
starts (a cluster outlives one call; a cold start adds 1-2 s of Python imports per worker).
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUNNY = ROOT.parent / "shared/data/stanford-bunny/reconstruction/bun_zipper.ply"

CHILD = r"""
import json, os, sys, time, hashlib, pathlib
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
os.environ.setdefault("RAY_AUTH_MODE", "disabled")
import numpy as np
import scanrig
from scanrig import distributed
data, workers, depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
p, n = np.load(data + "/points.npy"), np.load(data + "/normals.npy")
def hwm_mb(pid="self"):
    for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
def worker_peaks():
    peaks = []
    for e in pathlib.Path("/proc").iterdir():
        try:
            if e.name.isdigit() and (e / "cmdline").read_bytes().startswith(b"ray::"):
                peaks.append(hwm_mb(e.name))
        except OSError:
            pass
    return [x for x in peaks if x]
import inspect
# A scanrig before the grid adapted to the samples has no such keyword, and always builds the full grid.
kw = {"samples_per_cell": 0} if "samples_per_cell" in inspect.signature(distributed.reconstruct).parameters else {}
if workers == 0:
    t = time.perf_counter()
    v, f, r = scanrig.reconstruct(p, n, method="adfft", depth=depth, **kw)
    seconds, spread, peaks = time.perf_counter() - t, {}, []
else:
    distributed.connect(workers=workers)
    import ray
    # Warm: every worker process started and scanrig imported, as on a cluster that outlives one call.
    @ray.remote
    def warm():
        import scanrig._scanrig
        time.sleep(0.5)
    ray.get([warm.remote() for _ in range(2 * workers)])
    t = time.perf_counter()
    v, f, r = distributed.reconstruct(p, n, depth=depth, **kw)
    seconds = time.perf_counter() - t
    spread, peaks = r.get("distributed", {}), worker_peaks()
    ray.shutdown()
digest = hashlib.sha256(np.ascontiguousarray(v).tobytes() + np.ascontiguousarray(f).tobytes()).hexdigest()
print(json.dumps({"seconds": seconds, "driver_mb": hwm_mb(), "worker_mb": max(peaks) if peaks else None,
                  "n": r.get("n"), "leaves": sum(r["leaves_by_depth"]), "triangles": len(f), "digest": digest,
                  "spread": spread}))
"""


def run(data, workers, depth, path):
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = str(path) + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, "-c", CHILD, data, str(workers), str(depth)], capture_output=True, text=True, env=env
    )
    if out.returncode != 0:
        sys.exit(f"the run with {workers} worker(s) failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--depth", type=int, default=9)
    ap.add_argument("--cloud", type=pathlib.Path, help="an oriented PLY (default: the fused bunny)")
    ap.add_argument("--repeat", type=int, default=2, help="runs of each setting; the table takes the fastest")
    ap.add_argument("--baseline-path", type=pathlib.Path, help="PYTHONPATH of another scanrig to run alike")
    a = ap.parse_args()
    if not 6 <= a.depth <= 11:
        ap.error("--depth: 6 to 11")
    if a.repeat < 1:
        ap.error("--repeat: at least 1")
    if a.baseline_path and not (a.baseline_path / "scanrig").is_dir():
        ap.error(f"--baseline-path: {a.baseline_path} holds no scanrig package")
    import scanrig

    with tempfile.TemporaryDirectory() as tmp:
        if a.cloud:
            c = scanrig.read_cloud(a.cloud)
            if c["normals"] is None:
                ap.error(f"--cloud: {a.cloud} has no normals")
            p, n = c["points"], c["normals"]
        else:
            fused, _, _ = scanrig.fuse(scanrig.read_cloud(BUNNY)["points"])
            p, n = fused["points"], fused["normals"]
        np.save(f"{tmp}/points.npy", p)
        np.save(f"{tmp}/normals.npy", n)
        rows = []
        for label, path in [("before", a.baseline_path), ("now", None)] if a.baseline_path else [("now", None)]:
            for workers in [0, 1, 2]:
                runs = [run(tmp, workers, a.depth, path) for _ in range(a.repeat)]
                best = min(runs, key=lambda r: r["seconds"])
                best["driver_mb"] = max(r["driver_mb"] for r in runs)
                rows.append((label, workers, best))
                print(json.dumps({"label": label, "workers": workers, **best}), file=sys.stderr, flush=True)
    same = all(len({r["digest"] for lab, _, r in rows if lab == code}) == 1 for code in {lab for lab, _, _ in rows})
    same = "equal to the single process's" if same else "DIFFERENT from the single process's"
    first = rows[-1][2]
    print(f"AdFFT of {len(p)} points on the {first['n']}³ grid, {first['leaves']} leaves, "
          f"{first['triangles']} triangles; the distributed meshes {same}\n")
    print("| code | run | time (s) | × 1 worker | driver peak (MB) | worker peak (MB) |")
    print("|---|---|---|---|---|---|")
    for label, workers, r in rows:
        one = next(x for lab, w, x in rows if lab == label and w == 1)
        name = "single process, 2 threads" if workers == 0 else f"Ray, {workers} worker(s)"
        speed = f"{one['seconds'] / r['seconds']:.2f}×" if workers else "–"
        wmb = f"{r['worker_mb']:.0f}" if r["worker_mb"] else "–"
        print(f"| {label} | {name} | {r['seconds']:.1f} | {speed} | {r['driver_mb']:.0f} | {wmb} |")


if __name__ == "__main__":
    main()
