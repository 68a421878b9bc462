#!/usr/bin/env python3
"""Relative RMS error of an image against a reference over the object's pixels (the metric of
Wang et al. 2010, Fig. 13): sqrt(sum (a - r)^2 / sum r^2), per channel and over all three.

    tools/compare_exr.py ours.exr tests/reference/pt/milk-sphere.exr [--mask alpha] [--json]
                         [--diff diff.exr]

Object pixels (`--mask`): `alpha` (default; reference alpha >= 0.999, i.e. pixels the object
covers fully, so anti-aliased silhouette pixels, where a rasterizer and a path tracer differ by
construction, are left out; falls back to `nonblack` when the reference has no alpha),
`coverage` (alpha > 0) or `nonblack` (any reference channel > 0). Both images must have the same
size. Reads EXR through Mitsuba's Bitmap, in the venv tools/pt_reference.py makes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pt_reference import ensure_mitsuba  # noqa: E402


def load(path: Path):
    """(rgb [h, w, 3], alpha [h, w] or None) as float64."""
    import mitsuba as mi
    import numpy as np

    if not path.exists():
        raise SystemExit(f"error: {path}: no such file")
    bitmap = mi.Bitmap(str(path))
    fmt = bitmap.pixel_format()
    if fmt not in (mi.Bitmap.PixelFormat.RGB, mi.Bitmap.PixelFormat.RGBA):
        raise SystemExit(f"error: {path}: needs RGB or RGBA channels, has {fmt}")
    # Mitsuba's RGBA is premultiplied; with a black background that is the radiance itself.
    data = np.array(bitmap, dtype=np.float64)
    rgb = data[..., :3]
    alpha = data[..., 3] if fmt == mi.Bitmap.PixelFormat.RGBA else None
    if not np.all(np.isfinite(rgb)):
        raise SystemExit(f"error: {path}: {np.count_nonzero(~np.isfinite(rgb))} non-finite values")
    return rgb, alpha


def relative_rms(ours, reference, mask) -> dict:
    import numpy as np

    a, r = ours[mask], reference[mask]
    err = ((a - r) ** 2).sum(axis=0)
    ref = (r**2).sum(axis=0)
    # An all-black reference channel has no relative error to speak of: report None, not Inf.
    per = [math.sqrt(e / s) if s > 0 else None for e, s in zip(err, ref)]
    total = math.sqrt(err.sum() / ref.sum()) if ref.sum() > 0 else None
    return {
        "pixels": int(mask.sum()),
        "rel_rms": per,
        "rel_rms_all": total,
        "mean_ours": a.mean(axis=0).tolist() if len(a) else None,
        "mean_reference": r.mean(axis=0).tolist() if len(r) else None,
        "ratio_of_means": [float(x / y) if y > 0 else None for x, y in zip(a.sum(0), r.sum(0))],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("ours", type=Path)
    parser.add_argument("reference", type=Path)
    parser.add_argument("--mask", choices=["alpha", "coverage", "nonblack"], default="alpha")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--diff", type=Path, help="write ours - reference (RGB) to this EXR")
    args = parser.parse_args()
    ensure_mitsuba()
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    ours, _ = load(args.ours)
    reference, alpha = load(args.reference)
    if ours.shape != reference.shape:
        raise SystemExit(
            f"error: sizes differ: {args.ours} is {ours.shape[1]}x{ours.shape[0]}, "
            f"{args.reference} is {reference.shape[1]}x{reference.shape[0]}"
        )
    mask_kind = args.mask if alpha is not None else "nonblack"
    if mask_kind == "alpha":
        mask = alpha >= 0.999
    elif mask_kind == "coverage":
        mask = alpha > 0
    else:
        mask = (reference > 0).any(axis=-1)
    if not mask.any():
        raise SystemExit("error: the reference has no object pixels under this mask")
    result = {"ours": str(args.ours), "reference": str(args.reference), "mask": mask_kind}
    result.update(relative_rms(ours, reference, mask))
    if args.diff:
        tmp = args.diff.with_name(f".{args.diff.name}.tmp.exr")
        diff = np.ascontiguousarray((ours - reference) * mask[..., None], dtype=np.float32)
        mi.Bitmap(diff, mi.Bitmap.PixelFormat.RGB).write(str(tmp))
        os.replace(tmp, args.diff)
    if args.json:
        print(json.dumps(result))
    else:
        fmt = lambda v: "n/a" if v is None else f"{v:.4f}"  # noqa: E731
        print(
            f"{result['pixels']} object pixels ({mask_kind}); relative RMS "
            f"R {fmt(result['rel_rms'][0])} G {fmt(result['rel_rms'][1])} "
            f"B {fmt(result['rel_rms'][2])} all {fmt(result['rel_rms_all'])}; "
            f"mean ours / reference {' '.join(fmt(v) for v in result['ratio_of_means'])}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
