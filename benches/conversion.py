#!/usr/bin/env python3
"""Mesh-to-implicit conversion at the defaults, beside the RBF baseline.

    python3 benches/conversion.py OUT_DIR [MESH ...]

Without meshes: the closed meshes of ../shared/models, the full-resolution Stanford
bunny, and the bunny subdivided twice (about 1.1 million triangles, made here with
trimesh's midpoint subdivision, not stored). Each mesh is converted with the release
binary (`caoen convert MESH -o MODEL.json --json`) under `/usr/bin/time -v`, then the
RBF baseline (`caoen deviation MESH --rbf N --json`, N = the model's functions, at most
3000) is measured with the same deviation code, and, where N was capped, caoen again
at a budget matched to the baseline's stored numbers (closed, as the baseline is).
Prints the Markdown table of
docs/conversion.md and writes OUT_DIR/conversion.json. Needs an idle machine for the
times to mean anything; the CPU column is the steadier figure.
"""

import json
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
MODELS = os.path.join(ROOT, "..", "shared", "models")
DEFAULT = ["spot.obj", "cow.obj", "fandisk.obj", "fertility.off", "stanford-bunny.obj"]


def timed(args):
    """Runs args under GNU time: (stdout, wall s, user+sys s, peak MiB)."""
    t0 = time.time()
    p = subprocess.run(["/usr/bin/time", "-v"] + args, capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n{p.stderr[-2000:]}")

    def field(name):
        m = re.search(name + r": ([0-9.]+)", p.stderr)
        return float(m.group(1)) if m else float("nan")

    cpu = field("User time \\(seconds\\)") + field("System time \\(seconds\\)")
    return p.stdout, wall, cpu, field("Maximum resident set size \\(kbytes\\)") / 1024


def subdivided_bunny(out):
    """The Stanford bunny subdivided twice, as PLY."""
    path = os.path.join(out, "bunny-subdivided-1m.ply")
    if not os.path.exists(path):
        import trimesh

        m = trimesh.load(os.path.join(MODELS, "stanford-bunny.obj"), process=False)
        v, f = m.vertices, m.faces
        for _ in range(2):
            v, f = trimesh.remesh.subdivide(v, f)
        trimesh.Trimesh(v, f, process=False).export(path)
    return path


def row(name, method, size, wall, cpu, mib, d):
    dev = d["deviation"] if "deviation" in d else d
    t = f"{wall:.0f} s / {cpu:.1f} s" if cpu == cpu else f"{wall:.1f} s"
    m = f"{mib:.0f} MiB" if mib == mib else ""
    return (
        f"| {name} | {method} | {size} | {t} | {m} | "
        f"{dev['vertex_distance']['mean']:.5f} | {dev['vertex_distance']['max']:.4f} | "
        f"{dev['normal_angle_deg']['mean']:.2f} | {dev['normal_angle_deg']['max']:.1f} | "
        f"{100 * dev['depth']['mean_all_pixels']:.3f}% | "
        f"{100 * dev['depth']['mean_both_cover']:.3f}% | {100 * dev['depth']['mean']:.3f}% |"
    )


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    meshes = sys.argv[2:] or [os.path.join(MODELS, m) for m in DEFAULT] + [subdivided_bunny(out)]
    lines = [
        "| mesh | method | size | time (wall / CPU) | peak memory | vertex distance mean | max "
        "| normal angle mean (deg) | max | depth, all pixels | depth, both see | depth, either sees |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    results = []
    for mesh in meshes:
        name = os.path.splitext(os.path.basename(mesh))[0]
        model = os.path.join(out, name + ".json")
        print(f"{name}: converting", file=sys.stderr, flush=True)
        text, wall, cpu, mib = timed([BIN, "--quiet", "convert", mesh, "-o", model, "-f", "--json"])
        c = json.loads(text)
        n = c["functions"]
        # A shell with openings stores its cutters too: 9 numbers a triangle.
        with open(model) as f:
            cutters = f.read().count('"polygon"')
        how = c["open"]["handled_as"]
        method = "caoen" if how == "solid" else f"caoen, {how}"
        size = f"{n} functions" + (f" and {cutters} cutters" if cutters else "")
        lines.append(row(name, method, f"{size} ({5 * n + 5 + 9 * cutters} numbers)", wall, cpu, mib, c))
        centres = min(n, 3000)
        print(f"{name}: RBF baseline, {centres} centres", file=sys.stderr, flush=True)
        text, wall, cpu, mib = timed([BIN, "--quiet", "deviation", mesh, "--rbf", str(centres), "--json"])
        r = json.loads(text)
        lines.append(row("", "RBF", f"{r['size']} numbers", wall, cpu, mib, r))
        entry = {"mesh": name, "caoen": c, "rbf": r}
        if centres < n:
            # The same fit at the baseline's stored numbers (5 a function, 10 the base),
            # closed as the baseline is: cutters would add numbers the budget does not count.
            matched = max(1, (r["size"] - 5) // 5)
            print(f"{name}: caoen at {matched} functions", file=sys.stderr, flush=True)
            text, wall, cpu, mib = timed(
                [BIN, "--quiet", "convert", mesh, "-o", model, "-f", "--json",
                 "--max-functions", str(matched), "--holes", "close"]
            )
            m = json.loads(text)
            lines.append(
                row("", "caoen, matched", f"{m['functions']} functions ({5 * m['functions'] + 5} numbers)",
                    wall, cpu, mib, m)
            )
            entry["matched"] = m
        results.append(entry)
        print("\n".join(lines[-3:]), file=sys.stderr, flush=True)
    with open(os.path.join(out, "conversion.json"), "w") as f:
        json.dump(results, f, indent=1)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
