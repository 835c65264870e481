#!/usr/bin/env python3
"""Reconstructs the same oriented bunny points with scanrig's AdFFT and the Poisson peers installed
here, back to back at each depth, and writes the side-by-side table into BENCHMARKS.md (issue 42).

    cargo build --release --bin scanrig && cargo build --release -p process --example peers_bench
    python3 bench/peers.py [--depths 8 9 10] [--peer-python VENV/bin/python] [--poissonrecon BIN]
        [--repeat N] [--write]

The peers, each run when found, else named as missing in the table:
  - Open3D's Poisson (`TriangleMesh.create_from_point_cloud_poisson`) and MeshLab's screened Poisson
    (pymeshlab, `generate_surface_reconstruction_screened_poisson`), in the Python given by
    --peer-python (default: this one), each at its defaults but the depth;
  - Kazhdan's PoissonRecon, the binary given by --poissonrecon or found on PATH (built from its
    source with `make poissonrecon`), at its defaults but the depth.

Every tool runs as its own process, reading the same PLY and writing a mesh, so time is the whole run
(reading, reconstructing, writing; the Python peers' imports included, about a second) and peak is the
process's own maximum resident set (os.wait4's ru_maxrss). The meshes are then measured alike by
`peers_bench score` (accuracy, completeness and their mean against bun_zipper.ply, topology,
self-intersections). Compare ratios within one run of this script: the machine's speed drifts between
runs. With --repeat N each depth runs every tool N times in rounds (all tools, then all again), and
takes each tool's fastest time and largest peak: a 2-core machine's speed moves by a quarter from
minute to minute, and one slow minute had decided a ratio near the goal. A run that exceeds
--timeout is stopped and reported as such.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BEGIN, END = "<!-- peers-bench:begin -->", "<!-- peers-bench:end -->"

OPEN3D = """
import sys, open3d as o3d
pc = o3d.io.read_point_cloud(sys.argv[1])
assert pc.has_normals(), "no normals read from " + sys.argv[1]
mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pc, depth=int(sys.argv[3]))
assert o3d.io.write_triangle_mesh(sys.argv[2], mesh), "could not write " + sys.argv[2]
"""

MESHLAB = """
import sys, pymeshlab
ms = pymeshlab.MeshSet()
ms.load_new_mesh(sys.argv[1])
ms.generate_surface_reconstruction_screened_poisson(depth=int(sys.argv[3]))
ms.save_current_mesh(sys.argv[2])
"""


def run_measured(cmd, timeout):
    """Runs cmd; returns (seconds, peak MB, error or None). Peak is the child's own ru_maxrss."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = start + timeout
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() > deadline:
            proc.kill()
            _, status, usage = os.wait4(proc.pid, 0)
            return time.monotonic() - start, usage.ru_maxrss / 1024, f"stopped after {timeout:.0f} s"
        time.sleep(0.05)
    seconds = time.monotonic() - start
    err = proc.stderr.read()
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        last = [l for l in err.strip().splitlines() if l.strip()][-1:] or [f"exit {code}"]
        return seconds, usage.ru_maxrss / 1024, f"exit {code}: {last[0][:160]}"
    return seconds, usage.ru_maxrss / 1024, None


def python_has(python, module):
    return subprocess.run([python, "-c", f"import {module}"], capture_output=True).returncode == 0


