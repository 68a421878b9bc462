# A CPU diffusion render plus the GPU frame's single scattering (default - `--single-scattering
# off`), the relative RMS against a reference (alpha >= 0.999, all channels), as compare_exr.py's
# `all`. usage: add_ss.py CPU_DIFFUSION GPU_DEF GPU_NOSS REF
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), (b[..., 3] if b.shape[2] > 3 else None)
cpu, _ = load(sys.argv[1]); d, _ = load(sys.argv[2]); n, _ = load(sys.argv[3]); ref, alpha = load(sys.argv[4])
m = alpha >= 0.999; img = cpu + d - n
rel = lambda a: np.sqrt(((a[m] - ref[m]) ** 2).sum() / (ref[m] ** 2).sum())
per = [np.sqrt(((img[m][:, c] - ref[m][:, c]) ** 2).sum() / (ref[m][:, c] ** 2).sum()) for c in range(3)]
print(f"CPU diffusion + GPU single scattering: R {per[0]:.4f} G {per[1]:.4f} B {per[2]:.4f}; all {rel(img):.4f}; mean ours/ref {img[m].sum()/ref[m].sum():.3f}")
