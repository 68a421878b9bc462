# Relief of a display mesh finer than a radius (mm): the area-weighted mean angle between vertex
# normals and their average within the radius (the Rust surface_relief_degrees). usage: relief.py RADIUS_MM SURFACE.obj..
import sys, numpy as np
def load(obj):
    V=[];F=[]
    for line in open(obj):
        if line.startswith('v '): V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith('f '): F.append([int(x.split('/')[0])-1 for x in line.split()[1:4]])
    return np.array(V),np.array(F)
for obj in sys.argv[2:]:
    V,F=load(obj); r=float(sys.argv[1])
    fn=np.cross(V[F[:,1]]-V[F[:,0]],V[F[:,2]]-V[F[:,0]]); 
    vn=np.zeros_like(V); area=np.zeros(len(V))
    for k in range(3): np.add.at(vn,F[:,k],fn); np.add.at(area,F[:,k],np.linalg.norm(fn,axis=1)/6)
    vn/=np.maximum(np.linalg.norm(vn,axis=1,keepdims=True),1e-12)
    dev=np.zeros(len(V))
    for s in range(0,len(V),256):
        d=((V[s:s+256,None,:]-V[None,:,:])**2).sum(-1)
        w=np.clip(1-d/(r*r),0,None)**2*((vn[s:s+256]@vn.T)>0)
        ns=w@vn; ns/=np.maximum(np.linalg.norm(ns,axis=1,keepdims=True),1e-12)
        dev[s:s+256]=1-(ns*vn[s:s+256]).sum(1)
    ang=np.degrees(np.arccos(np.clip(1-dev,-1,1)))
    A=area.sum()
    order=np.argsort(ang); median=ang[order][np.searchsorted(np.cumsum(area[order]),A/2)]
    print(f"{obj}: {len(V)} v, area-weighted median {median:.2f} deg (the Rust surface_relief_degrees), mean {(area*ang).sum()/A:.2f}")
