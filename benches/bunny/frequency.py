# The error split by spatial frequency (Gaussian low pass of sigma px, masked) and the high-pass
# correlation with the reference. usage: frequency.py REF.exr OURS.exr..
import sys, numpy as np, mitsuba as mi, math
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p),dtype=np.float64)
refp=sys.argv[1]; R=load(refp); m=R[...,3]>=0.999; cov=(R[...,3]>0).astype(float); ref=R[...,:3]
def blur(x,s):
    k=np.arange(-int(3*s),int(3*s)+1); g=np.exp(-k**2/(2*s*s)); g/=g.sum()
    for ax in (0,1):
        x=np.apply_along_axis(lambda v: np.convolve(v,g,'same'),ax,x)
    return x
def lp(img,s):
    w=blur(cov,s); return np.stack([blur(img[...,c]*cov,s)/np.maximum(w,1e-9) for c in range(3)],-1)
refsq=(ref[m]**2).sum()
for p in sys.argv[2:]:
    o=load(p)[...,:3]; d=o-ref
    out=[f"{p.split('/')[-1]}: all {100*math.sqrt((d[m]**2).sum()/refsq):.2f}"]
    for s in (1.0,2.0,4.0):
        dl=lp(o,s)-lp(ref,s); dh=d-dl
        out.append(f"s{s:g}: low {100*math.sqrt((dl[m]**2).sum()/refsq):.2f} high {100*math.sqrt((dh[m]**2).sum()/refsq):.2f}")
    print('  '.join(out))
print("hf energy (s=2) relative to image rms, and correlation of hf with the reference's hf")
hr=ref-lp(ref,2.0)
for p in sys.argv[1:]:
    o=load(p)[...,:3]; h=o-lp(o,2.0)
    print(f"{p.split('/')[-1]}: hf {100*math.sqrt((h[m]**2).sum()/refsq):.2f}  corr {((h*hr)[m].sum()/math.sqrt((h[m]**2).sum()*(hr[m]**2).sum())):.3f}")
