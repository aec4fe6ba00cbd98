"""Sweeps the intra-prediction model (intra_sim.py): python3 intra_run.py [SIGMAS] [QS], writing
the workspace's target/intra-model/results_SIGMAS.pkl for intra_analyse.py."""
import os
from intra_sim import *
import pickle
MODESETS = {
  'full9': ['none','DC','H','V','A45','A67.5','A112.5','A135','planar'],
  'HV':    ['none','H','V'],
  'ext11': ['none','DC','H','V','A45','A67.5','A112.5','A135','A157.5','A202.5','planar'],
}
VARIANTS = [('full9', False), ('HV', False), ('full9', True), ('HV', True), ('ext11', False)]
QS = [float(q) for q in sys.argv[2].split(',')] if len(sys.argv) > 2 else [12, 20, 34, 56, 90, 150]
sigmas = [int(x) for x in sys.argv[1].split(',')] if len(sys.argv) > 1 else [4, 8]
Ms = {k: pred_matrix(v) for k, v in MODESETS.items()}
out = {}
for s in sigmas:
    D = load(s); Db = to_blocks(D); n = D.shape[0]; npix_img = H * W
    res = {'A': [], **{f'{ms}{"_orig" if o else ""}': [] for ms, o in VARIANTS}}
    for Q in QS:
        lam = Q * Q / 6.0
        levA, sseA = codec_A(Db, Q)
        bitsA = empirical_bits_per_image(levA) + NB
        res['A'].append(dict(Q=Q, bits=bitsA, sse=sseA))
        tabA = cost_table(counts_of(levA))[BAND]
        for ms, o in VARIANTS:
            t0 = time.time()
            M = Ms[ms]; nm = M.shape[0]
            lev, mo, sse = codec_B(D, Q, M, tabA, np.full(nm, np.log2(nm)), lam, orig_ref=o)
            frac1 = np.bincount(mo.ravel(), minlength=nm) / mo.size
            tab2 = cost_table(counts_of(lev))[BAND]
            mc = -np.log2((np.bincount(mo.ravel(), minlength=nm) + 0.5) / (mo.size + 0.5 * nm))
            lev, mo, sse = codec_B(D, Q, M, tab2, mc, lam, orig_ref=o)
            cbits = empirical_bits_per_image(lev)
            mbits = mode_bits_per_image(mo, nm)
            bits = cbits + mbits + NB
            frac = np.bincount(mo.ravel(), minlength=nm) / mo.size
            key = f'{ms}{"_orig" if o else ""}'
            res[key].append(dict(Q=Q, bits=bits, sse=sse, cbits=cbits, mbits=mbits,
                                 bits_fixedmode=cbits + NB * np.log2(nm) + NB,
                                 frac=frac, frac_pass1=frac1, names=MODESETS[ms]))
            print(f's={s} Q={Q:5.0f} {key:11s} A: {bitsA.sum()/(n*npix_img):.4f}bpp {psnr(sseA.sum(), n*npix_img):.3f}dB | '
                  f'B: {bits.sum()/(n*npix_img):.4f}bpp (modes {mbits.sum()/(n*npix_img):.4f}) {psnr(sse.sum(), n*npix_img):.3f}dB  [{time.time()-t0:.1f}s]', flush=True)
    out[s] = res
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'target', 'intra-model')
os.makedirs(OUT, exist_ok=True)
pickle.dump(out, open(f'{OUT}/results_{"_".join(map(str,sigmas))}.pkl', 'wb'))
