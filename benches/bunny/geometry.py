# Per-pixel geometry of the bunny as the references see it (usage: geometry.py SURFACE.obj OUT.npz REF.exr;
# SURFACE.obj from `translucent bake --mesh ../shared/meshes/stanford-bunny.obj --size-mm 20 --export DIR`):
# position, shading normal, thickness along -n, mean curvature (cotangent Laplacian at the nearest vertex).
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
obj=sys.argv[1]; out=sys.argv[2]; W=96
eye=[0,20,60]; 
scene=mi.load_dict({'type':'scene','integrator':{'type':'aov','aovs':'pp:position,nn:sh_normal'},
 'sensor':{'type':'perspective','fov_axis':'y','fov':30,'to_world':mi.ScalarTransform4f().look_at(origin=eye,target=[0,0,0],up=[0,1,0]),
   'sampler':{'type':'independent','sample_count':64},'film':{'type':'hdrfilm','width':W,'height':W,'pixel_format':'rgba','rfilter':{'type':'box'}}},
 'object':{'type':'obj','filename':obj,'face_normals':False}})
img=np.array(mi.render(scene))
print(img.shape)
# channels: R,G,B,A, pp xyz, nn xyz
ref=np.array(mi.Bitmap(sys.argv[3]),dtype=np.float64); alpha=ref[...,3]; pos=img[...,0:3]; nrm=img[...,3:6]
cov=np.maximum(alpha,1e-9)
pos=pos/cov[...,None]; nrm=nrm/cov[...,None]
nl=np.linalg.norm(nrm,axis=-1,keepdims=True); nrm=nrm/np.maximum(nl,1e-9)
# mesh curvature
V=[];F=[]
for line in open(obj):
    if line.startswith('v '): V.append([float(x) for x in line.split()[1:4]])
    elif line.startswith('f '): F.append([int(x.split('/')[0])-1 for x in line.split()[1:4]])
V=np.array(V);F=np.array(F)
L=np.zeros_like(V); area=np.zeros(len(V)); vn=np.zeros_like(V)
for k in range(3):
    i,j,m=F[:,k],F[:,(k+1)%3],F[:,(k+2)%3]
    a=V[i]-V[m]; b=V[j]-V[m]
    cot=(a*b).sum(1)/np.maximum(np.linalg.norm(np.cross(a,b),axis=1),1e-12)
    np.add.at(L,i,cot[:,None]*(V[j]-V[i])); np.add.at(L,j,cot[:,None]*(V[i]-V[j]))
fn=np.cross(V[F[:,1]]-V[F[:,0]],V[F[:,2]]-V[F[:,0]]); fa=np.linalg.norm(fn,axis=1)/2
for k in range(3): np.add.at(area,F[:,k],fa/3); np.add.at(vn,F[:,k],fn)
vn/=np.maximum(np.linalg.norm(vn,axis=1,keepdims=True),1e-12)
# Laplace-Beltrami = L/(2A) ; = -2 H n  (H>0 convex with outward n)
Hv=-(L/(2*np.maximum(area,1e-12))[:,None]*vn).sum(1)/2
# smooth a bit: mean over one-ring twice
for _ in range(6):
    acc=np.zeros(len(V)); cnt=np.zeros(len(V))
    for k in range(3):
        for kk in range(3):
            np.add.at(acc,F[:,k],Hv[F[:,kk]]); np.add.at(cnt,F[:,k],1)
    Hv=acc/cnt
H=np.full(alpha.shape,np.nan); thick=np.full(alpha.shape,np.nan)
ys,xs=np.nonzero(alpha>0)
P=pos[ys,xs]
for s in range(0,len(P),512):
    d=((P[s:s+512,None,:]-V[None,:,:])**2).sum(-1)
    idx=d.argmin(1); H[ys[s:s+512],xs[s:s+512]]=Hv[idx]
import math
eyev=np.array(eye,float); fwd=-eyev/np.linalg.norm(eyev); up=np.array([0,1.,0]); right=np.cross(fwd,up); right/=np.linalg.norm(right); up=np.cross(right,fwd)
t=math.tan(math.radians(15))
for y,x in zip(ys,xs):
    d=fwd+(2*(x+.5)/W-1)*t*right+(1-2*(y+.5)/W)*t*up; d/=np.linalg.norm(d)
    si=scene.ray_intersect(mi.Ray3f(mi.Point3f(*eyev),mi.Vector3f(*d)))
    if not si.is_valid(): continue
    n=np.array(si.sh_frame.n); p=np.array(si.p)
    if np.dot(n,d)>0: n=-n
    si2=scene.ray_intersect(mi.Ray3f(mi.Point3f(*(p-n*1e-4)),mi.Vector3f(*(-n))))
    thick[y,x]=si2.t if si2.is_valid() else np.inf
np.savez(out,alpha=alpha,pos=pos,nrm=nrm,H=H,thick=thick)
print('H percentiles',np.nanpercentile(H[alpha>0.999],[5,25,50,75,95]))
print('thick percentiles',np.nanpercentile(thick[alpha>0.999],[5,25,50,75,95]))
