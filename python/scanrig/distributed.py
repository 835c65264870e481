"""scanrig past one machine, on Ray: many scans, and AdFFT reconstructions too large for one process.

Two entry points, each the single-process result computed as Ray tasks (docs/scaling.md says what
each task sends and receives, and what limits the speed-up):

* :func:`process_scans` — every view of every scan (decode, triangulate, denoise) as a task in a
  scratch folder on its worker, returning the view's outputs packed; then each scan as a task that
  adopts its views' packs into the scan's output folder and runs the scan stages (merge, register,
  fuse, reconstruct, remesh), which find the views current. The scan folders must be readable by
  every worker (a shared file system) and the output folders writable by them.
* :func:`reconstruct` — AdFFT (thesis 5.3): the octree and coarse χ on the driver; the leaves' local
  FFT solves as tasks, each leaf cut into the parts the sweep's slabs need; the blend (eqs.
  5.19-5.20) and marching cubes as one task per slab of the grid, from the parts handed worker to
  worker; the slabs' meshes joined and cleaned on the driver. The points, normals and weights go
  into Ray's object store once; no solved leaf comes to the driver.

A task writes nothing outside its scratch folder until its scan adopts it, so a worker killed
mid-batch costs a retry (Ray reruns the task), never a lost or doubled result.

    python -m scanrig.distributed process SCAN... [--address HOST:PORT]
    python -m scanrig.distributed reconstruct CLOUD.ply -o MESH.ply [--depth 9]

Without ``--address`` (or ``RAY_ADDRESS``) a local Ray is started for the call and stopped after.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
import tempfile
import time
import warnings
from typing import Any, Optional, Sequence

import numpy as np

from . import _scanrig

try:
    import ray
except ImportError:  # pragma: no cover - said when used
    ray = None

# Ray reruns a task whose worker died this many times (its default is 3; said here, as the
# guarantee above rests on it).
RETRIES = 3


def _need_ray():
    if ray is None:
        raise ImportError("scanrig.distributed needs Ray: pip install 'ray>=2.40'")


def connect(address: Optional[str] = None, workers: Optional[int] = None) -> bool:
    """Connects to the Ray cluster at ``address`` (``"auto"``: the one ``ray start`` left running),
    or starts a local one with ``workers`` CPUs. Returns True when this call started Ray (the caller
    then shuts it down with ``ray.shutdown()``)."""
    _need_ray()
    if ray.is_initialized():
        return False
    # Each task runs the library single-threaded: Ray gives a task one CPU, and rayon's own pool of
    # every core on top of Ray's parallelism would put cores × workers threads on the cores.
    env = {"env_vars": {"RAYON_NUM_THREADS": "1"}}
    address = address or os.environ.get("RAY_ADDRESS")
    if address:
        ray.init(address=address, runtime_env=env, log_to_driver=False)
    else:
        ray.init(num_cpus=workers, runtime_env=env, include_dashboard=False, log_to_driver=False)
    return True


def _complete_views(scan: pathlib.Path) -> list[int]:
    # Read by the library, as every command reads a scan folder (journal applied, manifest checked).
    return _scanrig._complete_views(str(scan))


def _process_view(scan: str, view: int, force: bool) -> list[tuple[str, bytes]]:
    with tempfile.TemporaryDirectory(prefix=f"scanrig-view{view:03}-") as scratch:
        _scanrig.process(scan, scratch, force=force, until="denoise", views=[view])
        return _scanrig._pack(scratch)


def _process_scan(
    scan: str, out: str, force: bool, until: Optional[str], *packs: list[tuple[str, bytes]]
) -> dict[str, Any]:
    _scanrig._adopt(scan, out, list(packs))
    return _scanrig.process(scan, out, force=force, until=until)


def process_scans(
    folders: Sequence[os.PathLike | str],
    outs: Optional[Sequence[os.PathLike | str]] = None,
    *,
    force: bool = False,
    until: Optional[str] = None,
    address: Optional[str] = None,
    workers: Optional[int] = None,
) -> list[dict[str, Any]]:
    """Processes scan folders as ``scanrig.process`` does (to stage ``until``, as it takes it), each view
    a Ray task and each scan a task after its views; outputs go to ``outs`` (default
    ``SCAN/processed``). Returns the reports, in the order of ``folders``; the first scan that fails
    raises its error."""
    folders = [pathlib.Path(f).resolve() for f in folders]
    outs = [pathlib.Path(o).resolve() for o in outs] if outs is not None else [f / "processed" for f in folders]
    if len(outs) != len(folders):
        raise ValueError(f"outs: {len(outs)} folders for {len(folders)} scans")
    started = connect(address, workers)
    try:
        view_task = ray.remote(max_retries=RETRIES)(_process_view)
        scan_task = ray.remote(max_retries=RETRIES)(_process_scan)
        refs = []
        for scan, out in zip(folders, outs):
            packs = [view_task.remote(str(scan), v, force) for v in _complete_views(scan)]
            refs.append(scan_task.remote(str(scan), str(out), force, until, *packs))
        return ray.get(refs)
    finally:
        if started:
            ray.shutdown()


def _slab_parts(points, normals, weights, tasks, ids, grid, layers):
    # One return per slab (num_returns), so each slab's sweep is handed only its own parts.
    parts = _scanrig._adfft_slab_parts(points, normals, weights, tasks, ids, grid, layers)
    return tuple(parts) if len(parts) > 1 else parts[0]


def _sweep_slab(coarse, grid, layer, *part_lists):
    return _scanrig._adfft_sweep_slab([p for parts in part_lists for p in parts], coarse, grid, layer)


def reconstruct(
    points: np.ndarray,
    normals: np.ndarray,
    *,
    method: str = "adfft",
    depth: Optional[int] = None,
    error: Optional[float] = None,
    samples_per_cell: Optional[float] = None,
    slabs: Optional[int] = None,
    leaves_per_task: Optional[int] = None,
    address: Optional[str] = None,
    workers: Optional[int] = None,
    force: bool = False,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """AdFFT with its sweep done by Ray tasks: the same (V, F, report) as
    ``scanrig.reconstruct(points, normals, method="adfft", ...)``, the report with a
    ``"distributed"`` entry (leaves, tasks, slabs, seconds, MB moved). The samples go into the object
    store once. Solve tasks of ``leaves_per_task`` leaves each (default: one task per CPU) solve
    their leaves and cut each into the parts the slabs need; one task per slab (default: one per
    CPU) blends and marches its layers from those parts. The parts go from worker to worker; only the
    slabs' meshes come back, joined along their shared planes here. The mesh is checked as
    ``scanrig.reconstruct`` checks its own: no surface, or one far from the points, inside out,
    facing against their normals, leaving some out or coarsened by a few points far from the rest
    (unless ``force``), raises ``StageError``;
    anything else wrong is a ``UserWarning``."""
    if method != "adfft":
        raise ValueError(f'method: only "adfft" has leaves to spread over workers, got {method!r}')
    if leaves_per_task is not None and leaves_per_task < 1:
        raise ValueError(f"leaves_per_task must be at least 1, got {leaves_per_task}")
    if slabs is not None and not 1 <= slabs <= 4096:
        raise ValueError(f"slabs must be 1 to 4096, got {slabs}")
    # As scanrig.reconstruct takes it: a bool (NumPy's too), anything else a TypeError by name.
    if not isinstance(force, (bool, np.bool_)):
        raise TypeError(f"force must be True or False, got {force!r}")
    started = connect(address, workers)
    try:
        cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
        shared = (ray.put(np.ascontiguousarray(points)), ray.put(np.ascontiguousarray(normals)))
        spread: dict[str, Any] = {}

        def run(tasks, grid, weights, coarse, layers):
            start = time.perf_counter()
            w, c = ray.put(weights), ray.put(coarse)
            solve = ray.remote(max_retries=RETRIES, num_returns=len(layers))(_slab_parts)
            sweep = ray.remote(max_retries=RETRIES)(_sweep_slab)
            # One solve task per CPU: each builds its own k-d tree over the samples (a fifth of a
            # second for the bunny's 362,272), so more tasks cost more than the balance they buy.
            per = leaves_per_task or max(1, -(-len(tasks) // cpus))
            parts = []
            for i in range(0, len(tasks), per):
                refs = solve.remote(shared[0], shared[1], w, tasks[i : i + per], list(range(i, i + len(tasks[i : i + per]))), grid, layers)
                parts.append(refs if len(layers) > 1 else [refs])
            meshes = [sweep.remote(c, grid, layer, *[p[s] for p in parts]) for s, layer in enumerate(layers)]
            # When the solves were done, without fetching their parts here.
            ray.wait([r for p in parts for r in p], num_returns=len(parts) * len(layers), fetch_local=False)
            solved = time.perf_counter()
            meshes = ray.get(meshes)
            spread.update(
                leaves=len(tasks),
                tasks=len(parts),
                slabs=len(layers),
                seconds_solving=solved - start,
                seconds_sweeping=time.perf_counter() - solved,
                sent_mb=(points.nbytes + normals.nbytes + weights.nbytes + tasks.nbytes + coarse["values"].nbytes) / 1e6,
                returned_mb=sum(v.nbytes + f.nbytes for v, f in meshes) / 1e6,
            )
            return meshes

        v, f, report = _scanrig._adfft_slabs(
            points,
            normals,
            run,
            slabs=slabs or cpus,
            depth=depth,
            error=error,
            samples_per_cell=samples_per_cell,
            force=bool(force),
        )
        report["distributed"] = spread
        return v, f, report
    finally:
        if started:
            ray.shutdown()


def _say(message, category, filename, lineno, file=None, line=None):
    # A warning on the command line reads as scanrig's own do ("warning: ..."), not as a source line.
    print(f"warning: {message}", file=sys.stderr)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scanrig.distributed", description=__doc__.split("\n\n")[0])
    parser.add_argument("--address", help="a Ray cluster (HOST:PORT, or 'auto'); default: start a local one")
    parser.add_argument("--workers", type=int, help="CPUs of the local cluster (default: all)")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("process", help="process scan folders (each into SCAN/processed)")
    p.add_argument("scans", nargs="+", type=pathlib.Path)
    p.add_argument("--force", action="store_true", help="go on past implausible registrations, with warnings")
    p.add_argument("--until", help="stop after this stage (as `scanrig process --until` takes it)")
    r = sub.add_parser("reconstruct", help="AdFFT of an oriented cloud (PLY, E57, ...) into a mesh")
    r.add_argument("cloud", type=pathlib.Path)
    r.add_argument("-o", "--out", type=pathlib.Path, required=True)
    r.add_argument("--depth", type=int)
    r.add_argument("--error", type=float)
    r.add_argument("--samples-per-cell", type=float, help="as `scanrig reconstruct --samples-per-cell` (0: keep --depth)")
    r.add_argument("--slabs", type=int, help="slabs of the sweep (default: one per CPU)")
    r.add_argument("--force", action="store_true", help="keep a mesh its points do not support (far, inside out, facing against them, leaving some out, coarsened by points far from the rest), with a warning")
    args = parser.parse_args(argv)
    # Only for this call: main() run from Python leaves the caller's warning display as it was.
    with warnings.catch_warnings():
        warnings.showwarning = _say
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    try:
        if args.command == "process":
            reports = process_scans(
                args.scans, force=args.force, until=args.until, address=args.address, workers=args.workers
            )
            for scan, rep in zip(args.scans, reports):
                print(f"{scan}: {rep['total_seconds']:.1f} s, outputs in {scan / 'processed'}")
        else:
            cloud = _scanrig.read_cloud(args.cloud)
            if cloud["normals"] is None:
                raise _scanrig.StageError(f"{args.cloud} has no normals: reconstruction needs oriented points")
            v, f, rep = reconstruct(
                cloud["points"], cloud["normals"], depth=args.depth, error=args.error,
                samples_per_cell=args.samples_per_cell, slabs=args.slabs, address=args.address, workers=args.workers,
                force=args.force,
            )
            _scanrig.write_mesh(args.out, v, f)
            print(f"{args.out}: {len(v)} vertices, {len(f)} triangles")
    except (_scanrig.ScanrigError, ValueError, ImportError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
