"""What a global colour correction after caoen's decode would gain: per photograph and
quality, the 3x4 affine map of the decoded RGB (a colour matrix and an offset) that
brings it closest to the photograph by least squares, fitted on the even rows and
scored on the odd ones, as RGB PSNR added. Nothing is charged for its twelve numbers.
The restoration filters pass flat regions unchanged, so a plane's lost contrast or a
colour cast is left to this (docs/codec-ablation.md, "Levers estimated, not built").

    CAOEN=target/release/caoen python3 colour_gain.py [PHOTOS_DIR]
"""
import glob, os, subprocess, sys, tempfile
import numpy as np
from PIL import Image

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTOS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "photos")
QUALITIES = (20, 35, 50, 65)


def gain(original, decoded):
    h, w, _ = original.shape
    x = np.concatenate([decoded.reshape(-1, 3), np.ones((h * w, 1))], 1)
    t = original.reshape(-1, 3)
    even = (np.arange(h * w) // w) % 2 == 0
    m, *_ = np.linalg.lstsq(x[even], t[even], rcond=None)
    before = ((t - decoded.reshape(-1, 3)) ** 2)[~even].mean()
    after = ((t - x @ m) ** 2)[~even].mean()
    return 10 * np.log10(before / after), m


def main():
    work = tempfile.mkdtemp()
    cae, png = os.path.join(work, "t.cae"), os.path.join(work, "t.png")
    gains = {q: [] for q in QUALITIES}
    for photo in sorted(glob.glob(os.path.join(PHOTOS, "*.png"))):
        original = np.array(Image.open(photo).convert("RGB"), dtype=np.float64)
        line = os.path.basename(photo)
        for q in QUALITIES:
            subprocess.run([CAOEN, "--quiet", "encode", photo, "-q", str(q), "-o", cae, "-f"], check=True)
            subprocess.run([CAOEN, "--quiet", "decode", cae, "-o", png, "-f"], check=True)
            g, m = gain(original, np.array(Image.open(png).convert("RGB"), dtype=np.float64))
            gains[q].append(g)
            diagonal = " ".join(f"{m[c, c]:.3f}" for c in range(3))
            line += f"  q{q} {g:+.3f} dB (diagonal {diagonal})"
        print(line, flush=True)
    for q in QUALITIES:
        print(f"q{q}: mean {np.mean(gains[q]):+.3f} dB, largest {np.max(gains[q]):+.3f} dB")


if __name__ == "__main__":
    main()
