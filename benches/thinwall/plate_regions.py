"""Where the back-lit plate's error is: ours / reference per region of the plate-on-base scene
(tests/reference/pt/plate-on-base-backlit-eta1.exr; camera 0,20,60:0,0,0:30, 96 px, light
dir:0.2,-0.35,1). The regions come from the geometry, not from row bands: each pixel centre's
camera ray is cast against the two boxes of tests/reference/pt/make_shapes.py (base x [-15,15]
y [-10,-6] z [-8,8], plate x [-10,10] y [-6,10] z [-1,1], mm, the object frame of
`--size-mm 30`), and the hit classified:
  plate face   the plate's front face (z = 1) more than FOOT_MM above the base
  plate foot   the plate's front face within FOOT_MM of the base's top
  base lit     the base's top that the light reaches (shadow ray misses the plate)
  base shadow  the base's top in the plate's shadow (lit only through the plate)
  base front   the base's front face (z = 8, facing away from the light)
  silhouettes  a pixel whose 3 x 3 neighbourhood holds background or a depth jump > 2 mm
  other        the plate's top and sides, the base's sides
Prints, per render, the relative RMS (all channels) over compare_exr.py's default mask (reference
alpha >= 0.999: the issue's metric), over alpha > 0.9 and over every covered pixel (alpha > 0);
then per region: pixels (in the issue's metric), ours / reference ratio of means R, G, B, and the
share of the squared error over every covered pixel and over the issue's metric. Optionally
writes a PNG strip (reference | each render | ratio of the first render, grey = 1, red > 1,
blue < 1) and a region map PNG.
Run with the Mitsuba venv's python (compare_exr.py's `load`):
  target/pt-venv/bin/python benches/thinwall/plate_regions.py REF.exr OURS.exr [MORE.exr..] \
      [--png OUT.png] [--regions-png MAP.png]"""
import sys, zlib, struct
from pathlib import Path
import numpy as np
sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
from compare_exr import load  # noqa: E402

EYE, TARGET, FOVY_DEG = np.array([0.0, 20.0, 60.0]), np.zeros(3), 30.0
BOXES = {"base": ((-15, -10, -8), (15, -6, 8)), "plate": ((-10, -6, -1), (10, 10, 1))}
LIGHT_TRAVEL = np.array([0.2, -0.35, 1.0])
BASE_TOP_Y = -6.0
FOOT_MM = 3.0  # the plate's bottom 3 mm: where ours darkened towards the base (rows ~56-63)
SILHOUETTE_JUMP_MM = 2.0  # a depth step larger than this between neighbours is an occluding edge
REGIONS = ["plate face", "plate foot", "base lit", "base shadow", "base front", "silhouettes", "other"]
COLOURS = {"plate face": (0.9, 0.8, 0.3), "plate foot": (0.9, 0.3, 0.2), "base lit": (0.3, 0.8, 0.3),
           "base shadow": (0.2, 0.4, 0.9), "base front": (0.6, 0.3, 0.8), "silhouettes": (1, 1, 1),
           "other": (0.5, 0.5, 0.5)}


def cast(o, d):
    """(distance, box name, outward normal) of the nearest box hit, or (inf, None, None)."""
    best = (np.inf, None, None)
    for name, (lo, hi) in BOXES.items():
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (np.array(lo, float) - o) / d
            t2 = (np.array(hi, float) - o) / d
        near, far = np.nanmax(np.minimum(t1, t2)), np.nanmin(np.maximum(t1, t2))
        if near <= far and far > 0 and near < best[0]:
            axis = int(np.nanargmax(np.minimum(t1, t2)))
            n = np.zeros(3)
            n[axis] = -np.sign(d[axis])
            best = (near, name, n)
    return best


