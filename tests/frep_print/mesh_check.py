"""What a slicer's checks find in STL files: one JSON line per file.

    python3 mesh_check.py FILE.stl [FILE.stl ...]

For each file: triangle count, Open3D's self-intersecting triangle pairs, trimesh's
watertightness, winding consistency, Euler characteristic, bounds and volume, and what
admesh repairs (when it is installed). Open3D compares every pair of triangles, which
is quadratic, so the mesh is cut into boxes of a few thousand triangles (a triangle in
every box its bounding box meets) and each box checked alone: two triangles that
intersect meet in some box, so both are in that box's part and no pair is missed.
"""

import json
import re
import shutil
import subprocess
import sys

import numpy as np
import open3d as o3d
import trimesh

# Triangles per part: Open3D's quadratic pass stays around a hundredth of a second.
PART = 3000


def self_intersections(vertices, faces):
    """Open3D's self-intersecting pairs of the whole mesh, as a set of index pairs."""
    tri = vertices[faces]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    pairs = set()
    stack = [(vertices.min(axis=0), vertices.max(axis=0), np.arange(len(faces)), 0)]
    while stack:
        blo, bhi, idx, depth = stack.pop()
        if len(idx) <= PART or depth > 40:
            used, local = np.unique(faces[idx].ravel(), return_inverse=True)
            m = o3d.geometry.TriangleMesh(
                o3d.utility.Vector3dVector(vertices[used]),
                o3d.utility.Vector3iVector(local.reshape(-1, 3).astype(np.int32)),
            )
            for a, b in np.asarray(m.get_self_intersecting_triangles()):
                a, b = int(idx[a]), int(idx[b])
                pairs.add((min(a, b), max(a, b)))
            continue
        axis = int(np.argmax(bhi - blo))
        mid = 0.5 * (blo[axis] + bhi[axis])
        for half in (0, 1):
            nlo, nhi = blo.copy(), bhi.copy()
            if half == 0:
                nhi[axis] = mid
                keep = lo[idx, axis] <= mid
            else:
                nlo[axis] = mid
                keep = hi[idx, axis] >= mid
            stack.append((nlo, nhi, idx[keep], depth + 1))
    return pairs


def admesh(path):
    """The counts admesh reports as repairs (all zero for a clean file)."""
    if shutil.which("admesh") is None:
        return None
    out = subprocess.run(["admesh", path], capture_output=True, text=True).stdout
    keys = [
        "Degenerate facets",
        "Edges fixed",
        "Facets removed",
        "Facets added",
        "Facets reversed",
        "Backwards edges",
        "Number of parts",
    ]
    found = {}
    for k in keys:
        m = re.search(re.escape(k) + r"\s*:\s*(\d+)", out)
        found[k] = int(m.group(1)) if m else None
    return found


def check(path):
    m = trimesh.load(path, force="mesh")
    pairs = self_intersections(np.asarray(m.vertices), np.asarray(m.faces))
    return {
        "file": path,
        "triangles": int(len(m.faces)),
        "vertices": int(len(m.vertices)),
        "self_intersecting_pairs": len(pairs),
        "watertight": bool(m.is_watertight),
        "winding": bool(m.is_winding_consistent),
        "euler": int(m.euler_number),
        "lo": [float(v) for v in m.bounds[0]],
        "hi": [float(v) for v in m.bounds[1]],
        "volume": float(m.volume),
        "admesh": admesh(path),
    }


if __name__ == "__main__":
    for p in sys.argv[1:]:
        print(json.dumps(check(p)), flush=True)
