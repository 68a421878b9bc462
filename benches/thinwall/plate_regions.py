"""Where the back-lit plate's error is: ours / reference per region of the plate-on-base scene
(tests/reference/pt/plate-on-base-backlit-eta1.exr; camera 0,20,60:0,0,0:30, 96 px), the regions
row bands read off the image (BANDS). Prints per region: pixels, ratio of means R, G, B, and the share of the squared error
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

# Row bands of the 96 px image (read off the reference: the plate's face spans rows ~18-63, the
# base's top 64-72 and its front 73-81). The reference's alpha is below 0.999 on the plate above
# row ~56 (camera rays cross the 2 mm wall unscattered, ~1%), so compare_exr.py's default mask
# (and defaults_table.sh's number) sees only the plate's foot and the base.
BANDS = [("plate face, rows 20-55", 20, 56), ("plate foot, rows 56-63", 56, 64),
         ("base top (plate's shadow), rows 64-72", 64, 73), ("base front, rows 73-81", 73, 82)]
COLUMNS = (20, 76)  # away from the plate's side edges


def regions(w, h):
    lab = np.full((h, w), "other (edges, sides)", dtype=object)
    for name, lo, hi in BANDS:
        lab[lo:hi, COLUMNS[0]:COLUMNS[1]] = name
    return lab


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
metric = alpha >= 0.999 if alpha is not None else ref.sum(-1) > 0
mask = ref.sum(-1) > 0  # every covered pixel; `metric` is compare_exr.py's
tiles = [ref]
for f in args[1:]:
    ours, _ = load(Path(f))
    tiles.append(ours)
    err = ((ours - ref) ** 2 * mask[..., None]).sum()
    rms = np.sqrt(err / (ref ** 2 * mask[..., None]).sum())
    e2 = ((ours - ref) ** 2 * metric[..., None]).sum()
    rms2 = np.sqrt(e2 / (ref ** 2 * metric[..., None]).sum())
    print(f"{f}: relative RMS (all) {100 * rms2:.1f}% over compare_exr.py's mask "
          f"({metric.sum()} px), {100 * rms:.1f}% over every covered pixel ({mask.sum()} px)")
    for name in sorted(set(lab[mask])):
        m = mask & (lab == name)
        ratio = ours[m].mean(0) / np.maximum(ref[m].mean(0), 1e-12)
        share = ((ours[m] - ref[m]) ** 2).sum() / err
        inm = (m & metric).sum()
        print(f"  {name:38s} {m.sum():5d} px ({inm:4d} in the metric)  ours/ref {ratio[0]:.2f} {ratio[1]:.2f} {ratio[2]:.2f}  "
              f"share of squared error {100 * share:4.1f}%")
if out:
    scale = 1 / np.percentile(ref[mask], 99)
    g = lambda x: np.clip(x * scale, 0, 1) ** (1 / 2.2)
    q = tiles[1].sum(-1) / np.maximum(ref.sum(-1), 1e-12)
    d = np.clip(q - 1, -0.5, 0.5)  # red: ours brighter, blue: darker, grey: within a few %
    rm = np.stack([0.5 + d, 0.5 - np.abs(d), 0.5 - d], -1) * mask[..., None]
    img = np.concatenate([g(t) for t in tiles] + [rm], 1)
    img = np.repeat(np.repeat(img, 3, 0), 3, 1)
    png(out, img)
    print("wrote", out)
