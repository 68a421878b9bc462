"""Where the back-lit plate's error is: ours / reference per region of the plate-on-base scene
(tests/reference/pt/plate-on-base-backlit-eta1.exr; camera 0,20,60:0,0,0:30, 96 px), the regions
found by casting each pixel's ray at the two boxes of make_shapes.py (the plate 20 x 16 x 2 mm on
the 30 x 4 x 16 mm base, centred). Edge pixels (a region change within one pixel) are their own
region. Prints per region: pixels, ratio of means R, G, B, and the share of the squared error
(sum over the region of (ours - ref)^2 / sum over all of it). Optionally writes a PNG strip
(reference | each render | ratio of the first render, grey = 1, red > 1, blue < 1).
Run with the Mitsuba venv's python (compare_exr.py's `load`):
  target/pt-venv/bin/python benches/thinwall/plate_regions.py REF.exr OURS.exr [MORE.exr..] [--png OUT.png]"""
import sys, zlib, struct
from pathlib import Path
import numpy as np
sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
from compare_exr import load  # noqa: E402

BOXES = {"plate": ((-10, -6, -1), (10, 10, 1)), "base": ((-15, -10, -8), (15, -6, 8))}
EYE, TARGET, FOVY = np.array([0.0, 20.0, 60.0]), np.zeros(3), 30.0


def regions(w, h):
    f = TARGET - EYE; f /= np.linalg.norm(f)
    r = np.cross(f, [0.0, 1.0, 0.0]); r /= np.linalg.norm(r); u = np.cross(r, f)
    t = np.tan(np.radians(FOVY) / 2)
    j, i = np.mgrid[0:h, 0:w]
    x = ((i + 0.5) / w * 2 - 1) * t * w / h; y = (1 - (j + 0.5) / h * 2) * t
    d = f + x[..., None] * r + y[..., None] * u; d /= np.linalg.norm(d, axis=-1, keepdims=True)
    best = np.full((h, w), np.inf); label = np.full((h, w), "", dtype=object)
    for name, (lo, hi) in BOXES.items():
        lo, hi = np.array(lo, float), np.array(hi, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = (lo - EYE) / d; t1 = (hi - EYE) / d
        tn = np.minimum(t0, t1); tf = np.maximum(t0, t1)
        near = tn.max(-1); far = tf.min(-1); axis = tn.argmax(-1)
        hit = (near <= far) & (near > 0) & (near < best)
        sign = np.where(np.take_along_axis(d, axis[..., None], -1)[..., 0] > 0, "-", "+")
        face = np.char.add(np.char.add(sign.astype(str), np.array(["x", "y", "z"])[axis]), "")
        best = np.where(hit, near, best)
        label = np.where(hit, np.char.add(name + " ", face), label)
    names = {"plate +z": "plate face (camera side)", "plate +y": "plate top edge",
             "plate +x": "plate side", "plate -x": "plate side", "base +y": "base top",
             "base +z": "base front", "base +x": "base side", "base -x": "base side"}
    lab = np.vectorize(lambda s: names.get(s, s or "background"))(label)
    # base top: in front of the plate (its shadow) or behind it
    p = EYE + best[..., None] * d
    lab = np.where((lab == "base top") & (p[..., 2] > 1), "base top, in front (plate's shadow)", lab)
    lab = np.where((lab == "base top") & (p[..., 2] < -1), "base top, behind (lit)", lab)
    edge = np.zeros((h, w), bool)
    for dj, di in [(0, 1), (1, 0), (0, -1), (-1, 0)]:
        edge |= np.roll(lab, (dj, di), (0, 1)) != lab
    return np.where(edge & (lab != "background"), "edges (1 px)", lab)


def png(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\0" + (np.clip(row, 0, 1) * 255).astype(np.uint8).tobytes() for row in rgb)
    def chunk(k, data):
        return struct.pack(">I", len(data)) + k + data + struct.pack(">I", zlib.crc32(k + data))
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


args = [a for a in sys.argv[1:]]
out = None
if "--png" in args:
    k = args.index("--png"); out = args[k + 1]; del args[k:k + 2]
ref, alpha = load(Path(args[0]))
h, w, _ = ref.shape
lab = regions(w, h)
mask = alpha >= 0.999 if alpha is not None else ref.sum(-1) > 0
tiles = [ref]
for f in args[1:]:
    ours, _ = load(Path(f))
    tiles.append(ours)
    err = ((ours - ref) ** 2 * mask[..., None]).sum()
    rms = np.sqrt(err / (ref ** 2 * mask[..., None]).sum())
    print(f"{f}: relative RMS (all) {100 * rms:.1f}%")
    for name in sorted(set(lab[mask])):
        m = mask & (lab == name)
        ratio = ours[m].mean(0) / np.maximum(ref[m].mean(0), 1e-12)
        share = ((ours[m] - ref[m]) ** 2).sum() / err
        print(f"  {name:38s} {m.sum():5d} px  ours/ref {ratio[0]:.2f} {ratio[1]:.2f} {ratio[2]:.2f}  "
              f"share of squared error {100 * share:4.1f}%")
if out:
    scale = 1 / np.percentile(ref[mask], 99)
    g = lambda x: np.clip(x * scale, 0, 1) ** (1 / 2.2)
    q = tiles[1].sum(-1) / np.maximum(ref.sum(-1), 1e-12)
    rm = np.stack([np.clip(q - 1, 0, 1) * 2 + 0.5 * (q <= 1), 0.5 * (1 - np.abs(q - 1) * 2).clip(0, 1),
                   np.clip(1 - q, 0, 1) * 2 + 0.5 * (q >= 1)], -1) * mask[..., None]
    img = np.concatenate([g(t) for t in tiles] + [rm], 1)
    img = np.repeat(np.repeat(img, 3, 0), 3, 1)
    png(out, img)
    print("wrote", out)
