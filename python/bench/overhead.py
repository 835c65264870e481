"""Python call overhead of the bindings against the same work in Rust, measured in one run.

Runs the Rust reference (process/examples/binding_reference.rs), which times the ICP bench pair
(target tree built in the call, 41 runs) and the 387 K-point fusion (5 runs) and writes their
inputs, then times scanrig.icp and scanrig.fuse on those very inputs the same way. The overhead is
compared on the fastest run of each side (the one the machine disturbed least: on 2 shared cores the
medians of two processes drift apart by ±15 % on their own); medians are printed beside. The fixed
cost of a call (argument checks, the worker thread, the report dict) is timed on a 50-point ICP.

    cargo build --release -p process --example binding_reference
    python3 python/bench/overhead.py [target/release/examples/binding_reference]
"""

import json
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import scanrig

root = pathlib.Path(__file__).resolve().parents[2]
reference = sys.argv[1] if len(sys.argv) > 1 else str(root / "target/release/examples/binding_reference")

with tempfile.TemporaryDirectory() as tmp:
    out = subprocess.run([reference, tmp], capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1]
    if out.startswith("SKIPPED"):
        sys.exit(out)
    rust = json.loads(out)
    d = pathlib.Path(tmp)
    moving, target = scanrig.read_cloud(d / "icp_moving.ply"), scanrig.read_cloud(d / "icp_target.ply")
    initial = np.loadtxt(d / "icp_initial.txt")
    args = (moving["points"], moving["normals"], target["points"], target["normals"])

    def timed(call, runs, scale):
        times = []
        for _ in range(runs):
            t = time.perf_counter()
            call()
            times.append((time.perf_counter() - t) * scale)
        return min(times), statistics.median(times)

    icp_ms = timed(lambda: scanrig.icp(*args, initial=initial), 41, 1e3)
    # 50 target points onto themselves: a call with next to no work in it.
    tiny = tuple(a[:50].copy() for a in args[2:] * 2)
    call_ms = timed(lambda: scanrig.icp(*tiny, max_iterations=1), 200, 1e3)
    cloud = scanrig.read_cloud(d / "fuse_input.ply")
    fuse_s = timed(lambda: scanrig.fuse(cloud["points"], cloud["normals"], kernel_spacing=0.0), 5, 1.0)


def row(what, r, p, unit):
    print(
        f"{what}: Rust {r[0]:.4g} {unit}, Python {p[0]:.4g} {unit} (fastest): overhead {100 * (p[0] / r[0] - 1):+.1f} %"
        f"; medians {r[1]:.4g} and {p[1]:.4g} {unit}"
    )


row("ICP bench pair", rust["icp_ms"], icp_ms, "ms")
row(f"fusion of {rust['fuse_points']} points", rust["fuse_s"], fuse_s, "s")
print(f"fixed cost of a call (50-point ICP, one iteration): {1e3 * call_ms[1]:.0f} µs median")
