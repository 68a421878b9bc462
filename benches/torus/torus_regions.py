#!/usr/bin/env python3
"""The back-lit torus's error by region (issue 12, wave 9): each pixel of the 96 px reference's
camera ray-marched against the analytic torus (major 7, minor 3 mm: `--shape torus --size-mm 20`,
axis +Y) and classified: outer rim / inner band (the tube's side facing the hole, n . radial < 0),
lit / unlit (n . l > 0 and no ring in the way / the rest), shadowed by the ring (n . l > 0 but the
ray to the light meets the ring), silhouette (view cosine < 0.3). Prints per region the pixels,
ours / reference (ratio of means, R G B) and the share of the squared error, for the compare_exr
mask (alpha >= 0.999) and a stricter one (that mask eroded by one pixel). With --png writes
reference | ours | ratio (0.5..1.5 as blue..green..red) | signed difference (red: ours
brighter), cropped to the object, 6x, side by side.

    target/pt-venv/bin/python benches/torus/torus_regions.py OURS.exr [OURS2.exr ..] \
        [--ref tests/reference/pt/marble-torus-backlit-eta1.exr] [--png strip.png]
"""
import argparse
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
MAJOR, MINOR = 7.0, 3.0
EYE = np.array([0.0, 20.0, 60.0])
FOVY = 30.0
LIGHT_TRAVEL = np.array([0.2, -0.35, 1.0])


def load(p):
    b = np.array(mi.Bitmap(p), dtype=np.float64)
    return b[..., :3], (b[..., 3] if b.shape[2] > 3 else None)


def sdf(p):
    q = np.stack([np.hypot(p[..., 0], p[..., 2]) - MAJOR, p[..., 1]], -1)
    return np.linalg.norm(q, axis=-1) - MINOR


def march(o, d, t0=0.0, steps=400):
    t = np.full(d.shape[:-1], t0)
    hit = np.zeros(d.shape[:-1], bool)
    for _ in range(steps):
        p = o + t[..., None] * d
        s = sdf(p)
        hit |= s < 1e-5
        t = np.where(hit, t, t + s)
        if np.all(hit | (t > 200)):
            break
    return hit, t


