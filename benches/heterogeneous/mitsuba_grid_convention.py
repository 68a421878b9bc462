"""Where Mitsuba 3's `gridvolume` (use_grid_bbox, trilinear: the medium tools/pt_reference.py
builds from a `.vol`) puts a grid's values: cell centres or corners, axis order, orientation,
clamping. Prints the values that `engine/src/material/vol.rs`'s test
`sampling_puts_an_asymmetric_grid_where_mitsuba_puts_it` holds ours to.

    target/pt-venv/bin/python benches/heterogeneous/mitsuba_grid_convention.py
"""
import os
import struct
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def write(path, res, values):
    xres, yres, zres = res
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<5i", 1, xres, yres, zres, 1))
        f.write(struct.pack("<6f", -10, -10, -10, 10, 10, 10))
        f.write(np.asarray(values, dtype="<f4").tobytes())


def volume(path):
    return mi.load_dict({"type": "gridvolume", "filename": path, "use_grid_bbox": True,
                         "filter_type": "trilinear"})


work = tempfile.mkdtemp(prefix="grid-convention-")
path = os.path.join(work, "g.vol")
it = mi.Interaction3f()
# Two cells along y: 0 below, 1 above.
write(path, (1, 2, 1), [0.0, 1.0])
v = volume(path)
for y in [-10, -7.5, -5, -2.5, 0, 2.5, 5, 7.5, 10]:
    it.p = mi.Point3f(3, y, -2)
    print(f"1x2x1 y {y:+5.1f}: {v.eval_1(it):.6f}")
# 2 x 1 x 3 cells holding x + 10 z (data x fastest).
write(path, (2, 1, 3), [x + 10 * z for z in range(3) for x in range(2)])
v = volume(path)
for p in [(-5, 0, -20 / 3), (5, 0, -20 / 3), (-5, 0, 0), (-5, 0, 20 / 3), (0, 0, 0)]:
    it.p = mi.Point3f(*p)
    print(f"2x1x3 at {tuple(round(c, 3) for c in p)}: {v.eval_1(it):.6f}")
