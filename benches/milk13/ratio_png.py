# benches/milk13/ratio_png.py OURS MAIN REF OUT.png: ours / main (0.9..1.1), main / ref, ours / ref (0.8..1.2; blue low, red high), the reference and ours tone-mapped, 3x (target/pt-venv/bin/python).
import sys, numpy as np
sys.path.insert(0,'tools')
from compare_exr import load
from pathlib import Path
import mitsuba as mi; mi.set_variant("scalar_rgb")
(a,_),(b,_),(r,ra) = (load(Path(p)) for p in sys.argv[1:4])
m = ra >= 0.999
def img(q, lo, hi):
    t = np.clip((q - lo)/(hi-lo), 0, 1)
    out = np.zeros(q.shape+(3,)); out[...,0]=t; out[...,2]=1-t; out[...,1]=1-abs(2*t-1)
    out[~m]=0
    return out
q1 = a.mean(-1)/np.maximum(b.mean(-1),1e-9)
q2 = a.mean(-1)/np.maximum(r.mean(-1),1e-9)
q3 = b.mean(-1)/np.maximum(r.mean(-1),1e-9)
tone = lambda x: np.clip(x/ (np.percentile(r[m].mean(-1),99)),0,1)**(1/2.2)
row = np.concatenate([img(q1,0.9,1.1), img(q3,0.8,1.2), img(q2,0.8,1.2), tone(r), tone(a)], axis=1)
row = np.kron(row, np.ones((3,3,1)))

mi.util.write_bitmap(sys.argv[4], mi.Bitmap((row*255).astype(np.uint8)))
