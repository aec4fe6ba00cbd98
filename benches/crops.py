#!/usr/bin/env python3
"""Zoomed crops of caoen beside WebP and AVIF at the same file size.

    python3 benches/crops.py [BPP] [WORKDIR]

Encodes three photographs of `../shared/photos` with the release `caoen` at
`--target-bpp BPP` (default 0.25), then WebP (`cwebp -m 6 -size`, the same byte count)
and AVIF (`avifenc` speed 6, 4:2:0, the largest quantiser setting whose file is no
larger than caoen's), decodes all three with their own decoders and writes
`docs/bench/crops.png`: a 160x120 crop of each at 3x with nearest-neighbour zoom, the
original first, with each file's size and RGB PSNR. Prints the table of sizes and
PSNRs. Needs Pillow, numpy, cwebp/dwebp and avifenc/avifdec.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
BPP = float(sys.argv[1]) if len(sys.argv) > 1 else 0.25
WORK = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp()
PHOTOS = os.path.join(ROOT, "..", "shared", "photos")
# (photo, crop centre): fine detail next to flat areas, where block edges show first.
CROPS = [("photo-030", (400, 250)), ("photo-014", (380, 260)), ("photo-042", (384, 256))]
SIDE, HEIGHT, ZOOM = 160, 120, 3


def run(*args):
    subprocess.run(list(args), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def psnr(a, b):
    mse = ((np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) ** 2).mean()
    return 10 * np.log10(255**2 / mse)


def avif_at_most(src, limit, out):
    """The best AVIF (lowest quantiser) no larger than `limit` bytes."""
    best = None
    lo, hi = 0, 63
    while lo <= hi:
        q = (lo + hi) // 2
        run("avifenc", "-s", "6", "-y", "420", "--min", str(q), "--max", str(q), src, out + ".try.avif")
        if os.path.getsize(out + ".try.avif") <= limit:
            best = q
            os.replace(out + ".try.avif", out)
            hi = q - 1
        else:
            lo = q + 1
    if best is None:
        raise SystemExit(f"no AVIF of {src} fits in {limit} bytes")
    return best


def main():
    rows = []
    print("| photo | codec | bytes | bpp | RGB PSNR dB |")
    print("|---|---|---|---|---|")
    for name, centre in CROPS:
        src = os.path.join(PHOTOS, name + ".png")
        original = Image.open(src).convert("RGB")
        w, h = original.size
        base = os.path.join(WORK, name)
        run(CAOEN, "--quiet", "encode", src, "--target-bpp", str(BPP), "-o", base + ".cae", "-f")
        run(CAOEN, "--quiet", "decode", base + ".cae", "-o", base + ".caoen.png", "-f")
        size = os.path.getsize(base + ".cae")
        run("cwebp", "-quiet", "-m", "6", "-size", str(size), src, "-o", base + ".webp")
        run("dwebp", "-quiet", base + ".webp", "-o", base + ".webp.png")
        avif_at_most(src, size, base + ".avif")
        run("avifdec", base + ".avif", base + ".avif.png")
        row = [("original", original, None)]
        for codec, coded, png in [("caoen", ".cae", ".caoen.png"), ("WebP", ".webp", ".webp.png"), ("AVIF", ".avif", ".avif.png")]:
            img = Image.open(base + png).convert("RGB")
            n = os.path.getsize(base + coded)
            p = psnr(original, img)
            print(f"| {name} | {codec} | {n} | {n * 8 / (w * h):.3f} | {p:.2f} |")
            row.append((f"{codec}: {n} B, {p:.2f} dB", img, None))
        rows.append((name, centre, row))
    pad, lab = 6, 16
    cw, ch = SIDE * ZOOM, HEIGHT * ZOOM
    out = Image.new("RGB", (4 * (cw + pad) + pad, len(rows) * (ch + pad + lab) + pad), "white")
    d = ImageDraw.Draw(out)
    for r, (name, (cx, cy), row) in enumerate(rows):
        for c, (label, img, _) in enumerate(row):
            box = (cx - SIDE // 2, cy - HEIGHT // 2, cx + SIDE // 2, cy + HEIGHT // 2)
            crop = img.crop(box).resize((cw, ch), Image.NEAREST)
            x, y = pad + c * (cw + pad), pad + r * (ch + pad + lab) + lab
            out.paste(crop, (x, y))
            d.text((x, y - lab + 2), f"{name} {label}", fill="black")
    target = os.path.join(ROOT, "docs", "bench", "crops.png")
    out.save(target)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
