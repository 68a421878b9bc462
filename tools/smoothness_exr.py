#!/usr/bin/env python3
"""High-frequency content of a rendered image over the object's interior pixels: how much a
lattice pattern (rings, blotches a few pixels across) adds to smooth shading.

    tools/smoothness_exr.py ours.exr [--sigma 2.0] [--json]

hf = sqrt(mean ((Y - G_sigma * Y) / (G_sigma * Y))^2), the RMS of the relative high-pass of the
luminance Y = (r + g + b) / 3, over pixels whose whole (6 sigma + 1)^2 window is object (alpha >=
0.999, or any channel > 0 without alpha), with G_sigma a Gaussian of `sigma` pixels (separable).
Relative per pixel, so a dark side's rings count as much as a bright crescent's curvature (a
plain energy ratio is dominated by the few brightest pixels). Also printed: the same per channel
as an energy ratio sqrt(sum (I - G I)^2 / sum I^2), and `cov`: the coefficient of variation of
Y over the same interior pixels (anti-aliased silhouettes left out) (the issue's flatness metric for a sphere under a constant
environment at eta = 1, whose exact radiance is constant). Reads EXR through Mitsuba's Bitmap, in the
venv tools/pt_reference.py makes (as tools/compare_exr.py).
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
    y = rgb.mean(axis=-1)[interior]
    y_blur = blurred.mean(axis=-1)[interior]
    total = float(np.sqrt(np.mean(((y - y_blur) / np.maximum(y_blur, 1e-30)) ** 2)))
    y_all = y
    cov = float(np.std(y_all) / max(np.mean(y_all), 1e-30))
    if a.json:
        print(json.dumps({"hf": total, "hf_rgb": per_channel.tolist(), "cov": cov,
                          "pixels": int(interior.sum())}))
    else:
        r, g, b = (100 * per_channel).tolist()
        print(f"hf {100 * total:.2f}% (energy r {r:.2f}, g {g:.2f}, b {b:.2f}) over "
              f"{int(interior.sum())} px, cov {100 * cov:.2f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
