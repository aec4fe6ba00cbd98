#!/usr/bin/env python3
"""Tile edges of a camera-size photo: are they visible?

    python3 benches/tile_edges.py [PHOTO.jpg] [WORKDIR]

Encodes the photo with the release `caoen` at several qualities, decodes it, and prints
per quality the mean squared error of the whole image, of the pixels on either side of
every tile edge, and of the pixels on either side of the 32-pixel root edges inside the
tiles (what any block edge costs). Writes `docs/bench/tile-edges.png`: 128x128 crops
centred on two tile corners, zoomed 3x, beside the original (red ticks mark the tile
lines). Needs Pillow and numpy.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTO = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "large", "012mp-bus.jpg")
WORK = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp()
os.makedirs(WORK, exist_ok=True)
QUALITIES = [20, 50, 75, 90]
TILE = 512
CORNERS = [(2048, 1024), (2560, 512)]


def edge_mask(h, w, period, keep):
    xs = [x for t in range(period, w, period) if keep(t) for x in (t - 1, t)]
    ys = [y for t in range(period, h, period) if keep(t) for y in (t - 1, t)]
    m = np.zeros((h, w), dtype=bool)
    m[:, xs] = True
    m[ys, :] = True
    return m


def main():
    # One decode of the JPEG for everyone: caoen reads this PNG, the errors are against it.
    original = Image.open(PHOTO).convert("RGB")
    source = os.path.join(WORK, "source.png")
    original.save(source, compress_level=1)
    a = np.asarray(original, dtype=np.float64)
    h, w, _ = a.shape
    tiles = edge_mask(h, w, TILE, lambda t: True)
    roots = edge_mask(h, w, 32, lambda t: t % TILE != 0)
    decoded = {}
    print("| quality | bpp | PSNR dB | MSE image | MSE tile edges | ratio | MSE root edges inside tiles | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for q in QUALITIES:
        cae = os.path.join(WORK, f"q{q}.cae")
        png = os.path.join(WORK, f"q{q}.png")
        # At its own size: the measure is of the tiles' edges in the coded image.
        subprocess.run(
            [CAOEN, "encode", source, "-q", str(q), "--resampling", "off", "-o", cae, "-f", "--quiet"], check=True
        )
        subprocess.run([CAOEN, "decode", cae, "-o", png, "-f", "--quiet"], check=True)
        img = Image.open(png).convert("RGB")
        decoded[q] = img
        se = ((a - np.asarray(img, dtype=np.float64)) ** 2).mean(axis=2)
        m, e, r = se.mean(), se[tiles].mean(), se[roots].mean()
        bpp = os.path.getsize(cae) * 8 / (w * h)
        print(f"| {q} | {bpp:.3f} | {10 * np.log10(255**2 / m):.2f} | {m:.3f} | {e:.3f} | {e / m:.3f} | {r:.3f} | {r / m:.3f} |")
    columns = [("original", original)] + [(f"caoen q{q}", decoded[q]) for q in (20, 50, 75)]
    s, z, pad, lab = 128, 3, 6, 18
    out = Image.new("RGB", (len(columns) * (s * z + pad) + pad, len(CORNERS) * (s * z + pad + lab) + pad), "white")
    d = ImageDraw.Draw(out)
    for r, (cx, cy) in enumerate(CORNERS):
        for c, (name, img) in enumerate(columns):
            crop = img.crop((cx - s // 2, cy - s // 2, cx + s // 2, cy + s // 2)).resize((s * z, s * z), Image.NEAREST)
            x, y = pad + c * (s * z + pad), pad + r * (s * z + pad + lab) + lab
            out.paste(crop, (x, y))
            d.text((x, y - lab + 2), f"{name}, tile corner ({cx},{cy}) at the centre", fill="black")
            m = s // 2 * z
            for t in ((x + m, y - 4, x + m, y), (x + m, y + s * z, x + m, y + s * z + 4),
                      (x - 4, y + m, x, y + m), (x + s * z, y + m, x + s * z + 4, y + m)):
                d.line(t, fill="red", width=2)
    target = os.path.join(ROOT, "docs", "bench", "tile-edges.png")
    out.save(target)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
