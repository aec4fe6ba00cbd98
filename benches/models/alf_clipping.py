#!/usr/bin/env python3
"""What clipping the restoration filter's differences (the nonlinear adaptive loop
filter of VVC) would add to caoen's linear restoration filters. Each file's
restoration section is removed and the file decoded again; on its BT.601 luma,
least-squares filters on caoen's 7x7 diamond are fitted to the photograph, one per
image or one per pixel class (activity octile by direction), with the differences
f(p + d) - f(p) as they are or clipped to +-C (C from 64 down to 4, 8-bit units, the
best per image), nothing charged for the taps (docs/codec-ablation.md, "Levers
estimated, not built").

    python3 alf_clipping.py FILES PHOTOS [CAOEN]

FILES holds caoen files named PHOTO-Q.cae; PHOTOS the photographs, photo-PHOTO.png.
"""
import glob
import os
import struct
import subprocess
import tempfile

import numpy as np
from PIL import Image
def y(a): return a@np.array([0.299,0.587,0.114])
SH=[(1,0),(2,0),(3,0),(-2,1),(-1,1),(0,1),(1,1),(2,1),(-1,2),(0,2),(1,2),(0,3)]
def sh(a,dx,dy):
    h,w=a.shape; p=np.pad(a,3,mode='edge'); return p[3+dy:3+dy+h,3+dx:3+dx+w]
def classes(f):
    # crude: activity quantised by local laplacian energy (8 levels) x direction (5)
    lv=np.abs(2*f-sh(f,0,-1)-sh(f,0,1)); lh=np.abs(2*f-sh(f,-1,0)-sh(f,1,0))
    from scipy.ndimage import uniform_filter
    V=uniform_filter(lv,5); Hh=uniform_filter(lh,5)
    act=V+Hh
    a=np.digitize(act,np.quantile(act,[.125,.25,.375,.5,.625,.75,.875]))
    d=np.where(V>2*Hh,1,np.where(Hh>2*V,2,0))
    return a*3+d
def fit(feats,t,cls):
    gain=0; out=np.zeros_like(t)
    for c in np.unique(cls):
        m=cls==c
        X=feats[:,m].T; tt=t[m]
        A=X.T@X+1e-3*np.eye(X.shape[1]); w=np.linalg.solve(A,X.T@tt)
        # split-half honesty not modelled; charge nothing
        out[m]=X@w
    return out


def without_restoration(data):
    """The file with its restoration section left out (sections: tag, length, payload, CRC)."""
    out, i = bytearray(data[:5]), 5
    while i < len(data):
        n = struct.unpack("<I", data[i + 1:i + 5])[0]
        end = i + 5 + n + 4
        if data[i] != ord("R"):
            out += data[i:end]
        i = end
    return bytes(out)


def main():
    import sys
    files, photos = sys.argv[1], sys.argv[2]
    caoen = sys.argv[3] if len(sys.argv) > 3 else "target/release/caoen"
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for f in sorted(glob.glob(os.path.join(files, "*.cae"))):
            n = os.path.basename(f)[:-4]
            p, q = n.split("-")
            cae, png = os.path.join(tmp, "plain.cae"), os.path.join(tmp, "plain.png")
            with open(f, "rb") as src, open(cae, "wb") as dst:
                dst.write(without_restoration(src.read()))
            subprocess.run([caoen, "--quiet", "decode", cae, "-o", png, "-f"], check=True)
            o = y(np.asarray(Image.open(os.path.join(photos, f"photo-{p}.png")).convert("RGB")).astype(float))
            d = y(np.asarray(Image.open(png).convert("RGB")).astype(float))
            t = o - d
            e0 = (t ** 2).mean()
            cls = classes(d)
            row = []
            for clip in (None, 64, 32, 16, 8, 4):
                feats = []
                for dx, dy in SH:
                    a, b = sh(d, dx, dy) - d, sh(d, -dx, -dy) - d
                    if clip:
                        a, b = np.clip(a, -clip, clip), np.clip(b, -clip, clip)
                    feats.append((a + b).ravel())
                feats = np.array(feats)
                one = 10 * np.log10(e0 / ((t.ravel() - fit(feats, t.ravel(), np.zeros(t.size, int))) ** 2).mean())
                by_class = 10 * np.log10(e0 / ((t.ravel() - fit(feats, t.ravel(), cls.ravel())) ** 2).mean())
                row.append((one, by_class))
            r = np.array(row)
            print(n, "linear %.3f / %.3f dB" % tuple(r[0]), "clipped %.3f / %.3f dB (one filter / by class)" % (r[:, 0].max(), r[:, 1].max()), flush=True)
            res.setdefault(q, []).append((r[0, 0], r[0, 1], r[:, 0].max(), r[:, 1].max()))
    for q in sorted(res):
        m = np.mean(res[q], axis=0)
        print(f"q{q}: one filter {m[0]:.3f} -> {m[2]:.3f} dB clipped; by class {m[1]:.3f} -> {m[3]:.3f} dB")


if __name__ == "__main__":
    main()
