#!/usr/bin/env python3
"""Writes the closed, outward-wound OBJ meshes of the path-traced reference scenes that are not
procedural shapes (issue 12): the boundary faces of a union of axis-aligned boxes on a regular grid
of CELL mm, every face split into CELL-sized squares (two triangles each), so the display mesh has
vertices everywhere for per-vertex shading, and no T-junctions (vertices are shared on the grid).

    tests/reference/pt/make_shapes.py [DIR]    # writes plate-on-base.obj and u-block.obj into DIR
                                               # (default target/pt-shapes; never committed)

- plate-on-base.obj: a 30 x 4 x 16 mm base (x, y, z) with a 20 x 16 x 2 mm plate standing on it,
  its 2 mm thickness along z, centred: the thin wall of issue 12 item 5 (render with --size-mm 30).
- u-block.obj: a 20 x 14 x 10 mm block with an 8 mm wide, 10 mm deep slot from the top: two 6 mm
  arms facing each other across the slot, a concave solid that is not a knot (--size-mm 20).
"""
from pathlib import Path

CELL = 0.5


def boxes_mesh(boxes):
    """Boundary of the union of integer-cell boxes [(x0,x1,y0,y1,z0,z1)] in cells."""
    solid = set()
    for x0, x1, y0, y1, z0, z1 in boxes:
        for i in range(x0, x1):
            for j in range(y0, y1):
                for k in range(z0, z1):
                    solid.add((i, j, k))
    verts, index, faces = [], {}, []

    def v(p):
        if p not in index:
            index[p] = len(verts) + 1
            verts.append(p)
        return index[p]

    # For each cell face whose neighbour is empty: a quad wound counter-clockwise from outside.
    dirs = [((1, 0, 0), 0), ((-1, 0, 0), 0), ((0, 1, 0), 1), ((0, -1, 0), 1), ((0, 0, 1), 2), ((0, 0, -1), 2)]
    for (i, j, k) in sorted(solid):
        for d, axis in dirs:
            if (i + d[0], j + d[1], k + d[2]) in solid:
                continue
            base = [i, j, k]
            if sum(d) > 0:
                base[axis] += 1
            u, w = [a for a in range(3) if a != axis]
            corners = []
            for du, dw in [(0, 0), (1, 0), (1, 1), (0, 1)]:
                c = list(base)
                c[u] += du
                c[w] += dw
                corners.append(tuple(c))
            q = [v(c) for c in corners]
            # Wind counter-clockwise seen from outside: (c1 - c0) x (c2 - c0) along d.
            e1 = [corners[1][a] - corners[0][a] for a in range(3)]
            e2 = [corners[2][a] - corners[0][a] for a in range(3)]
            cross = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
            if sum(c * x for c, x in zip(cross, d)) < 0:
                q = q[::-1]
            faces.append((q[0], q[1], q[2]))
            faces.append((q[0], q[2], q[3]))
    return verts, faces


def write(path, boxes, origin):
    verts, faces = boxes_mesh(boxes)
    with open(path, "w") as f:
        f.write(f"# {path.name}: written by make_shapes.py (issue 12 references); mm\n")
        for p in verts:
            f.write("v {} {} {}\n".format(*(CELL * c - o for c, o in zip(p, origin))))
        for t in faces:
            f.write("f {} {} {}\n".format(*t))
    # Sanity: signed volume must be positive (outward winding).
    vol = 0.0
    centre = [sum(p[a] for p in verts) / len(verts) + 0.123 for a in range(3)]  # off the grid planes
    for a, b, c in faces:
        pa, pb, pc = ([x - o for x, o in zip(verts[i - 1], centre)] for i in (a, b, c))
        vol += (pa[0] * (pb[1] * pc[2] - pb[2] * pc[1]) - pa[1] * (pb[0] * pc[2] - pb[2] * pc[0])
                + pa[2] * (pb[0] * pc[1] - pb[1] * pc[0])) / 6.0
    expect = sum((x1 - x0) * (y1 - y0) * (z1 - z0) for x0, x1, y0, y1, z0, z1 in boxes)
    assert abs(vol - expect) < 1e-6 * expect, (path, vol, expect)
    print(f"{path}: {len(verts)} vertices, {len(faces)} triangles, volume {vol * CELL ** 3:.1f} mm^3")


def cells(mm):
    return round(mm / CELL)


if __name__ == "__main__":
    import sys

    repo = Path(__file__).resolve().parents[3]
    here = Path(sys.argv[1]) if len(sys.argv) > 1 else repo / "target" / "pt-shapes"
    here.mkdir(parents=True, exist_ok=True)
    # Plate on a base: base x [0,30] y [0,4] z [0,16]; plate x [5,25] y [4,20] z [7,9]; centred.
    base = (0, cells(30), 0, cells(4), 0, cells(16))
    plate = (cells(5), cells(25), cells(4), cells(20), cells(7), cells(9))
    write(here / "plate-on-base.obj", [base, plate], (15.0, 10.0, 8.0))
    # U-block: x [0,20] y [0,14] z [0,10] minus the slot x [6,14] y [4,14].
    left = (0, cells(6), 0, cells(14), 0, cells(10))
    right = (cells(14), cells(20), 0, cells(14), 0, cells(10))
    bottom = (cells(6), cells(14), 0, cells(4), 0, cells(10))
    write(here / "u-block.obj", [left, right, bottom], (10.0, 7.0, 5.0))
