# How much of the error depends on the lattice (wave 11): renders of the same scene at several
# --resolution; prints each error, the error of their mean image, and the pairwise differences.
# usage: lattice.py REF.exr OURS.exr.. ; optional SEED.exr (same scene, another seed, SPP2 spp) via
# NOISE=SEED.exr:SPP:SPP2 prints the reference's own noise n = rms(diff) / sqrt(1 + SPP / SPP2).
import sys, os, math, itertools, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p), dtype=np.float64)
R = load(sys.argv[1]); m = R[..., 3] >= 0.999; ref = R[..., :3]; refsq = (ref ** 2).sum(-1)[m].sum()
rms = lambda x: 100 * math.sqrt((x ** 2).sum(-1)[m].sum() / refsq)
if os.environ.get('NOISE'):
    p, spp, spp2 = os.environ['NOISE'].split(':')
    d = rms(load(p)[..., :3] - ref); print(f"reference noise: {d / math.sqrt(1 + float(spp) / float(spp2)):.2f}% (difference {d:.2f}%)")
ims = {p: load(p)[..., :3] for p in sys.argv[2:]}
for p, x in ims.items(): print(f"{p}: {rms(x - ref):.2f}%")
mean = sum(ims.values()) / len(ims)
pair = [rms(ims[a] - ims[b]) for a, b in itertools.combinations(ims, 2)]
print(f"mean image of {len(ims)}: {rms(mean - ref):.2f}%; pairwise difference {np.mean(pair):.2f}% (one lattice's own part ~{np.mean(pair) / math.sqrt(2):.2f}%)")
