"""Upper bound of what a linear restoration filter on caoen's decoded luma would gain: for
each photograph and quality, 7x7 filters that bring the decoded BT.601 luma closest to the
original's by least squares, and the luma PSNR they add. With `K` classes, each 64x64
region takes the best of `K` filters or none (regions start in classes by activity, then
filters and choices are refitted four times). Nothing is charged for the taps or the
choices.

    CAOEN=target/release/caoen python3 restoration_gain.py [PHOTOS_DIR] [K]
"""
import glob, os, subprocess, sys, tempfile
import numpy as np
from PIL import Image

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTOS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "photos")
CLASSES = int(sys.argv[2]) if len(sys.argv) > 2 else 1
QUALITIES = (30, 50, 70)
RADIUS = 3
REGION = 64
ROUNDS = 4


def luma(path):
    a = np.array(Image.open(path).convert("RGB"), dtype=np.float64)
    return 0.299 * a[..., 0] + 0.587 * a[..., 1] + 0.114 * a[..., 2]


def gain(original, decoded):
    h, w = decoded.shape
    pad = np.pad(decoded, RADIUS, mode="edge")
    taps = np.stack([pad[RADIUS + dy:RADIUS + dy + h, RADIUS + dx:RADIUS + dx + w].ravel()
                     for dy in range(-RADIUS, RADIUS + 1) for dx in range(-RADIUS, RADIUS + 1)], 1)
    target, plain = original.ravel(), decoded.ravel()
    cols = (w + REGION - 1) // REGION
    region = ((np.arange(h) // REGION)[:, None] * cols + (np.arange(w) // REGION)[None, :]).ravel()
    regions = region.max() + 1
    gy, gx = np.gradient(decoded)
    activity = np.bincount(region, weights=(np.abs(gy) + np.abs(gx)).ravel(), minlength=regions)
    cls = np.minimum(np.argsort(np.argsort(activity)) * CLASSES // regions, CLASSES - 1)
    unfiltered = np.bincount(region, weights=(target - plain) ** 2, minlength=regions)
    for _ in range(ROUNDS):
        errors = []
        for k in range(CLASSES):
            rows = cls[region] == k
            if rows.sum() < taps.shape[1] * 4:
                errors.append(unfiltered)
                continue
            coef, *_ = np.linalg.lstsq(taps[rows], target[rows], rcond=None)
            errors.append(np.bincount(region, weights=(target - taps @ coef) ** 2, minlength=regions))
        errors = np.stack(errors + [unfiltered], 1)
        best = np.argmin(errors, 1)
        # A region that takes no filter keeps its class for the next fit.
        cls = np.where(best == CLASSES, cls, best)
    after = errors[np.arange(regions), best].sum()
    return 10 * np.log10(unfiltered.sum() / after)


def main():
    work = tempfile.mkdtemp()
    cae, png = os.path.join(work, "t.cae"), os.path.join(work, "t.png")
    gains = {q: [] for q in QUALITIES}
    for photo in sorted(glob.glob(os.path.join(PHOTOS, "*.png"))):
        original = luma(photo)
        for q in QUALITIES:
            subprocess.run([CAOEN, "--quiet", "encode", photo, "-q", str(q), "-o", cae, "-f"], check=True)
            subprocess.run([CAOEN, "--quiet", "decode", cae, "-o", png, "-f"], check=True)
            g = gain(original, luma(png))
            gains[q].append(g)
            print(f"{os.path.basename(photo)} q{q}: +{g:.3f} dB", file=sys.stderr, flush=True)
    print(f"{CLASSES} filter(s) per image, chosen per {REGION}x{REGION} region" if CLASSES > 1 else "1 filter per image")
    for q in QUALITIES:
        print(f"q{q}: mean +{np.mean(gains[q]):.3f} dB, largest +{np.max(gains[q]):.3f} dB")
    print(f"all: mean +{np.mean([g for v in gains.values() for g in v]):.3f} dB")


if __name__ == "__main__":
    main()
