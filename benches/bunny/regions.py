# Squared-error share of ours vs reference by region of the bunny (geom.npz from geometry.py).
# usage: regions.py OURS.exr REF.exr GEOM.npz LIGHT_DIR [PNG_PREFIX] (ears: y > 6 mm)
import sys, numpy as np, mitsuba as mi, math
mi.set_variant('scalar_rgb')
def load(p):
    b=np.array(mi.Bitmap(p),dtype=np.float64); return b[...,:3], (b[...,3] if b.shape[2]>3 else None)
ours,_=load(sys.argv[1]); ref,alpha=load(sys.argv[2]); g=np.load(sys.argv[3])
L=-np.array([float(v) for v in sys.argv[4].split(',')]); L/=np.linalg.norm(L)
nrm,pos,H,thick=g['nrm'],g['pos'],g['H'],g['thick']
eye=np.array([0,20,60.]); view=eye-pos; view/=np.maximum(np.linalg.norm(view,axis=-1,keepdims=True),1e-9)
nl=(nrm*L).sum(-1); nv=(nrm*view).sum(-1)
a=ours.sum(-1); r=ref.sum(-1)
def table(mask, title):
    m=mask
    err=((ours-ref)**2).sum(-1); tot=err[m].sum(); refsq=(ref**2).sum(-1)[m].sum()
    print(f"== {title}: {m.sum()} px, rel rms {100*math.sqrt(tot/refsq):.2f}%")
    return m, err, tot, refsq
def rows(m, err, tot, refsq, groups):
    print(f"  {'region':34s} {'px':>5s} {'ours/ref':>8s} {'err2 share':>10s} {'rms if perfect':>14s}")
    for name,gm in groups:
        s=m&gm
        if s.sum()==0: continue
        e=err[s].sum()
        print(f"  {name:34s} {s.sum():5d} {a[s].sum()/r[s].sum():8.3f} {e/tot:10.3f} {100*math.sqrt((tot-e)/refsq):13.2f}%")
strict=alpha>=0.999
m,err,tot,refsq=table(strict,"metric mask alpha>=0.999")
# rim: fully covered pixels next to a partly covered one
part=alpha<0.999
nb=np.zeros_like(part)
for dy in (-1,0,1):
    for dx in (-1,0,1): nb|=np.roll(np.roll(part,dy,0),dx,1)
rim=strict&nb
nb2=rim.copy()
for dy in (-1,0,1):
    for dx in (-1,0,1): nb2|=np.roll(np.roll(rim,dy,0),dx,1)
rim2=strict&nb2&~rim
ys,xs=np.mgrid[0:96,0:96]
ear=(pos[...,1]>g['ear_y']) if 'ear_y' in g else (pos[...,1]>6.0)
peak=r[strict].max()
groups=[("rim (next to alpha<0.999)",rim),("second ring",rim2),("interior (rest)",strict&~rim&~rim2),
 ("ears (y>6mm)",ear),("body (y<=6mm)",~ear),
 ("lit n.l>0.3",nl>0.3),("n.l 0..0.3",(nl>0)&(nl<=0.3)),("unlit n.l<=0",nl<=0),
 ("view cos<0.3",nv<0.3),("view cos 0.3..0.6",(nv>=0.3)&(nv<0.6)),("view cos>=0.6",nv>=0.6),
 ("concave H<-0.1",H<-0.1),("flat |H|<=0.1",np.abs(H)<=0.1),("H 0.1..0.3",(H>0.1)&(H<=0.3)),("H 0.3..0.6",(H>0.3)&(H<=0.6)),("H>0.6",H>0.6),
 ("thick<4mm",thick<4),("thick 4..8",(thick>=4)&(thick<8)),("thick>=8",thick>=8),
 ("ref<0.2 peak",r<0.2*peak),("ref 0.2..0.5",(r>=0.2*peak)&(r<0.5*peak)),("ref 0.5..0.8",(r>=0.5*peak)&(r<0.8*peak)),("ref>=0.8 peak",r>=0.8*peak)]
rows(m,err,tot,refsq,groups)
for thr,name in ((0.9,"alpha>0.9"),(0.0,"alpha>0 (coverage)")):
    mm,e2,t2,r2=table(alpha>thr if thr>0 else alpha>0, name)
    rows(mm,e2,t2,r2,[("alpha<0.999 part",alpha<0.999),("alpha>=0.999 part",alpha>=0.999)])
if len(sys.argv)>5:
    pre=sys.argv[5]
    ratio=np.where(alpha>0, a/np.maximum(r,1e-6),0)
    # ratio map: 1 -> grey, >1 red, <1 blue; range 0.5..1.5
    t=np.clip((ratio-1)/0.5,-1,1)
    img=np.zeros((96,96,3)); img[...,0]=0.5+0.5*np.clip(t,0,1); img[...,2]=0.5+0.5*np.clip(-t,0,1); img[...,1]=0.5*(1-np.abs(t)); img[alpha<=0]=0
    img[(alpha>0)&~strict]*=0.6
    d=(a-r)/peak; t=np.clip(d/0.15,-1,1)
    img2=np.zeros((96,96,3)); img2[...,0]=np.clip(t,0,1); img2[...,2]=np.clip(-t,0,1); img2[...,1]=0
    img2[(alpha>0)&(np.abs(t)<0.02)]=0.15
    both=np.concatenate([img,img2],1)
    both=np.repeat(np.repeat(both,4,0),4,1)
    mi.Bitmap((np.clip(both,0,1)*255).astype(np.uint8)).write(pre+'-ratio-diff.png')