def regions(w, h):
    forward = (TARGET - EYE) / np.linalg.norm(TARGET - EYE)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.radians(FOVY_DEG / 2))
    to_light = -LIGHT_TRAVEL / np.linalg.norm(LIGHT_TRAVEL)
    lab = np.full((h, w), "", dtype=object)
    depth = np.full((h, w), np.inf)
    for i in range(h):
        for j in range(w):
            d = forward + (2 * (j + 0.5) / w - 1) * half * w / h * right + (1 - 2 * (i + 0.5) / h) * half * up
            d /= np.linalg.norm(d)
            t, name, n = cast(EYE, d)
            if name is None:
                continue
            p = EYE + t * d
            depth[i, j] = t
            if name == "plate" and n[2] > 0.5:
                lab[i, j] = "plate face" if p[1] > BASE_TOP_Y + FOOT_MM else "plate foot"
            elif name == "base" and n[1] > 0.5:
                lab[i, j] = "base shadow" if cast(p + 1e-6 * n, to_light)[1] else "base lit"
            elif name == "base" and n[2] > 0.5:
                lab[i, j] = "base front"
            else:
                lab[i, j] = "other"
    covered = np.isfinite(depth)
    for i in range(h):
        for j in range(w):
            if not covered[i, j]:
                continue
            nb = depth[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2]
            if (~np.isfinite(nb)).any() or np.abs(nb - depth[i, j]).max() > SILHOUETTE_JUMP_MM:
                lab[i, j] = "silhouettes"
    return lab


def png(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\0" + (np.clip(row, 0, 1) * 255).astype(np.uint8).tobytes() for row in rgb)
    def chunk(k, data):
        return struct.pack(">I", len(data)) + k + data + struct.pack(">I", zlib.crc32(k + data))
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def rel_rms(ours, ref, m):
    return np.sqrt(((ours - ref) ** 2 * m[..., None]).sum() / (ref ** 2 * m[..., None]).sum())


args = [a for a in sys.argv[1:]]
opts = {}
for key in ("--png", "--regions-png"):
    if key in args:
        k = args.index(key); opts[key] = args[k + 1]; del args[k:k + 2]
ref, alpha = load(Path(args[0]))
h, w, _ = ref.shape
lab = regions(w, h)
if alpha is None:
    alpha = (ref.sum(-1) > 0).astype(float)
metric = alpha >= 0.999  # compare_exr.py's default mask: the metric
mostly = alpha > 0.9
mask = alpha > 0  # every covered pixel
tiles = [ref]
for f in args[1:]:
    ours, _ = load(Path(f))
    tiles.append(ours)
    print(f"{f}: relative RMS (all) {100 * rel_rms(ours, ref, metric):.1f}% over alpha >= 0.999 "
          f"({metric.sum()} px, the issue's metric), {100 * rel_rms(ours, ref, mostly):.1f}% over alpha > 0.9 "
          f"({mostly.sum()} px), {100 * rel_rms(ours, ref, mask):.1f}% over alpha > 0 ({mask.sum()} px)")
    err = ((ours - ref) ** 2 * mask[..., None]).sum()
    err_metric = ((ours - ref) ** 2 * metric[..., None]).sum()
    for name in REGIONS:
        m = mask & (lab == name)
        if not m.any():
            continue
        ratio = ours[m].mean(0) / np.maximum(ref[m].mean(0), 1e-12)
        share = ((ours[m] - ref[m]) ** 2).sum() / err
        share_metric = ((ours[m & metric] - ref[m & metric]) ** 2).sum() / err_metric
        print(f"  {name:12s} {m.sum():5d} px ({(m & metric).sum():4d} in the metric)  ours/ref "
              f"{ratio[0]:.2f} {ratio[1]:.2f} {ratio[2]:.2f}  share of squared error {100 * share:4.1f}% "
              f"(in the metric {100 * share_metric:4.1f}%)")
    uncovered = (lab == "") & mask
    if uncovered.any():
        print(f"  ({uncovered.sum()} reference pixels outside the cast geometry)")
if "--png" in opts:
    scale = 1 / np.percentile(ref[mask], 99)
    g = lambda x: np.clip(x * scale, 0, 1) ** (1 / 2.2)
    q = tiles[1].sum(-1) / np.maximum(ref.sum(-1), 1e-12)
    d = np.clip(q - 1, -0.5, 0.5)  # red: ours brighter, blue: darker, grey: within a few %
    rm = np.stack([0.5 + d, 0.5 - np.abs(d), 0.5 - d], -1) * mask[..., None]
    img = np.concatenate([g(t) for t in tiles] + [rm], 1)
    png(opts["--png"], np.repeat(np.repeat(img, 3, 0), 3, 1))
    print("wrote", opts["--png"])
if "--regions-png" in opts:
    img = np.zeros((h, w, 3))
    for name, c in COLOURS.items():
        img[lab == name] = c
    img *= np.where(metric, 1.0, 0.6)[..., None]  # dimmed: outside the metric
    png(opts["--regions-png"], np.repeat(np.repeat(img, 3, 0), 3, 1))
    print("wrote", opts["--regions-png"])
