#!/usr/bin/env python3
"""What a CDEF-like deringing filter (AV1's constrained directional enhancement) would
add to caoen's decodes: each 8x8 block's direction from the decoded luma's structure
tensor, the primary taps along it and the secondary ones at 45 degrees, each
difference constrained by AV1's function (damping 6), one strength pair per image
chosen by the luma PSNR against the photograph, nothing charged for it. BT.601 luma
of 8-bit decodes (docs/codec-ablation.md, "Levers estimated, not built").

    python3 cdef_gain.py DECODES PHOTOS
"""
import glob
import os

import numpy as np
from PIL import Image
def y(a): return a@np.array([0.299,0.587,0.114])
# AV1 CDEF directions: offsets (dy,dx) for k=1,2 per direction 0..7
DIRS=[[(-1,1),(-2,2)],[(0,1),(-1,2)],[(0,1),(0,2)],[(0,1),(1,2)],[(1,1),(2,2)],[(1,0),(2,1)],[(1,0),(2,0)],[(1,0),(2,-1)]]
def shift(a,dy,dx):
    h,w=a.shape
    p=np.pad(a,2,mode='edge')
    return p[2+dy:2+dy+h,2+dx:2+dx+w]
def directions(img):
    # per 8x8 block: direction minimizing variance along lines (approximate: use smoothed gradient structure tensor)
    gy,gx=np.gradient(img)
    h,w=img.shape; H,W=h//8,w//8
    def bs(a): return a[:H*8,:W*8].reshape(H,8,W,8).sum(axis=(1,3))
    jxx,jyy,jxy=bs(gx*gx),bs(gy*gy),bs(gx*gy)
    # orientation of edge (perpendicular to gradient)
    theta=0.5*np.arctan2(2*jxy,jxx-jyy)  # gradient angle
    edge=theta+np.pi/2
    coh=np.sqrt((jxx-jyy)**2+4*jxy**2)/(jxx+jyy+1e-9)
    # map edge angle (y down) to 8 directions: dir 2 = horizontal (0,1), dir 6 vertical, dir0 = up-right 45 deg, dir4 = down-right
    # angle a = atan2(dy,dx) of direction vector with y down; dir2: a=0; dir0: a=-45; dir4: +45; dir6: 90; dir1 ~ -22.5; dir3 ~ 22.5; dir5 ~ 67.5; dir7 ~ 112.5
    a=np.degrees(np.arctan2(np.sin(edge),np.cos(edge)))  # -180..180
    a=np.mod(a,180)  # 0..180 (undirected)
    # dir angles
    da={2:0,3:26.6,4:45,5:63.4,6:90,7:116.6,0:135,1:153.4}
    best=np.zeros(a.shape,int); bd=np.full(a.shape,1e9)
    for d,ang in da.items():
        dd=np.minimum(np.abs(a-ang),180-np.abs(a-ang))
        m=dd<bd; best[m]=d; bd[m]=dd[m]
    return best,coh
def constrain(diff,s,damp):
    if s==0: return np.zeros_like(diff)
    sh=max(0,damp-int(np.floor(np.log2(s))))
    return np.sign(diff)*np.minimum(np.abs(diff),np.maximum(0,s-np.abs(diff)/2**sh))
def cdef(img,pri,sec,damp=6,blockdir=None):
    h,w=img.shape; H,W=h//8,w//8
    d,coh=blockdir
    dmap=np.kron(d,np.ones((8,8),int))
    full=np.zeros((h,w),int); full[:H*8,:W*8]=dmap; 
    out=np.zeros_like(img)
    pw=[4/16,2/16]; sw=[2/16,1/16]
    for dd in range(8):
        m=(full==dd)
        if not m.any(): continue
        acc=np.zeros_like(img)
        for k in range(2):
            for sgn in (1,-1):
                oy,ox=DIRS[dd][k]; acc+=pw[k]*constrain(shift(img,sgn*oy,sgn*ox)-img,pri,damp)
                for s2 in ((dd+2)%8,(dd-2)%8):
                    oy,ox=DIRS[s2][k]; acc+=sw[k]*constrain(shift(img,sgn*oy,sgn*ox)-img,sec,damp)
        out[m]=acc[m]
    return img+out

def main():
    import argparse
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("decodes", help="folder of caoen decodes named PHOTO-Q.png, each beside its PHOTO-Q.cae")
    ap.add_argument("photos", help="folder of the photographs, photo-PHOTO.png")
    a = ap.parse_args()
    tot = {}
    for f in sorted(glob.glob(os.path.join(a.decodes, "*.png"))):
        p, q = os.path.basename(f)[:-4].split("-")
        o = y(np.asarray(Image.open(os.path.join(a.photos, f"photo-{p}.png")).convert("RGB")).astype(float))
        d = y(np.asarray(Image.open(f).convert("RGB")).astype(float))
        bd = directions(d)
        e0 = ((d - o) ** 2).mean()
        best = (0, 0, 0)
        for pri in (1, 2, 3, 4, 6, 8):
            for sec in (0, 1, 2, 4):
                c = cdef(d, pri, sec, 6, bd)
                g = 10 * np.log10(e0 / ((c - o) ** 2).mean())
                if g > best[0]:
                    best = (g, pri, sec)
        bpp = os.path.getsize(f[:-4] + ".cae") * 8 / o.size
        print(p, q, f"{bpp:.3f} bpp", f"{10 * np.log10(255 ** 2 / e0):.2f} dB, gain {best[0]:.3f} dB at primary {best[1]}, secondary {best[2]}", flush=True)
        tot.setdefault(q, []).append(best[0])
    for q, v in sorted(tot.items()):
        print(f"q{q}: mean gain {np.mean(v):.3f} dB")


if __name__ == "__main__":
    main()
