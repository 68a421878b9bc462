import sys, numpy as np
sys.path.insert(0,'tools')
from compare_exr import load
from pathlib import Path
(ours,_), (main,_), (ref,ra) = (load(Path(p)) for p in sys.argv[1:4])
m = ra >= 0.999
o, b, r = ours[m].mean(1), main[m].mean(1), ref[m].mean(1)
peak = r.max()
for name, sel in [("dim <0.2 peak", r < 0.2*peak), ("0.2-0.5", (r>=0.2*peak)&(r<0.5*peak)), ("0.5-0.8", (r>=0.5*peak)&(r<0.8*peak)), (">=0.8", r>=0.8*peak)]:
    print(f"{name}: n {sel.sum()} ours/ref {o[sel].mean()/r[sel].mean():.3f} main/ref {b[sel].mean()/r[sel].mean():.3f} rms ours {np.sqrt(((o[sel]-r[sel])**2).mean())/r.mean():.4f} main {np.sqrt(((b[sel]-r[sel])**2).mean())/r.mean():.4f}")
q = o/b
print("ours/main ratio percentiles 1,10,50,90,99:", np.percentile(q,[1,10,50,90,99]))
