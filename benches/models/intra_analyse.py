"""BD-rates of the intra-prediction model's sweeps: python3 intra_analyse.py target/intra-model/results_*.pkl."""
from intra_sim import bd_rate, psnr, H, W, NB
import pickle, numpy as np, sys
res = {}
for f in sys.argv[1:]:
    res.update(pickle.load(open(f, 'rb')))
npix = H * W
for s, R in res.items():
    A = R['A']; n = len(A[0]['bits'])
    rA = np.array([a['bits'].sum() for a in A]) / (n * npix)
    pA = np.array([psnr(a['sse'].sum(), n * npix) for a in A])
    print(f'\n=== sigma={s}  Q={[a["Q"] for a in A]}')
    print('A bpp ', rA.round(4)); print('A psnr', pA.round(2))
    for key in [k for k in R if k != 'A']:
        B = R[key]
        rB = np.array([b['bits'].sum() for b in B]) / (n * npix)
        rBf = np.array([b['bits_fixedmode'].sum() for b in B]) / (n * npix)
        pB = np.array([psnr(b['sse'].sum(), n * npix) for b in B])
        bd_p = bd_rate(rA, pA, rB, pB, 'pchip'); bd_c = bd_rate(rA, pA, rB, pB, 'cubic')
        bd_f = bd_rate(rA, pA, rBf, pB, 'pchip')
        # per photo
        per = []
        for i in range(n):
            ra = np.array([a['bits'][i] for a in A]) / npix; pa = psnr(np.array([a['sse'][i] for a in A]), npix)
            rb = np.array([b['bits'][i] for b in B]) / npix; pb = psnr(np.array([b['sse'][i] for b in B]), npix)
            per.append(bd_rate(ra, pa, rb, pb, 'pchip'))
        per = np.array(per)
        # per-Q rate savings at (nearly) equal Q
        print(f'{key:11s} BD pchip {bd_p:6.2f}%  cubic {bd_c:6.2f}%  (fixed log2(M) mode bits: {bd_f:6.2f}%)  '
              f'per-photo [{per.min():.2f}, {per.max():.2f}] median {np.median(per):.2f}')
        print(f'            B bpp {rB.round(4)}  psnr {pB.round(2)}  mode-bits bpp {np.array([b["mbits"].sum() for b in B]).round(0)/(n*npix)}')
        print(f'            per-photo BD: {per.round(1)}')
        for j in (0, len(B) - 1):
            print(f'            modes @Q={B[j]["Q"]:.0f}: ' + ' '.join(f'{nm}:{fr*100:.1f}%' for nm, fr in zip(B[j]['names'], B[j]['frac'])))