def tools(a):
    """(name, command for (input, output, depth)) of each tool found, and the names of those missing."""
    found, missing = [], []
    found.append(("scanrig AdFFT", lambda i, o, d: [a.scanrig, "reconstruct", i, "-o", o, "--method", "adfft", "--depth", str(d)]))
    if python_has(a.peer_python, "open3d"):
        found.append(("Open3D Poisson", lambda i, o, d: [a.peer_python, "-c", OPEN3D, i, o, str(d)]))
    else:
        missing.append(f"Open3D (not importable by {a.peer_python})")
    pr = a.poissonrecon or shutil.which("PoissonRecon")
    if pr:
        found.append(("PoissonRecon", lambda i, o, d: [pr, "--in", i, "--out", o, "--depth", str(d)]))
    else:
        missing.append("PoissonRecon (give --poissonrecon)")
    if python_has(a.peer_python, "pymeshlab"):
        found.append(("MeshLab screened Poisson", lambda i, o, d: [a.peer_python, "-c", MESHLAB, i, o, str(d)]))
    else:
        missing.append(f"pymeshlab (not importable by {a.peer_python})")
    return found, missing


def topology_text(s):
    if s.get("closed_manifold"):
        shape = f"closed, genus {s['genus']}"
    else:
        shape = f"open ({s['boundary_edges']} boundary, {s['non_manifold_edges']} non-manifold edges)"
    return f"{shape}, {s['components']} comp., {s['self_intersections']} self-int."


