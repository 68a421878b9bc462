"""Middle band (rows 44..51) of ours / reference, pooled in 8-px column groups over fully covered pixels."""
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
Ld = lambda p: np.array(mi.Bitmap(p), dtype=np.float64)
import os
ref = Ld(sys.argv[1]); r0 = int(os.environ.get("ROW0", 44)); rows = slice(r0, r0 + 8); AL = float(os.environ.get("ALPHA", 0.999))
R = ref[rows]; m = R[..., 3] >= AL
print('cols    ', ' '.join(f'{c:>14d}' for c in range(0, 96, 8)))
print('ref R   ', ' '.join(f'{R[:, c:c+8, 0][m[:, c:c+8]].mean() if m[:, c:c+8].sum() > 8 else float("nan"):14.5f}' for c in range(0, 96, 8)))
for f in sys.argv[2:]:
    A = Ld(f)[rows]; out = []
    for c in range(0, 96, 8):
        mm = m[:, c:c+8]
        if mm.sum() > 8:
            r = A[:, c:c+8, :3][mm].mean(0) / R[:, c:c+8, :3][mm].mean(0); out.append('/'.join(f'{x:.2f}' for x in r))
        else: out.append('-')
    print(f'{f:18s}', ' '.join(f'{o:>14s}' for o in out))
