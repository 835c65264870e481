#!/usr/bin/env python3
"""Runs `scanrig process` on one scan with two (or more) builds, interleaved, and prints each stage's
fastest and median seconds and largest peak per build. Interleaving is the point: on a shared machine
the same build's total drifts by ±10 % from one run to the next, and a comparison of two builds is
only fair when both saw the same conditions.

    python3 bench/pipeline_ab.py SCAN BUILD_A BUILD_B [--rounds 3]

SCAN is a scan folder (`scanrig demo -o demo36` writes demo36/scan); BUILD_* are scanrig binaries.
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import tempfile
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scan")
    ap.add_argument("builds", nargs="+")
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    rows = {b: [] for b in a.builds}
    work = tempfile.mkdtemp(prefix="pipeline-ab-")
    try:
        for r in range(a.rounds):
            for b in a.builds:
                out = os.path.join(work, "out")
                shutil.rmtree(out, ignore_errors=True)
                t = time.monotonic()
                subprocess.run([b, "process", a.scan, "-o", out, "-q"], check=True, stdout=subprocess.DEVNULL)
                wall = time.monotonic() - t
                with open(os.path.join(out, "report.json")) as f:
                    report = json.load(f)
                row = {s["stage"]: (s["seconds"], s["peak_mb"] or 0.0) for s in report["stages"]}
                row["wall"] = (wall, 0.0)
                rows[b].append(row)
                print(f"round {r + 1} {b}: " + ", ".join(f"{k} {v[0]:.2f} s" for k, v in row.items()), flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    stages = list(rows[a.builds[0]][0].keys())
    print("\n| stage | " + " | ".join(f"{b} fastest / median s, peak MB" for b in a.builds) + " |")
    print("|---|" + "---|" * len(a.builds))
    for s in stages:
        cells = []
        for b in a.builds:
            secs = [row[s][0] for row in rows[b] if s in row]
            peak = max(row[s][1] for row in rows[b] if s in row)
            cells.append(f"{min(secs):.2f} / {statistics.median(secs):.2f}" + (f", {peak:.0f}" if peak else ""))
        print(f"| {s} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
