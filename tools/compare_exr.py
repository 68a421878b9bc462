#!/usr/bin/env python3
"""Relative RMS error of an image against a reference over the object's pixels (the metric of
Wang et al. 2010, Fig. 13): sqrt(sum (a - r)^2 / sum r^2), per channel and over all three.

    tools/compare_exr.py ours.exr tests/reference/pt/milk-sphere.exr [--mask alpha] [--json]
                         [--diff diff.exr]

`--sphere-reflection X,Y,Z:TX,TY,TZ:FOVY:RADIUS:ETA:R,G,B` subtracts from the reference the
exact mirror reflection of a constant environment (radiance R,G,B) off a sphere of that radius at
the origin seen by that camera (Fresnel, unpolarized, per pixel centre). `translucent render`
draws that reflection itself unless `--no-specular`; with `--no-specular` this option isolates the
diffusion part of a dielectric reference.

Object pixels (`--mask`): `alpha` (default; reference alpha >= 0.999, i.e. pixels the object
covers fully, so anti-aliased silhouette pixels, where a rasterizer and a path tracer differ by
construction, are left out; falls back to `nonblack` when the reference has no alpha),
`coverage` (alpha > 0) or `nonblack` (any reference channel > 0). Both images must have the same
size. `--mask-from OTHER.exr` takes the alpha mask from another render of the same geometry and
camera: a material so thin that camera rays cross it unscattered (ketchup's red, mean free path
4 mm, on a 20 mm sphere at eta 1) has alpha < 0.999 in every pixel of its own reference. Reads EXR through Mitsuba's Bitmap, in the venv tools/pt_reference.py makes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

# Importing pt_reference must not leave a tools/__pycache__ in the working tree.
sys.dont_write_bytecode = True
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


def fresnel_reflectance(cos_i, eta):
    """Unpolarized Fresnel reflectance from outside (index 1) into index eta."""
    import numpy as np

    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_i**2)) / eta
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))
    rs = ((cos_i - eta * cos_t) / (cos_i + eta * cos_t)) ** 2
    rp = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)) ** 2
    return 0.5 * (rs + rp)


def sphere_reflection(spec: str, width: int, height: int):
    """[h, w, 3] mirror reflection of a constant environment off a sphere at the origin."""
    import numpy as np

    from pt_reference import SceneError, numbers, parse_camera

    parts = spec.split(":")
    try:
        if len(parts) != 6:
            raise SceneError("expected X,Y,Z:TX,TY,TZ:FOVY:RADIUS:ETA:R,G,B")
        eye, target, fovy = parse_camera(":".join(parts[:3]))
        (radius,) = numbers("radius", parts[3], 1)
        (eta,) = numbers("eta", parts[4], 1)
        env = numbers("radiance", parts[5], 3)
    except SceneError as e:
        raise SystemExit(f"error: --sphere-reflection {spec!r}: {e}") from None
    if radius <= 0 or eta <= 0:
        raise SystemExit(f"error: --sphere-reflection {spec!r}: radius and eta must be > 0")
    eye, target = np.array(eye), np.array(target)
    forward = (target - eye) / np.linalg.norm(target - eye)
    # Same rule as Camera::view_proj: +Y up unless looking along Y.
    looking_along_y = np.linalg.norm(np.cross(forward, [0.0, 1.0, 0.0])) <= 1e-6
    up = np.array([0.0, 0.0, 1.0]) if looking_along_y else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = math.tan(math.radians(fovy) / 2)
    ys, xs = np.mgrid[0:height, 0:width]
    px = (2 * (xs + 0.5) / width - 1) * half * width / height
    py = (1 - 2 * (ys + 0.5) / height) * half
    d = forward + px[..., None] * right + py[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = (d * eye).sum(-1)
    disc = b * b - (eye @ eye - radius * radius)
    hit = disc > 0
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    normal = (eye + t[..., None] * d) / radius
    cos_i = np.clip(-(d * normal).sum(-1), 0.0, 1.0)
    return (fresnel_reflectance(cos_i, eta) * hit)[..., None] * np.array(env)


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


def self_check() -> int:
    """Exact answers: the metric of a scaled image, the mask, Fresnel at normal incidence."""
    import numpy as np

    rng = np.random.default_rng(1)
    reference = rng.uniform(0.1, 2.0, (8, 8, 3))
    mask = np.zeros((8, 8), bool)
    mask[2:6, 1:7] = True
    ours = reference * np.array([1.1, 1.0, 0.5])
    ours[~mask] = 1e9  # outside the object: must not count
    got = relative_rms(ours, reference, mask)
    checks = {
        "scaled image gives |scale - 1| per channel": np.allclose(got["rel_rms"], [0.1, 0.0, 0.5]),
        "pixels counted": got["pixels"] == 24,
        "black reference channel is None, not Inf": relative_rms(
            ours, reference * [1, 1, 0], mask
        )["rel_rms"][2]
        is None,
        "Fresnel at normal incidence": math.isclose(
            float(fresnel_reflectance(np.array(1.0), 1.5)), 0.04, rel_tol=1e-12
        ),
        "Fresnel at grazing incidence": math.isclose(
            float(fresnel_reflectance(np.array(0.0), 1.3)), 1.0
        ),
    }
    for name, ok in checks.items():
        print(f"{name}: {'ok' if ok else 'FAIL'}")
    return 0 if all(checks.values()) else 1


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("ours", type=Path, nargs="?")
    parser.add_argument("reference", type=Path, nargs="?")
    parser.add_argument("--self-check", action="store_true", help="test the metric and exit")
    parser.add_argument("--mask", choices=["alpha", "coverage", "nonblack"], default="alpha")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--sphere-reflection", metavar="CAMERA:RADIUS:ETA:R,G,B")
    parser.add_argument("--diff", type=Path, help="write ours - reference (RGB) to this EXR")
    parser.add_argument(
        "--mask-from", type=Path, help="the alpha mask of this EXR (same size) instead"
    )
    args = parser.parse_args()
    ensure_mitsuba()
    if args.self_check:
        return self_check()
    if args.ours is None or args.reference is None:
        parser.error("give OURS.exr and REFERENCE.exr")
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
    if args.sphere_reflection:
        h, w = reference.shape[:2]
        reference = reference - sphere_reflection(args.sphere_reflection, w, h)
    if args.mask_from:
        other, alpha = load(args.mask_from)
        if alpha is None or other.shape != reference.shape:
            raise SystemExit(f"error: --mask-from {args.mask_from}: needs alpha and the same size")
    mask_kind = args.mask if alpha is not None else "nonblack"
    if mask_kind == "alpha":
        mask = alpha >= 0.999
    elif mask_kind == "coverage":
        mask = alpha > 0
    else:
        mask = (reference > 0).any(axis=-1)
    if not mask.any():
        raise SystemExit("error: the reference has no object pixels under this mask")
    if args.mask_from:
        mask_kind += f" of {args.mask_from}"
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
