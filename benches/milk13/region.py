# benches/milk13/region.py OURS MAIN REF: pixels grouped by ours / main (all channels), each group's mean ours / ref and main / ref (the object's alpha >= 0.999).
import sys, numpy as np
sys.path.insert(0,'tools')
from compare_exr import load
from pathlib import Path
(a,_),(b,_),(r,ra) = (load(Path(p)) for p in sys.argv[1:4])
m = ra >= 0.999
q = a.mean(-1)/np.maximum(b.mean(-1),1e-9)
for lo,hi in [(0,0.95),(0.95,0.98),(0.98,1.02),(1.02,9)]:
    s = m & (q>=lo) & (q<hi)
    if s.sum()==0: continue
    print(f"ours/main in [{lo},{hi}): n {s.sum()} ours/ref {a[s].mean()/r[s].mean():.3f} main/ref {b[s].mean()/r[s].mean():.3f}")