def normal(p):
    r = np.hypot(p[..., 0], p[..., 2])
    c = np.stack([p[..., 0] / r * MAJOR, np.zeros_like(r), p[..., 2] / r * MAJOR], -1)
    n = p - c
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def geometry(h, w):
    fwd = -EYE / np.linalg.norm(EYE)
    right = np.cross(fwd, [0, 1, 0.0]); right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    t = np.tan(np.radians(FOVY) / 2)
    jj, ii = np.mgrid[0:h, 0:w]
    x = (2 * (ii + 0.5) / w - 1) * t
    y = (1 - 2 * (jj + 0.5) / h) * t
    d = fwd + x[..., None] * right + y[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    with np.errstate(over="ignore", invalid="ignore"):
        hit, t = march(EYE, d)
    p = EYE + t[..., None] * d
    n = normal(p)
    l = -LIGHT_TRAVEL / np.linalg.norm(LIGHT_TRAVEL)
    nl = (n * l).sum(-1)
    with np.errstate(over="ignore", invalid="ignore"):
        shadow_hit, _ = march(p + n * 1e-3, np.broadcast_to(l, p.shape).copy(), steps=300)
    radial = np.stack([p[..., 0], np.zeros_like(p[..., 0]), p[..., 2]], -1)
    radial /= np.linalg.norm(radial, axis=-1, keepdims=True) + 1e-12
    nr = (n * radial).sum(-1)
    vcos = -(n * d).sum(-1)
    return dict(hit=hit, nl=nl, shadowed=shadow_hit & (nl > 0), nr=nr, vcos=vcos, p=p)


def report(name, ours, ref, mask, g):
    err2 = ((ours - ref) ** 2).sum(-1)
    tot = err2[mask].sum()
    rel = np.sqrt(tot / (ref[mask] ** 2).sum())
    print(f"{name}: rel RMS (all) {100 * rel:.1f}%, {mask.sum()} px")
    lit = (g["nl"] > 0) & ~g["shadowed"]
    regions = [
        ("outer rim", g["nr"] >= 0), ("inner band", g["nr"] < 0),
        ("lit (n.l>0, unshadowed)", lit), ("shadowed by the ring", g["shadowed"]),
        ("unlit (n.l<=0)", g["nl"] <= 0), ("silhouette (vcos<0.3)", g["vcos"] < 0.3),
        ("outer, unlit", (g["nr"] >= 0) & (g["nl"] <= 0)), ("outer, lit", (g["nr"] >= 0) & lit),
        ("inner, unlit", (g["nr"] < 0) & (g["nl"] <= 0)), ("inner, lit", (g["nr"] < 0) & lit),
        ("inner, shadowed", (g["nr"] < 0) & g["shadowed"]),
        ("near ring, outer unlit", (g["p"][..., 2] > 0) & (g["nr"] >= 0) & (g["nl"] <= 0)),
        ("  its centre (|x| < 3)", (g["p"][..., 2] > 0) & (g["nr"] >= 0) & (g["nl"] <= 0) & (np.abs(g["p"][..., 0]) < 3)),
        ("  its ends (|x| >= 3)", (g["p"][..., 2] > 0) & (g["nr"] >= 0) & (g["nl"] <= 0) & (np.abs(g["p"][..., 0]) >= 3)),
        ("ring's sides (|x| > 7)", np.abs(g["p"][..., 0]) > 7),
        ("far ring (z<0)", g["p"][..., 2] < 0),
        ("not silhouette (vcos>=0.3)", g["vcos"] >= 0.3),
    ]
    for rname, r in regions:
        m = mask & r
        if m.sum() == 0:
            continue
        ratio = ours[m].sum(0) / ref[m].sum(0)
        print(f"  {rname:26s} {m.sum():5d} px  ours/ref {ratio[0]:.3f} {ratio[1]:.3f} {ratio[2]:.3f}"
              f"  err^2 share {err2[m].sum() / tot:.3f}")


def png(path, ref, ours_list, mask):
    tiles = []
    expo = 1.0 / np.percentile(ref[mask].sum(-1) / 3, 99)
    tm = lambda x: np.clip(x * expo, 0, 1) ** (1 / 2.2)
    tiles.append(tm(ref))
    for ours in ours_list:
        tiles.append(tm(ours))
        ratio = ours.sum(-1) / np.maximum(ref.sum(-1), 1e-9)
        v = np.clip((ratio - 0.5), 0, 1)
        rimg = np.stack([v, 1 - 2 * np.abs(v - 0.5), 1 - v], -1) * mask[..., None]
        tiles.append(rimg)
        diff = (ours - ref).sum(-1) * expo / 3
        s = np.clip(diff * 4, -1, 1)
        dimg = np.stack([np.maximum(s, 0), np.zeros_like(s), np.maximum(-s, 0)], -1) * (mask | (ref.sum(-1) > 0))[..., None]
        tiles.append(dimg)
    rows = np.nonzero((ref.sum(-1) > 0).any(1))[0]
    cols = np.nonzero((ref.sum(-1) > 0).any(0))[0]
    box = (slice(max(rows[0] - 2, 0), rows[-1] + 3), slice(max(cols[0] - 2, 0), cols[-1] + 3))
    img = np.concatenate([t[box] for t in tiles], 1)
    img = np.repeat(np.repeat(img, 6, 0), 6, 1)
    mi.Bitmap(np.ascontiguousarray(img.astype(np.float32)), mi.Bitmap.PixelFormat.RGB).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=False).write(path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ours", nargs="+")
    ap.add_argument("--ref", default="tests/reference/pt/marble-torus-backlit-eta1.exr")
    ap.add_argument("--png")
    a = ap.parse_args()
    ref, alpha = load(a.ref)
    h, w = ref.shape[:2]
    g = geometry(h, w)
    mask = (alpha >= 0.999) & g["hit"]
    if (alpha >= 0.999).sum() != mask.sum():
        print(f"note: {(alpha >= 0.999).sum() - mask.sum()} masked pixels miss the analytic torus")
    strict = mask.copy()
    for dj, di in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)]:
        strict &= np.roll(np.roll(alpha >= 0.999, dj, 0), di, 1)
    ours_list = []
    for o in a.ours:
        ours, _ = load(o)
        ours_list.append(ours)
        report(o, ours, ref, mask, g)
        report(o + " (strict: eroded 1 px)", ours, ref, strict, g)
    if a.png:
        png(a.png, ref, ours_list, mask)


if __name__ == "__main__":
    main()
