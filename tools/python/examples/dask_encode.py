#!/usr/bin/env python3
"""Encode a folder of images on a Dask cluster, one task per file.

    python dask_encode.py IN_DIR OUT_DIR [--scheduler ADDRESS] [--workers N] [-q Q] [-e E]

Without ``--scheduler`` a ``LocalCluster`` of N worker processes runs on this machine;
with it, the workers of a running cluster do the work, and IN_DIR and OUT_DIR must be
on storage every worker sees at the same paths. Each task encodes one file with
``caoen.encode_file`` exactly as ``caoen encode`` does, so OUT_DIR ends up with the
same files, the same names and the same bytes as ``caoen encode IN_DIR -o OUT_DIR``.
Dask schedules; the dashboard (its link is printed) shows the tasks' progress.
Outputs are written whole (a temporary file renamed into place); ``--resume`` skips
outputs that are already whole ``.cae`` files, and an existing output is otherwise
replaced only with ``--force``. A file that fails is reported and the rest go on; the
exit code is 1 if any failed.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import List, Optional, Tuple


def encode_one(src: str, dst: str, quality: float, effort: Optional[int]) -> Tuple[int, int]:
    """The task: encode ``src`` into ``dst``; returns (bytes in, bytes out)."""
    import caoen

    Path(dst).parent.mkdir(parents=True, exist_ok=True)
    data = caoen.encode_file(src, dst, quality=quality, effort=effort)
    return os.path.getsize(src), len(data)


def is_complete(path: Path) -> bool:
    """Whether ``path`` is a whole .cae file (every section, every CRC), as --resume asks."""
    import caoen

    try:
        caoen.info(path.read_bytes())
        return True
    except (OSError, caoen.CaoenError):
        return False


def inputs(root: Path, out: Path) -> List[Path]:
    """The images under ``root`` as ``caoen encode DIR`` finds them, in name order."""
    import caoen

    out_real = out.resolve() if out.exists() else None
    found = []
    for dirpath, dirnames, filenames in os.walk(root):
        here = Path(dirpath)
        # The output folder is not an input when it lies inside the input's tree.
        dirnames[:] = [
            d for d in dirnames if here / d == root or (here / d).resolve() != out_real
        ]
        for name in filenames:
            path = here / name
            if path.is_file() and caoen.is_image_name(path):
                found.append(path.relative_to(root))
    return sorted(found)


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", type=Path, help="folder of images")
    parser.add_argument("output", type=Path, help="folder to write the .cae files into")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("-q", "--quality", type=float, default=75.0, help="quality 0..100")
    parser.add_argument("-e", "--effort", type=int, default=None, help="effort 1..9")
    parser.add_argument("--resume", action="store_true", help="skip outputs already whole")
    parser.add_argument("-f", "--force", action="store_true", help="replace existing outputs")
    args = parser.parse_args(argv)

    from dask.distributed import Client, LocalCluster, as_completed, progress

    if not args.input.is_dir():
        parser.error(f"{args.input}: not a folder")
    args.output.mkdir(parents=True, exist_ok=True)
    rels = inputs(args.input, args.output)
    import caoen

    jobs, failed, skipped = [], [], 0
    for rel in rels:
        dst = args.output / caoen.output_name(rel)
        if dst.exists() and args.resume and is_complete(dst):
            skipped += 1
        elif dst.exists() and not args.force:
            failed.append(f"{dst}: exists; pass --force to overwrite it")
        else:
            jobs.append((str(args.input / rel), str(dst)))

    cluster = None
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        # One thread per worker process: each encode uses every core of its machine.
        cluster = LocalCluster(
            n_workers=args.workers, threads_per_worker=1, dashboard_address=":0"
        )
        client = Client(cluster)
    print(f"dashboard: {client.dashboard_link}", flush=True)
    start = time.perf_counter()
    try:
        futures = client.map(
            encode_one,
            [s for s, _ in jobs],
            [d for _, d in jobs],
            quality=args.quality,
            effort=args.effort,
            pure=False,
        )
        if sys.stderr.isatty():
            progress(futures)
        done = bytes_in = bytes_out = 0
        for future in as_completed(futures):
            try:
                i, o = future.result()
                done, bytes_in, bytes_out = done + 1, bytes_in + i, bytes_out + o
            except Exception as e:  # noqa: BLE001 - each task's failure is reported
                failed.append(str(e))
                print(f"error: {e}", file=sys.stderr, flush=True)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    seconds = time.perf_counter() - start
    print(
        f"encoded {done} of {len(rels)} files ({skipped} already complete, "
        f"{len(failed)} failed): {bytes_in} bytes -> {bytes_out} bytes in {seconds:.2f} s",
        file=sys.stderr,
    )
    for f in failed:
        print(f"failed: {f}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