def table(rows, depths, missing, stamp):
    out = [BEGIN, "", stamp, ""]
    out.append("| depth | tool | time | peak | chamfer (acc. / compl.) | triangles | topology |")
    out.append("|---|---|---|---|---|---|---|")
    for d in depths:
        for r in [r for r in rows if r["depth"] == d]:
            if r.get("error"):
                out.append(f"| {d} | {r['tool']} | {r['seconds']:.1f} s | {r['peak_mb']:.0f} MB | {r['error']} | – | – |")
                continue
            s = r["score"]
            out.append(
                f"| {d} | {r['tool']} | {r['seconds']:.1f} s | {r['peak_mb']:.0f} MB | "
                f"{s['chamfer_mm']:.4f} ({s['accuracy_mm']:.4f} / {s['completeness_mm']:.4f}) mm | "
                f"{s['triangles']:,} | {topology_text(s)} |"
            )
    out.append("")
    for d in depths:
        ours = next((r for r in rows if r["depth"] == d and r["tool"] == "scanrig AdFFT" and not r.get("error")), None)
        peers = [r for r in rows if r["depth"] == d and r["tool"] != "scanrig AdFFT" and not r.get("error")]
        if not ours or not peers:
            continue
        fastest = min(peers, key=lambda r: r["seconds"])
        leanest = min(peers, key=lambda r: r["peak_mb"])
        best = min(peers, key=lambda r: r["score"]["chamfer_mm"])
        out.append(
            f"- depth {d}: AdFFT time {ours['seconds'] / fastest['seconds']:.2f} × the fastest peer's ({fastest['tool']}; "
            f"goal ≤ 0.5 ×), peak {ours['peak_mb'] / leanest['peak_mb']:.2f} × the leanest's ({leanest['tool']}; goal ≤ 1 ×), "
            f"chamfer {ours['score']['chamfer_mm'] / best['score']['chamfer_mm']:.3f} × the best peer's ({best['tool']}; goal ≤ 1 ×)."
        )
    if missing:
        out.append(f"- Not run (not installed here): {', '.join(missing)}.")
    out += ["", END]
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--depths", type=int, nargs="+", default=[8, 9, 10])
    ap.add_argument("--scanrig", default=os.path.join(ROOT, "target/release/scanrig"))
    ap.add_argument("--scorer", default=os.path.join(ROOT, "target/release/examples/peers_bench"))
    ap.add_argument("--peer-python", default=sys.executable)
    ap.add_argument("--poissonrecon")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds one reconstruction may run")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each tool per depth, in interleaved rounds (time: the fastest)")
    ap.add_argument("--write", action="store_true", help="replace the table in BENCHMARKS.md")
    ap.add_argument("--keep", help="a new folder to keep the input and the meshes in")
    a = ap.parse_args()
    if not 1 <= a.repeat <= 20:
        ap.error("--repeat: 1 to 20")
    if any(not 5 <= d <= 12 for d in a.depths):
        ap.error("--depths: each between 5 and 12")
    for what, path in [("--scanrig", a.scanrig), ("--scorer", a.scorer)]:
        if not os.access(path, os.X_OK):
            ap.error(f"{what}: {path} is not an executable (build it: see this script's help)")
    if a.poissonrecon and not os.access(a.poissonrecon, os.X_OK):
        ap.error(f"--poissonrecon: {a.poissonrecon} is not an executable")
    if a.keep and os.path.exists(a.keep):
        ap.error(f"--keep: {a.keep} exists; give a new folder")
    work = a.keep or tempfile.mkdtemp(prefix="peers-bench-")
    os.makedirs(work, exist_ok=True)
    try:
        points = os.path.join(work, "bunny_oriented.ply")
        subprocess.run([a.scorer, "export", points], check=True)
        found, missing = tools(a)
        rows = []
        for d in a.depths:
            # Rounds: every tool once, then every tool again, so a slow minute on this shared machine
            # falls on all of them alike; each tool's time is its fastest run, its peak its largest.
            runs = {name: [] for name, _ in found}
            for _ in range(a.repeat):
                for name, cmd in found:
                    out = os.path.join(work, f"{re.sub(r'[^a-z0-9]+', '_', name.lower())}_{d}.ply")
                    if os.path.exists(out):
                        os.remove(out)  # so a run that writes nothing is not credited with the last one's mesh
                    runs[name].append((out, *run_measured(cmd(points, out, d), a.timeout)))
            for name, _ in found:
                out = runs[name][-1][0]
                failed = [r[3] for r in runs[name] if r[3] is not None]
                seconds = min(r[1] for r in runs[name])
                row = {"depth": d, "tool": name, "seconds": seconds, "peak_mb": max(r[2] for r in runs[name])}
                if a.repeat > 1:
                    row["runs_seconds"] = [round(r[1], 2) for r in runs[name]]
                err = failed[0] if failed else None
                if err is None and not os.path.exists(out):
                    err = "wrote no mesh"
                if err is None:
                    # The last run's mesh (a peer's can differ from run to run).
                    scored = subprocess.run([a.scorer, "score", out], check=True, capture_output=True, text=True)
                    row["score"] = json.loads(scored.stdout.strip().splitlines()[-1])
                    err = row["score"].get("error")
                    if err is None and row["score"].get("chamfer_mm") is None:
                        err = "scored no chamfer (a distance came out NaN)"
                if err:
                    row["error"] = err
                rows.append(row)
                print(json.dumps(row), flush=True)
        stamp = (
            f"`python3 bench/peers.py --depths {' '.join(map(str, a.depths))}"
            + (f" --repeat {a.repeat}` " if a.repeat > 1 else "` ")
            + f"on {time.strftime('%Y-%m-%d')}, "
            f"{os.cpu_count()} cores: the ten aligned bunny scans (362,272 points, sensor-oriented PCA normals), "
            "each tool a process of its own; time and peak RSS of the whole process"
            + (f" (the fastest and the largest of {a.repeat} runs, in rounds of every tool)" if a.repeat > 1 else "")
            + "; chamfer = the mean of "
            "accuracy and completeness against bun_zipper.ply (mm)."
        )
        text = table(rows, a.depths, missing, stamp)
        print(text)
        if a.write:
            path = os.path.join(ROOT, "BENCHMARKS.md")
            with open(path) as f:
                doc = f.read()
            if BEGIN in doc and END in doc:
                doc = doc[: doc.index(BEGIN)] + text + doc[doc.index(END) + len(END) :]
            else:
                doc = doc.rstrip("\n") + "\n\n## AdFFT against the Poisson peers (issue 42)\n\n" + text + "\n"
            tmp = path + ".peers-tmp"
            with open(tmp, "w") as f:
                f.write(doc)
            os.replace(tmp, path)
            print(f"wrote the table into {path}")
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
