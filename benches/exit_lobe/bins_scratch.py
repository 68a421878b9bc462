import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b=np.array(mi.Bitmap(p)); return b[...,:3].astype(float), (b[...,3] if b.shape[2]>3 else None)
ours,_=load(sys.argv[1]); ref,alpha=load(sys.argv[2])
L=np.array([float(x) for x in sys.argv[3].split(',')]); L=-L/np.linalg.norm(L)  # direction to light
eye=np.array([0,20,60.]); fwd=-eye/np.linalg.norm(eye); up=np.array([0,1,0.]); right=np.cross(fwd,up); right/=np.linalg.norm(right); up=np.cross(right,fwd)
h,w=ref.shape[:2]; t=np.tan(np.radians(30)/2); R=10.0
res=[]
for j in range(h):
  for i in range(w):
    if alpha is not None and alpha[j,i]<0.999: continue
    x=(2*(i+.5)/w-1)*t; y=(1-2*(j+.5)/h)*t
    d=fwd+x*right+y*up; d/=np.linalg.norm(d)
    b=np.dot(eye,d); c=np.dot(eye,eye)-R*R; disc=b*b-c
    if disc<0: continue
    s=-b-np.sqrt(disc); p=eye+s*d; n=p/R
    res.append((np.dot(n,L), -np.dot(n,d), ours[j,i].sum(), ref[j,i].sum()))
a=np.array(res)
print("n.l bin     count  ours/ref  relerr^2-share")
tot=((a[:,2]-a[:,3])**2).sum()
for lo in np.arange(-1,1,0.2):
  m=(a[:,0]>=lo)&(a[:,0]<lo+0.2)
  if m.sum()==0: continue
  print(f"{lo:+.1f}..{lo+.2:+.1f} {m.sum():5d} {a[m,2].sum()/a[m,3].sum():.3f} {((a[m,2]-a[m,3])**2).sum()/tot:.3f}")
print("view cos bins")
for lo in np.arange(0,1,0.2):
  m=(a[:,1]>=lo)&(a[:,1]<lo+0.2)
  if m.sum()==0: continue
  print(f"{lo:.1f}..{lo+.2:.1f} {m.sum():5d} {a[m,2].sum()/a[m,3].sum():.3f} {((a[m,2]-a[m,3])**2).sum()/tot:.3f}")
print("2D: rows n.l bins, cols view-cos bins (ratio, count)")
for lo in np.arange(-0.6,1,0.2):
  row=[]
  for vo in np.arange(0,1,0.2):
    m=(a[:,0]>=lo)&(a[:,0]<lo+0.2)&(a[:,1]>=vo)&(a[:,1]<vo+0.2)
    row.append(f"{a[m,2].sum()/a[m,3].sum():.3f}({m.sum():3d})" if m.sum()>5 else "     -     ")
  print(f"{lo:+.1f} "+" ".join(row))
