"""What filters chosen by pixel class would add to caoen's decoded luma, on top of what
the file already restores: for each photograph and quality, least-squares filters on
the 12-tap luma diamond, one per class, bring the decoded BT.601 luma closest to the
original's, and the luma PSNR they add is printed for five classings: one class; 5 and
8 activity levels; 5 and 8 activity levels by 5 directions (none, across columns,
across rows, the two diagonals), from second differences summed over 5x5 windows as
`codec/caoen-decoder/src/restoration/mod.rs` classifies. Nothing is charged for the taps.

    CAOEN=target/release/caoen python3 restoration_classes.py [PHOTOS_DIR]
"""
import glob, os, subprocess, sys, tempfile
import numpy as np
from PIL import Image
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CAOEN = os.environ.get("CAOEN", os.path.join(ROOT, "target", "release", "caoen"))
PHOTOS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "photos")
WORK = tempfile.mkdtemp()
SHAPE=[(1,0),(2,0),(3,0),(0,1),(0,2),(0,3),(1,1),(-1,1),(2,1),(-2,1),(1,2),(-1,2)]
def luma(p):
    a=np.array(Image.open(p).convert("RGB"),dtype=np.float64)
    return 0.299*a[...,0]+0.587*a[...,1]+0.114*a[...,2]
def regress(f):
    h,w=f.shape; R=3; p=np.pad(f,R,mode="edge")
    g=lambda dx,dy: p[R+dy:R+dy+h,R+dx:R+dx+w]
    return np.stack([(g(dx,dy)+g(-dx,-dy)-2*f).ravel() for dx,dy in SHAPE],1)
def box(a,r):
    c=np.pad(a,r,mode="edge").cumsum(0).cumsum(1); c=np.pad(c,((1,0),(1,0)))
    n=2*r+1; h,w=a.shape
    return c[n:n+h,n:n+w]-c[:h,n:n+w]-c[n:n+h,:w]+c[:h,:w]
def classes(f, na, dirs):
    p=np.pad(f,1,mode="edge"); c=p[1:-1,1:-1]
    v=np.abs(2*c-p[:-2,1:-1]-p[2:,1:-1]); hh=np.abs(2*c-p[1:-1,:-2]-p[1:-1,2:])
    d1=np.abs(2*c-p[:-2,:-2]-p[2:,2:]); d2=np.abs(2*c-p[:-2,2:]-p[2:,:-2])
    gv,gh,g1,g2=[box(x,2) for x in (v,hh,d1,d2)]
    act=gv+gh
    # activity classes by fixed log thresholds (per 25-pixel window sum of 8-bit laplacians)
    th=np.array([8,20,45,100,220,480,1000])[:na-1] if na>1 else np.array([])
    A=np.searchsorted(th,act)
    if not dirs: return A.ravel()
    hv=np.maximum(gv,gh)/(np.minimum(gv,gh)+1e-9); dd=np.maximum(g1,g2)/(np.minimum(g1,g2)+1e-9)
    D=np.zeros(f.shape,int)
    ishv=(hv>dd)&(hv>2); isd=(dd>=hv)&(dd>2)
    D[ishv&(gh>gv)]=1; D[ishv&(gh<=gv)]=2; D[isd&(g1>g2)]=3; D[isd&(g1<=g2)]=4
    return (A*5+D).ravel()
def fitgain(X,t,cls,n):
    tot=0
    for k in range(n):
        m=cls==k
        if m.sum()<200: continue
        Xk,tk=X[m],t[m]
        A=Xk.T@Xk; b=Xk.T@tk; A+=np.eye(A.shape[0])*1e-4*np.trace(A)/A.shape[0]+1e-9
        wv=np.linalg.solve(A,b); tot+=2*wv@b-wv@(Xk.T@Xk)@wv
    return tot
res={}
print("luma dB added: 1 class, 5 levels, 8 levels, 5 levels x 5 directions, 8 x 5", flush=True)
for photo in sorted(glob.glob(PHOTOS+"/*.png")):
    o=luma(photo); name=os.path.basename(photo)[:-4]
    for q in (30,50,70):
        png=f"{WORK}/{name}-{q}.png"
        if not os.path.exists(png):
            cae=f"{WORK}/{name}-{q}.cae"
            subprocess.run([CAOEN,"--quiet","encode",photo,"-q",str(q),"-o",cae,"-f"],check=True)
            subprocess.run([CAOEN,"--quiet","decode",cae,"-o",png,"-f"],check=True)
        d=luma(png); X=regress(d); t=(o-d).ravel(); e0=(t*t).sum()
        out=[]
        for na,dirs in ((1,False),(5,False),(8,False),(5,True),(8,True)):
            cls=classes(d,na,dirs); n=na*5 if dirs else na
            g=fitgain(X,t,cls,n); out.append(10*np.log10(e0/(e0-g)))
        res.setdefault(q,[]).append(out)
        print(name,q," ".join(f"{x:.3f}" for x in out),flush=True)
for q,v in res.items(): print(q,"mean"," ".join(f"{x:.3f}" for x in np.mean(v,0)))
