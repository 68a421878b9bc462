#!/usr/bin/env python3
"""High-frequency energy of a rendered image over the object's interior pixels: the share of the
image that a lattice pattern (rings, blotches a few pixels across) adds to smooth shading.

    tools/smoothness_exr.py ours.exr [--sigma 2.0] [--json]

hf = sqrt(sum (I - G_sigma * I)^2 / sum I^2) over pixels whose whole (6 sigma + 1)^2 window is
object (alpha >= 0.999, or any channel > 0 without alpha), summed over the three channels, with
G_sigma a Gaussian of `sigma` pixels (separable, normalized per pixel over object pixels only, so
the silhouette does not count as detail). Smooth shading of a 20 mm object at 96-128 px has
hf of a few tenths of a percent; the lattice of 24-48 cells adds to it. Reads EXR through
Mitsuba's Bitmap, in the venv tools/pt_reference.py makes (as tools/compare_exr.py).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))
from pt_reference import ensure_mitsuba  # noqa: E402


def blur(values, mask, sigma: float):
    """Gaussian blur of `values` [h, w, c] over the pixels in `mask`, renormalized."""
    import numpy as np

    radius = int(3 * sigma)
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (x / sigma) ** 2)

    def separable(a):
        out = a
        for axis in (0, 1):
            out = np.apply_along_axis(lambda r: np.convolve(r, kernel, mode="same"), axis, out)
        return out

    m = mask.astype(np.float64)
    weight = separable(m)
    blurred = np.stack([separable(values[..., c] * m) for c in range(values.shape[-1])], -1)
    return blurred / np.maximum(weight, 1e-12)[..., None], weight


def main() -> int:
    ensure_mitsuba()
    import numpy as np

    from compare_exr import load

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("image", type=Path)
    p.add_argument("--sigma", type=float, default=2.0)
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    rgb, alpha = load(a.image)
    mask = alpha >= 0.999 if alpha is not None else np.any(rgb > 0, axis=-1)
    blurred, _ = blur(rgb, mask, a.sigma)
    # Interior: the whole window is object.
    radius = int(3 * a.sigma)
    box = np.ones(2 * radius + 1)
    full = mask.astype(np.float64)
    for axis in (0, 1):
        full = np.apply_along_axis(lambda r: np.convolve(r, box, mode="same"), axis, full)
    interior = full >= (2 * radius + 1) ** 2 - 0.5
    d = (rgb - blurred)[interior]
    ref = rgb[interior]
    per_channel = np.sqrt(np.sum(d**2, axis=0) / np.maximum(np.sum(ref**2, axis=0), 1e-30))
    total = float(np.sqrt(np.sum(d**2) / max(np.sum(ref**2), 1e-30)))
    if a.json:
        print(json.dumps({"hf": total, "hf_rgb": per_channel.tolist(), "pixels": int(interior.sum())}))
    else:
        r, g, b = (100 * per_channel).tolist()
        print(f"hf {100 * total:.2f}% (r {r:.2f}, g {g:.2f}, b {b:.2f}) over {int(interior.sum())} px")
    return 0


if __name__ == "__main__":
    sys.exit(main())
