"""Per-photograph BD-rate of codec B against codec A in one rate window, by RGB PSNR and
by luma PSNR, from a `caoen bench --report` JSON:

    python3 window_bd.py REPORT.json A B LO_BPP HI_BPP

The window is placed on A's curve (the PSNR range A spans between LO and HI bpp), as the
bench's window figures are; each curve is first reduced to its frontier.
"""
import json, sys, numpy as np
from scipy.interpolate import PchipInterpolator
r=json.load(open(sys.argv[1])); A, Bc = sys.argv[2], sys.argv[3]
lo_bpp, hi_bpp = float(sys.argv[4]), float(sys.argv[5])
def curve(img, c, key):
    pts=sorted((m['bpp'], m[key]) for m in r['measurements'] if m['image']==img and m['codec']==c and m[key] is not None)
    return np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
def bd(ra, pa, rb, pb):
    # window on A's curve in bpp
    fa = PchipInterpolator(np.log(ra), pa)
    plo, phi = fa(np.log(max(lo_bpp, ra.min()))), fa(np.log(min(hi_bpp, ra.max())))
    # frontier monotone
    ia = np.argsort(pa); ib = np.argsort(pb)
    ga = PchipInterpolator(np.maximum.accumulate(pa[ia]) + np.arange(len(ia))*1e-9, np.log(ra[ia]))
    gb = PchipInterpolator(np.maximum.accumulate(pb[ib]) + np.arange(len(ib))*1e-9, np.log(rb[ib]))
    lo, hi = max(plo, pb.min()), min(phi, pb.max())
    if hi - lo < 0.05: return None
    xs = np.linspace(lo, hi, 100)
    return (np.exp(np.mean(gb(xs) - ga(xs))) - 1) * 100
imgs = sorted({m['image'] for m in r['measurements']})
for key in ['psnr', 'psnr_y']:
    vals = []
    for img in imgs:
        v = bd(*curve(img, A, key), *curve(img, Bc, key)); vals.append(v)
    print(key, ' '.join('%s:%s' % (i[6:9], 'na' if v is None else '%+.1f' % v) for i, v in zip(imgs, vals)), 'mean %+.1f' % np.mean([v for v in vals if v is not None]))
