#!/usr/bin/python3
"""Generate the obstacle meshes in data/ (Wavefront OBJ, z up, metres).

Usage:
  scripts/make_meshes.py            rewrite data/blocks.obj, data/house.obj,
                                    data/street_lamp.obj and data/ball.obj
  scripts/make_meshes.py --check    check the meshes: the ones this script
                                    builds, and the files in data/ (which must
                                    also be identical to what it would write)
  scripts/make_meshes.py --outdir D write the files into D instead of data/

Every mesh is a closed, watertight triangle surface, oriented consistently
with counter-clockwise triangles seen from outside (normals point out). The
files hold only a comment header, "v x y z" lines and "f i j k" lines with
1-based indices. Standard library only; the output is deterministic (the same
bytes on every run).

The check verifies, per mesh: every index is valid and every vertex used; no
two vertices at the same position; no degenerate (zero-area) triangle; every
undirected edge is used by exactly two triangles, once in each direction
(closed, manifold along edges, consistently oriented); the signed volume of
every connected component is positive (outward orientation); and the volume
and bounding box match the intended shape. Exit code 0 when all pass, 1 when
a check fails, 2 on bad usage.
"""

import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.normpath(os.path.join(HERE, "..", "data"))


# ----------------------------------------------------------------------------
# Mesh building
# ----------------------------------------------------------------------------

class Mesh:
    """Vertices (list of (x, y, z)) and triangles (0-based index triples)."""

    def __init__(self):
        self.v = []
        self.f = []

    def vert(self, x, y, z):
        self.v.append((float(x), float(y), float(z)))
        return len(self.v) - 1

    def tri(self, a, b, c):
        self.f.append((a, b, c))

    def quad(self, a, b, c, d):
        """Planar convex quad a-b-c-d, counter-clockwise seen from outside."""
        self.tri(a, b, c)
        self.tri(a, c, d)


