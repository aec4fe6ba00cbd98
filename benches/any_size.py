#!/usr/bin/env python3
"""Any-size decode of the photographs: does a decode at a larger size keep its quality?

    python3 benches/any_size.py [WORKDIR]

Each photograph in ../shared/photos is downscaled to half its size per side (Lanczos),
encoded by the release `caoen` at q50 and q75 at that size (`--resampling off`), and
then decoded two ways: by caoen at the full size (`--size`, the continuous layers
evaluated at the output positions) and at its coded size, upscaled with Lanczos. Both
are scored by RGB PSNR against the full-size photograph; the script prints, per
quality, the mean, smallest and largest difference (full-size decode minus upscale).
Needs Pillow and numpy.
"""
import glob
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTOS = os.path.join(ROOT, "..", "shared", "photos")
WORK = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp()
QUALITIES = [50, 75]


def psnr(a, b):
    mse = ((np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) ** 2).mean()
    return 10 * np.log10(255**2 / mse)


def caoen(*args):
    subprocess.run([CAOEN, *args, "-f", "--quiet"], check=True)


def main():
    os.makedirs(WORK, exist_ok=True)
    rows = []
    for path in sorted(glob.glob(os.path.join(PHOTOS, "*.png"))):
        name = os.path.basename(path)[:-4]
        full = Image.open(path).convert("RGB")
        w, h = full.size
        half = os.path.join(WORK, f"{name}-half.png")
        full.resize((w // 2, h // 2), Image.LANCZOS).save(half)
        for q in QUALITIES:
            cae = os.path.join(WORK, f"{name}-q{q}.cae")
            big = os.path.join(WORK, f"{name}-q{q}-full.png")
            small = os.path.join(WORK, f"{name}-q{q}-half.png")
            caoen("encode", half, "-q", str(q), "--resampling", "off", "-o", cae)
            caoen("decode", cae, "--size", f"{w}x{h}", "-o", big)
            caoen("decode", cae, "-o", small)
            direct = psnr(Image.open(big).convert("RGB"), full)
            upscaled = psnr(Image.open(small).convert("RGB").resize((w, h), Image.LANCZOS), full)
            rows.append((q, direct, upscaled))
    print("| quality | full-size decode dB | Lanczos upscale dB | difference: mean | smallest | largest |")
    print("|---|---|---|---|---|---|")
    for q in QUALITIES:
        r = [x for x in rows if x[0] == q]
        d = np.array([x[1] - x[2] for x in r])
        print(f"| {q} | {np.mean([x[1] for x in r]):.2f} | {np.mean([x[2] for x in r]):.2f} | "
              f"{d.mean():+.3f} | {d.min():+.3f} | {d.max():+.3f} |")


if __name__ == "__main__":
    main()
