#!/usr/bin/env python3
"""Runs `scanrig process` once and prints, per stage, its wall seconds and how many cores it kept busy
on average (CPU seconds over wall seconds, from /proc/PID/stat sampled every 50 ms). A stage near 1.0 on
a 2-core machine leaves a core idle: work that could run beside it.

    python3 bench/cpu_timeline.py BUILD SCAN

Stage boundaries come from the progress lines `process` prints on stderr as each stage ends.
"""

import os
import subprocess
import sys
import tempfile
import threading
import time

TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICK
    except (FileNotFoundError, ProcessLookupError):
        return None


def main():
    build, scan = sys.argv[1], sys.argv[2]
    out = tempfile.mkdtemp(prefix="cpu-timeline-")
    t0 = time.monotonic()
    proc = subprocess.Popen(
        [build, "process", scan, "-o", os.path.join(out, "p")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    samples = []

    def sample():
        while proc.poll() is None:
            c = cpu_seconds(proc.pid)
            if c is not None:
                samples.append((time.monotonic() - t0, c))
            time.sleep(0.05)

    sampler = threading.Thread(target=sample)
    sampler.start()
    marks = []
    for line in proc.stderr:
        line = line.strip()
        if line:
            marks.append((time.monotonic() - t0, line[:70]))
    proc.wait()
    sampler.join()
    end = time.monotonic() - t0
    marks.append((end, "end"))

    def cpu_at(t):
        best = (0.0, 0.0)
        for s in samples:
            if s[0] <= t:
                best = s
        return best[1]

    # `process` prints a stage's line as it ends ("fuse 1/1"; views as they finish): the time since
    # the previous line is that stage's. Consecutive lines of one stage are joined.
    rows = []
    previous = 0.0
    for t, line in marks:
        name = line.split(":")[0].split(" ")[0]
        if rows and rows[-1][0] == name:
            rows[-1][2] = t
        else:
            rows.append([name, previous, t])
        previous = t
    print(f"{'stage':<16}{'start':>8}{'wall s':>8}{'cores':>7}")
    for name, a, b in rows:
        if b - a < 0.05:
            continue
        cores = (cpu_at(b) - cpu_at(a)) / (b - a)
        print(f"{name:<16}{a:>8.2f}{b - a:>8.2f}{cores:>7.2f}")
    print(f"total {end:.2f} s, {samples[-1][1] if samples else 0:.1f} CPU s")


if __name__ == "__main__":
    main()