def add_box(m, lo, hi):
    """Axis-aligned box [lo, hi] as 8 vertices and 12 outward triangles."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    # bottom ring (z0) and top ring (z1), counter-clockwise seen from above
    b = [m.vert(x0, y0, z0), m.vert(x1, y0, z0), m.vert(x1, y1, z0), m.vert(x0, y1, z0)]
    t = [m.vert(x0, y0, z1), m.vert(x1, y0, z1), m.vert(x1, y1, z1), m.vert(x0, y1, z1)]
    m.quad(b[0], b[3], b[2], b[1])  # bottom, seen from below
    m.quad(t[0], t[1], t[2], t[3])  # top
    for i in range(4):
        j = (i + 1) % 4
        m.quad(b[i], b[j], t[j], t[i])  # sides


def blocks():
    """Two boxes forming a 4 m wide passage (y in [13, 17]) between them."""
    m = Mesh()
    add_box(m, (24, 0, 0), (32, 13, 16))   # block A
    add_box(m, (24, 17, 0), (32, 30, 16))  # block B
    return m


def house():
    """Box body 8 x 6 x 4 m plus a gable roof (ridge along x, top at z = 7),
    built as one pentagonal prism along x with its base centred at the origin.
    """
    m = Mesh()
    # profile in the (y, z) plane, counter-clockwise seen from +x
    prof = [(-3.0, 0.0), (3.0, 0.0), (3.0, 4.0), (0.0, 7.0), (-3.0, 4.0)]
    n = len(prof)
    back = [m.vert(-4.0, y, z) for y, z in prof]   # x = -4 gable end
    front = [m.vert(4.0, y, z) for y, z in prof]   # x = +4 gable end
    for i in range(1, n - 1):  # end caps: fans of the convex pentagon
        m.tri(front[0], front[i], front[i + 1])
        m.tri(back[0], back[i + 1], back[i])
    for i in range(n):  # floor, two walls, two roof planes
        j = (i + 1) % n
        m.quad(back[i], back[j], front[j], front[i])
    return m


def street_lamp():
    """Square pole 0.2 m wide (z 0 to 5.6) under a 0.8 x 0.8 x 0.4 m head
    (z 5.6 to 6.0), as one closed surface: the underside of the head is a
    square ring that shares its inner edge with the top of the pole.
    """
    m = Mesh()
    hp, hh = 0.1, 0.4           # half widths of pole and head
    z0, z1, z2 = 0.0, 5.6, 6.0  # ground, pole top = head bottom, head top

    def ring(h, z):
        return [m.vert(-h, -h, z), m.vert(h, -h, z), m.vert(h, h, z), m.vert(-h, h, z)]

    p = ring(hp, z0)  # pole foot
    q = ring(hp, z1)  # pole top (inner edge of the head's underside)
    o = ring(hh, z1)  # head, bottom outer edge
    t = ring(hh, z2)  # head top
    m.quad(p[0], p[3], p[2], p[1])  # pole foot, facing down
    for i in range(4):
        j = (i + 1) % 4
        m.quad(p[i], p[j], q[j], q[i])  # pole sides
        m.quad(q[i], q[j], o[j], o[i])  # underside of the head, facing down
        m.quad(o[i], o[j], t[j], t[i])  # head sides
    m.quad(t[0], t[1], t[2], t[3])  # head top
    return m


def ball(subdivisions=3):
    """Icosphere of radius 1 at the origin: an icosahedron whose triangles are
    split in four `subdivisions` times, with every vertex on the unit sphere
    (20 * 4^3 = 1280 triangles, 642 vertices)."""
    m = Mesh()
    g = (1.0 + math.sqrt(5.0)) / 2.0
    base = [(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0),
            (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
            (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)]

    def unit(p):
        r = math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
        return m.vert(p[0] / r, p[1] / r, p[2] / r)

    for p in base:
        unit(p)
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        mid = {}

        def midpoint(a, b):
            key = (a, b) if a < b else (b, a)
            if key not in mid:
                pa, pb = m.v[a], m.v[b]
                mid[key] = unit(((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2,
                                 (pa[2] + pb[2]) / 2))
            return mid[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    m.f = faces
    return m


# name -> (builder, description, expected volume, expected bbox min, max, volume tolerance)
SPHERE_VOL = 4.0 / 3.0 * math.pi
MESHES = {
    "blocks": (blocks,
               "two boxes 8 x 13 x 16 m, x in [24,32], y in [0,13] and [17,30], z in [0,16]",
               2 * 8 * 13 * 16, (24, 0, 0), (32, 30, 16), 1e-9),
    "house": (house,
              "house, base centred at the origin: body 8 x 6 x 4 m, gable roof to z = 7 (ridge along x)",
              8 * 6 * 4 + 8 * (6 * 3 / 2), (-4, -3, 0), (4, 3, 7), 1e-9),
    "street_lamp": (street_lamp,
                    "street lamp, base at the origin: pole 0.2 x 0.2 x 5.6 m, head 0.8 x 0.8 x 0.4 m (z 5.6 to 6.0)",
                    0.2 * 0.2 * 5.6 + 0.8 * 0.8 * 0.4, (-0.4, -0.4, 0), (0.4, 0.4, 6.0), 1e-9),
    # an inscribed polyhedron is a little smaller than the sphere (about 0.9 %)
    "ball": (ball,
             "sphere of radius 1 at the origin (icosphere, 3 subdivisions)",
             SPHERE_VOL, (-1, -1, -1), (1, 1, 1), 0.03),
}


# ----------------------------------------------------------------------------
# OBJ writing and reading
# ----------------------------------------------------------------------------

def fmt(x):
    s = "%.10g" % x
    return "0" if s == "-0" else s


def obj_text(name, desc, m):
    lines = ["# %s.obj: %s" % (name, desc),
             "# Generated by scripts/make_meshes.py; do not edit, rerun the script.",
             "# Closed triangle mesh, counter-clockwise seen from outside; z up, metres.",
             "# %d vertices, %d triangles" % (len(m.v), len(m.f))]
    lines += ["v %s %s %s" % tuple(fmt(c) for c in p) for p in m.v]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in m.f]
    return "\n".join(lines) + "\n"


def parse_obj(text):
    """Read back v and f lines (the only kinds this script writes)."""
    m = Mesh()
    for n, line in enumerate(text.splitlines(), 1):
        s = line.split()
        if not s or s[0].startswith("#"):
            continue
        if s[0] == "v" and len(s) == 4:
            m.vert(*(float(c) for c in s[1:]))
        elif s[0] == "f" and len(s) == 4:
            m.tri(*(int(c) - 1 for c in s[1:]))
        else:
            raise ValueError("line %d: unexpected %r" % (n, line))
    return m


# ----------------------------------------------------------------------------
# Checks
# ----------------------------------------------------------------------------

def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def check_mesh(m, vol_expected, lo, hi, vol_tol):
    """Return (list of problems, stats dict)."""
    bad = []
    nv = len(m.v)
    for k, f in enumerate(m.f):
        if any(i < 0 or i >= nv for i in f):
            bad.append("triangle %d has an index out of range" % (k + 1))
            return bad, {}
        if len(set(f)) != 3:
            bad.append("triangle %d repeats a vertex" % (k + 1))
    used = set(i for f in m.f for i in f)
    if len(used) != nv:
        bad.append("%d vertices are not used by any triangle" % (nv - len(used)))
    if len(set(m.v)) != nv:
        bad.append("%d vertices duplicate another vertex's position" % (nv - len(set(m.v))))

    # edges: each directed edge exactly once, and its reverse exactly once
    directed = {}
    for f in m.f:
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            directed[(a, b)] = directed.get((a, b), 0) + 1
    n_dup = sum(1 for c in directed.values() if c > 1)
    n_open = sum(1 for (a, b) in directed if (b, a) not in directed)
    if n_dup:
        bad.append("%d directed edges used by more than one triangle "
                   "(inconsistent orientation or non-manifold)" % n_dup)
    if n_open:
        bad.append("%d edges without an oppositely oriented partner (open or flipped)" % n_open)
    n_edges = len(set((min(a, b), max(a, b)) for a, b in directed))

    # degenerate triangles
    for k, (a, b, c) in enumerate(m.f):
        n = cross(sub(m.v[b], m.v[a]), sub(m.v[c], m.v[a]))
        if math.sqrt(dot(n, n)) < 1e-12:
            bad.append("triangle %d has zero area" % (k + 1))

    # connected components (union-find over triangle vertices)
    parent = list(range(nv))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b, c in m.f:
        for u in (b, c):
            ra, ru = find(a), find(u)
            if ra != ru:
                parent[ru] = ra
    comp_vol = {}
    for a, b, c in m.f:
        r = find(a)
        comp_vol[r] = comp_vol.get(r, 0.0) + dot(m.v[a], cross(m.v[b], m.v[c])) / 6.0
    for r, vol in comp_vol.items():
        if not vol > 0:
            bad.append("a component has signed volume %.6g <= 0 (inward orientation)" % vol)
    vol = sum(comp_vol.values())
    if abs(vol - vol_expected) > vol_tol * abs(vol_expected):
        bad.append("volume %.6g differs from the intended %.6g" % (vol, vol_expected))

    bmin = tuple(min(p[i] for p in m.v) for i in range(3))
    bmax = tuple(max(p[i] for p in m.v) for i in range(3))
    if any(abs(bmin[i] - lo[i]) > 1e-9 or abs(bmax[i] - hi[i]) > 1e-9 for i in range(3)):
        bad.append("bounding box %s - %s, intended %s - %s" % (bmin, bmax, lo, hi))

    euler = nv - n_edges + len(m.f)
    stats = {"vertices": nv, "triangles": len(m.f), "edges": n_edges,
             "components": len(comp_vol), "euler": euler, "volume": vol,
             "bbox": (bmin, bmax)}
    if euler != 2 * len(comp_vol):
        bad.append("Euler characteristic %d, expected %d for %d sphere-like components"
                   % (euler, 2 * len(comp_vol), len(comp_vol)))
    return bad, stats


def run_check(outdir):
    ok = True
    for name, (build, desc, vol, lo, hi, tol) in MESHES.items():
        path = os.path.join(outdir, name + ".obj")
        built = build()
        problems, st = check_mesh(built, vol, lo, hi, tol)
        problems = ["built: " + p for p in problems]
        expected_text = obj_text(name, desc, built)
        try:
            with open(path, encoding="ascii") as fh:
                text = fh.read()
        except OSError as e:
            problems.append("cannot read %s: %s" % (path, e))
            text = None
        if text is not None:
            if text != expected_text:
                problems.append("%s differs from what the script writes (stale: rerun it)" % path)
            try:
                file_problems, st = check_mesh(parse_obj(text), vol, lo, hi, tol)
                problems += ["file: " + p for p in file_problems]
            except ValueError as e:
                problems.append("file: %s" % e)
        if st:
            (x0, y0, z0), (x1, y1, z1) = st["bbox"]
            print("%-16s %5d vertices %5d triangles %5d edges  %d component(s)  "
                  "volume %.6g m^3  bbox [%g,%g]x[%g,%g]x[%g,%g]"
                  % (name + ".obj", st["vertices"], st["triangles"], st["edges"],
                     st["components"], st["volume"], x0, x1, y0, y1, z0, z1))
        for p in problems:
            print("  FAIL: " + p)
        ok = ok and not problems
    print("check: %s" % ("all meshes closed, consistently oriented outward" if ok else "FAILED"))
    return 0 if ok else 1


def main(argv):
    ap = argparse.ArgumentParser(description="Generate (or --check) the obstacle meshes in data/.")
    ap.add_argument("--check", action="store_true",
                    help="check the built meshes and the files instead of writing")
    ap.add_argument("--outdir", default=DATA, help="folder of the .obj files (default: data/)")
    args = ap.parse_args(argv)
    if args.check:
        return run_check(args.outdir)
    os.makedirs(args.outdir, exist_ok=True)
    for name, (build, desc, _vol, _lo, _hi, _tol) in MESHES.items():
        m = build()
        path = os.path.join(args.outdir, name + ".obj")
        with open(path, "w", encoding="ascii", newline="\n") as fh:
            fh.write(obj_text(name, desc, m))
        print("wrote %s (%d vertices, %d triangles)" % (path, len(m.v), len(m.f)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
