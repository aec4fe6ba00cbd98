"""Upper bound of what a linear restoration filter on caoen's decoded luma would gain: for
each photograph and quality, the 7x7 filter that minimises the squared error of the
decoded BT.601 luma against the original's (one least-squares fit per image, no cost for
its taps), and the luma PSNR it adds.

    CAOEN=target/release/caoen python3 restoration_gain.py [PHOTOS_DIR]
"""
import glob, os, subprocess, sys, tempfile
import numpy as np
from PIL import Image

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTOS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "photos")
QUALITIES = (30, 50, 70)
RADIUS = 3


def luma(path):
    a = np.array(Image.open(path).convert("RGB"), dtype=np.float64)
    return 0.299 * a[..., 0] + 0.587 * a[..., 1] + 0.114 * a[..., 2]


def gain(original, decoded):
    h, w = decoded.shape
    pad = np.pad(decoded, RADIUS, mode="edge")
    taps = [pad[RADIUS + dy:RADIUS + dy + h, RADIUS + dx:RADIUS + dx + w].ravel()
            for dy in range(-RADIUS, RADIUS + 1) for dx in range(-RADIUS, RADIUS + 1)]
    a = np.stack(taps, 1)
    coef, *_ = np.linalg.lstsq(a, original.ravel(), rcond=None)
    before = np.mean((original - decoded) ** 2)
    after = np.mean((original.ravel() - a @ coef) ** 2)
    return 10 * np.log10(before / after)


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
    for q in QUALITIES:
        print(f"q{q}: mean +{np.mean(gains[q]):.3f} dB, largest +{np.max(gains[q]):.3f} dB")
    print(f"all: mean +{np.mean([g for v in gains.values() for g in v]):.3f} dB")


if __name__ == "__main__":
    main()
