#!/usr/bin/env python3
"""Speckle of an image region (benches/RESULTS.md, "Speckle of the bounce in the torus's hole").

The relative RMS between the image and its 3x3 box-blurred copy over a rectangle (default: the
inside of the default scene's torus hole at 512 px), luminance in [0, 1]. Grain from vertex to
vertex raises it; smooth shading gradients barely do.

    target/pt-venv/bin/python tools/speckle.py a.png [b.png ...] [--rect x0,y0,x1,y1]
"""
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def speckle(path, rect):
    img = np.array(mi.Bitmap(path)).astype(np.float64)[..., :3] / 255.0
    lum = img @ np.array([0.2126, 0.7152, 0.0722])
    x0, y0, x1, y1 = rect
    blur = sum(
        lum[y0 + dy : y1 + dy, x0 + dx : x1 + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)
    ) / 9.0
    core = lum[y0:y1, x0:x1]
    return float(np.sqrt(np.mean((core - blur) ** 2)) / np.mean(core))


def main(argv):
    rect = (195, 195, 335, 240)
    paths = []
    it = iter(argv)
    for a in it:
        if a == "--rect":
            rect = tuple(int(v) for v in next(it).split(","))
        else:
            paths.append(a)
    for p in paths:
        print(f"{p}: speckle {100.0 * speckle(p, rect):.3f}% over {rect}")


if __name__ == "__main__":
    main(sys.argv[1:])
