# panels.py OUT.png A.exr [B.exr ..]: the bunny front's ratio maps against the reference (red > 1, blue < 1, +-30%), the shadow classes of shadow.py (yellow lit, green cast shadow, blue attached; GEOM2 at target/bunny/geom2.npz) and the reference
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p),dtype=np.float64)
R=load('tests/reference/pt/bunny-marble-dir-eta1.exr'); a=R[...,3]; m=a>=0.999; r=R[...,:3].sum(-1)
g=np.load('target/bunny/geom2.npz'); L=-np.array([0.5,-1,-0.5]); L/=np.linalg.norm(L); nl=(g['nrm']*L).sum(-1); vis=g['vis']
ys,xs=np.nonzero(a>0); y0,y1,x0,x1=ys.min()-1,ys.max()+2,xs.min()-1,xs.max()+2
def ratio_img(o):
    ratio=np.where(a>0,o/np.maximum(r,1e-6),1); t=np.clip((ratio-1)/0.3,-1,1)
    img=np.zeros((96,96,3)); img[...,0]=0.5+0.5*np.clip(t,0,1); img[...,2]=0.5+0.5*np.clip(-t,0,1); img[...,1]=0.5*(1-np.abs(t)); img[a<=0]=0; img[(a>0)&~m]*=0.5
    return img
panels=[ratio_img(load(p)[...,:3].sum(-1)) for p in sys.argv[2:]]
cls=np.zeros((96,96,3)); cls[(a>0)&(nl>0)&(vis>0.5)]=[0.8,0.8,0.6]; cls[(a>0)&(nl>0)&(vis<0.5)]=[0.2,0.6,0.2]; cls[(a>0)&(nl<=0)]=[0.2,0.2,0.6]
refi=np.clip((R[...,:3]/np.percentile(R[...,:3][m],99))**(1/2.2),0,1)
panels+= [cls, refi]
sl=lambda x:x[y0:y1,x0:x1]
both=np.concatenate([sl(p) for p in panels],1); both=np.repeat(np.repeat(both,5,0),5,1)
mi.Bitmap((np.clip(both,0,1)*255).astype(np.uint8)).write(sys.argv[1])
