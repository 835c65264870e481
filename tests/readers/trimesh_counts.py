"""Independent readers' view of scanrig's files (issue 22): each file given is opened with trimesh (E57
with pye57, libE57Format's Python binding, which trimesh does not read) and described as JSON on stdout — what it loaded as, vertex and face counts, and for meshes the edge
topology of its triangles (trimesh splits polygons into triangles on load): edges used by exactly two
triangles, edges used by more, and the Euler characteristic V - E + F.

Usage: python3 trimesh_counts.py FILE...   (exit status 0; an unreadable file is reported, not raised)
"""
import json
import sys
from collections import Counter

import numpy as np
import trimesh


def describe_e57(path):
    try:
        import pye57

        e57 = pye57.E57(path)
        counts, extents, colored, normals = 0, [0.0, 0.0, 0.0], False, False
        for k in range(e57.scan_count):
            # Normals are the surface-normals extension (nor:normalX ...), which libE57Format reads and
            # pye57 hands back only as fields it names unsupported: it reads the rest when told to.
            header = e57.get_header(k)
            names = [header.point_fields[i] for i in range(len(header.point_fields))]
            normals = normals or "nor:normalX" in names
            data = e57.read_scan_raw(k, ignore_unsupported_fields=True)
            xyz = np.stack([data["cartesianX"], data["cartesianY"], data["cartesianZ"]], axis=1)
            counts += len(xyz)
            if len(xyz):
                extents = [max(a, float(b)) for a, b in zip(extents, np.ptp(xyz, axis=0))]
            colored = colored or "colorRed" in data
        return {"type": "E57", "vertices": counts, "finite": True, "extent": extents, "colored": colored,
                "normals": normals}
    except Exception as e:
        return {"error": f"{type(e).__name__}: {e}"}


def describe(path):
    if path.lower().endswith(".e57"):
        return describe_e57(path)
    try:
        loaded = trimesh.load(path, process=False)
    except Exception as e:  # the caller asserts on it, naming the file
        return {"error": f"{type(e).__name__}: {e}"}
    if isinstance(loaded, trimesh.Scene):
        geoms = list(loaded.dump()) if hasattr(loaded, "dump") else list(loaded.geometry.values())
        if len(geoms) == 1:
            loaded = geoms[0]
        elif geoms and all(isinstance(g, trimesh.Trimesh) for g in geoms):
            loaded = trimesh.util.concatenate(geoms)
    out = {"type": type(loaded).__name__}
    vertices = getattr(loaded, "vertices", None)
    if vertices is not None:
        out["vertices"] = int(len(vertices))
        out["finite"] = bool(np.isfinite(np.asarray(vertices)).all())
        out["extent"] = [float(x) for x in np.ptp(np.asarray(vertices), axis=0)] if len(vertices) else [0, 0, 0]
    colors = getattr(getattr(loaded, "visual", None), "vertex_colors", None)
    if colors is None:
        colors = getattr(loaded, "colors", None)
    if colors is not None and len(colors):
        out["colored"] = bool(np.asarray(colors)[:, :3].std() > 0)
    faces = getattr(loaded, "faces", None)
    if isinstance(loaded, trimesh.Trimesh) and faces is not None:
        out["faces"] = int(len(faces))
        # Edges keyed by sorted vertex pairs; merged vertices are not assumed (process=False).
        edges = Counter(map(tuple, np.sort(loaded.edges, axis=1).tolist()))
        out["edges"] = len(edges)
        out["edges_shared_by_two"] = sum(1 for c in edges.values() if c == 2)
        out["edges_shared_by_more"] = sum(1 for c in edges.values() if c > 2)
        out["euler"] = int(len(loaded.vertices)) - len(edges) + int(len(faces))
    return out


if __name__ == "__main__":
    print(json.dumps({p: describe(p) for p in sys.argv[1:]}))
