#!/usr/bin/python3
"""Generate the target-shape meshes in data/shapes/ (Wavefront OBJ, z up, metres).

Usage:
  scripts/make_shapes.py            rewrite data/shapes/*.obj and data/shapes/README.md
  scripts/make_shapes.py --check    check the meshes: the ones this script builds,
                                    and the files in data/shapes/ (which must also
                                    be identical to what it would write)
  scripts/make_shapes.py --outdir D write the files into D instead of data/shapes/

These are the guidance ("target shape") meshes of the shape-constrained flying
insects model (Chen et al. 2019): the swarm forms, and morphs between, these
shapes. moon.obj (a crescent moon), sphere.obj, mammoth.obj, shark.obj, and
horse_00.obj ... horse_07.obj (eight keyframes of one galloping horse mesh:
the same vertex count, vertex order and triangles in every frame, only the
vertex positions differ; frame 7 is followed by frame 0 again).

Every mesh is the zero level set of an implicit function (smooth unions of
ellipsoids and tapered capsules, smooth differences of spheres), extracted
with marching cubes (scikit-image, Lewiner's method) on a regular grid fine
enough for the thin parts (fins, tusks, ears, legs), welded on a 0.1 mm
lattice (the 4 decimals of the file) and cleaned (no zero-area triangles, no
unused or duplicate vertices), then decimated to its triangle budget by
quadric-error edge collapses that keep the topology, scaled to its intended
size and centred so that its bounding-box centre is the origin. The horse is
one rest-pose mesh deformed per keyframe by linear-blend skinning (bones for
the torso, neck, head, tail and the upper and lower segment of each leg;
smooth weights from the distance to the bones).

Files hold only a comment header, "v x y z" lines (4 decimals) and "f i j k"
lines with 1-based indices; triangles are counter-clockwise seen from outside
(normals point out). Needs Debian's python3-numpy and python3-skimage, hence
/usr/bin/python3 (the script installs them with apt when missing). The output is
deterministic: the same bytes on every run.

The check verifies, per mesh: every index is valid and every vertex used; no
two vertices at the same position; no zero-area triangle; every undirected
edge used by exactly two triangles, once in each direction (closed, manifold
along edges, consistently oriented); one connected component of genus 0
(Euler characteristic 2) with positive signed volume (outward orientation);
the bounding box centred at the origin with the intended size; the triangle
count within 3,000-12,000; all horse frames share the triangles and vertex
count of horse_00; the files (and README.md) equal what the script writes; and
the .obj files together stay under 4 MB. Exit code 0 when all pass, 1 when a
check fails, 2 on bad usage.
"""

import argparse
import heapq
import math
import os
import sys

import subprocess


def _install_missing():
    """Install Debian's python3-numpy and python3-skimage with apt when they are
    missing (only this script needs them, so scripts/setup.sh does not)."""
    sudo = ["sudo"] if os.geteuid() != 0 else []
    print("make_shapes: installing python3-numpy python3-skimage", file=sys.stderr)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(sudo + ["apt-get", "update", "-qq"], check=True, env=env)
    subprocess.run(sudo + ["apt-get", "install", "-y", "-qq", "--no-install-recommends", "python3-numpy", "python3-skimage"],
                   check=True, env=env)

try:
    import numpy as np
    from skimage import measure
except ImportError:
    _install_missing()
    import numpy as np
    from skimage import measure

HERE = os.path.dirname(os.path.abspath(__file__))
OUTDIR = os.path.normpath(os.path.join(HERE, "..", "data", "shapes"))

UNIT = 10000          # file coordinates are integers of 0.1 mm (4 decimals)
MIN_TRIS, MAX_TRIS = 3000, 12000
MAX_TOTAL_BYTES = 4 * 1000 * 1000


# ----------------------------------------------------------------------------
# Implicit modelling: signed distance-like functions, negative inside.
# Every function takes the grid coordinate arrays X, Y, Z (same shape).
# ----------------------------------------------------------------------------

def smin(a, b, k):
    """Polynomial smooth minimum (smooth union) with blend radius k."""
    if k <= 0:
        return np.minimum(a, b)
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def smax(a, b, k):
    """Polynomial smooth maximum (smooth intersection) with blend radius k."""
    return -smin(-a, -b, k)


def union(fields, k):
    out = fields[0]
    for f in fields[1:]:
        out = smin(out, f, k)
    return out


def sphere(X, Y, Z, c, r):
    return np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) - r


def ellipsoid(X, Y, Z, c, r, pitch=0.0):
    """Ellipsoid with centre c and semi-axes r, rotated by `pitch` degrees
    about the y axis (positive: its +x end goes up). Approximate distance
    (Quilez' k0 * (k0 - 1) / k1 estimate)."""
    x, y, z = X - c[0], Y - c[1], Z - c[2]
    if pitch:
        ca, sa = math.cos(math.radians(pitch)), math.sin(math.radians(pitch))
        x, z = ca * x + sa * z, -sa * x + ca * z
    k0 = np.sqrt((x / r[0]) ** 2 + (y / r[1]) ** 2 + (z / r[2]) ** 2)
    k1 = np.sqrt((x / r[0] ** 2) ** 2 + (y / r[1] ** 2) ** 2 + (z / r[2] ** 2) ** 2)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)


def capsule(X, Y, Z, a, b, ra, rb):
    """Tapered capsule: the segment a-b thickened by a radius that varies
    linearly from ra (at a) to rb (at b)."""
    bax, bay, baz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    px, py, pz = X - a[0], Y - a[1], Z - a[2]
    t = np.clip((px * bax + py * bay + pz * baz) / (bax * bax + bay * bay + baz * baz), 0.0, 1.0)
    dx, dy, dz = px - t * bax, py - t * bay, pz - t * baz
    return np.sqrt(dx * dx + dy * dy + dz * dz) - (ra + t * (rb - ra))


def tube(X, Y, Z, nodes, radii):
    """Union of tapered capsules along a polyline (nodes with radii)."""
    out = None
    for i in range(len(nodes) - 1):
        d = capsule(X, Y, Z, nodes[i], nodes[i + 1], radii[i], radii[i + 1])
        out = d if out is None else np.minimum(out, d)
    return out


def flat_tube(X, Y, Z, nodes, radii, normal, flat):
    """A tube squashed by the factor `flat` along `normal` (unit vector) about
    the plane through nodes[0] normal to it: a fin or a lobe. The nodes should
    lie in that plane."""
    ln = math.sqrt(sum(float(v) * float(v) for v in normal))
    n = [float(v) / ln for v in normal]
    c = nodes[0]
    s = (X - c[0]) * n[0] + (Y - c[1]) * n[1] + (Z - c[2]) * n[2]
    g = 1.0 / flat - 1.0
    return flat * tube(X + g * s * n[0], Y + g * s * n[1], Z + g * s * n[2], nodes, radii)


def bezier(ctrl, n):
    """n + 1 points on the Bezier curve with control points ctrl (any degree)."""
    ctrl = [tuple(float(c) for c in p) for p in ctrl]
    deg = len(ctrl) - 1
    pts = []
    for i in range(n + 1):
        t = i / n
        p = [0.0, 0.0, 0.0]
        for j, q in enumerate(ctrl):
            w = math.comb(deg, j) * t ** j * (1.0 - t) ** (deg - j)
            for k in range(3):
                p[k] += w * q[k]
        pts.append(tuple(p))
    return pts


def ramp(r0, r1, n, power=1.0):
    """n + 1 radii from r0 to r1 (power > 1: stays thick longer)."""
    return [r1 + (r0 - r1) * (1.0 - (i / n)) ** (1.0 / power) if power != 1.0
            else r0 + (r1 - r0) * i / n for i in range(n + 1)]


# ----------------------------------------------------------------------------
# The shapes (design coordinates: metres, close to the final size; x forward)
# Each builder returns a function F(X, Y, Z) and the box [lo, hi] holding
# the surface.
# ----------------------------------------------------------------------------

def moon_field():
    """Crescent moon in the x-z plane, horns pointing +x: a sphere of radius
    10 minus a sphere of radius 9 offset by 4.6 m along x (a smooth
    difference), cut down to a 4 m thick slab (|y| <= 2) whose smooth
    intersection rounds the rims and thins the horns towards their tips."""
    R, r, off, half = 10.0, 9.0, 4.6, 2.0

    def F(X, Y, Z):
        big = np.sqrt(X * X + Y * Y + Z * Z) - R
        cut = np.sqrt((X - off) ** 2 + Y * Y + Z * Z) - r
        crescent = smax(big, -cut, 0.6)
        return smax(crescent, np.abs(Y) - half, 2.2)

    return F, (-10.6, -2.6, -10.6), (7.0, 2.6, 10.6)


def sphere_field():
    def F(X, Y, Z):
        return np.sqrt(X * X + Y * Y + Z * Z) - 8.0

    return F, (-8.6, -8.6, -8.6), (8.6, 8.6, 8.6)


def mammoth_field():
    """Woolly mammoth facing +x, feet at z = 0: barrel body with a shoulder
    hump and a sloping back, head with a domed skull, trunk hanging down and
    curling backwards at the tip, two long tusks curving down, out, forward,
    then up and in, four pillar legs, small ears, a small tail."""

    def F(X, Y, Z):
        body = union([
            ellipsoid(X, Y, Z, (-0.5, 0, 9.0), (6.6, 3.9, 4.0)),
            ellipsoid(X, Y, Z, (2.8, 0, 11.2), (3.6, 3.3, 3.0), pitch=-10),   # shoulder hump
            ellipsoid(X, Y, Z, (-4.2, 0, 8.8), (3.0, 3.5, 3.4)),              # rump
            ellipsoid(X, Y, Z, (0.5, 0, 7.2), (5.0, 3.5, 2.6)),               # belly
        ], 1.5)
        head = union([
            ellipsoid(X, Y, Z, (7.0, 0, 11.0), (2.3, 2.2, 2.8), pitch=-20),
            sphere(X, Y, Z, (6.6, 0, 13.2), 1.9),                             # domed skull
            ellipsoid(X, Y, Z, (8.2, 0, 9.6), (1.5, 1.5, 1.8)),               # trunk root / mouth
        ], 1.2)
        tnodes = bezier([(8.6, 0, 10.2), (10.4, 0, 8.6), (10.6, 0, 4.0), (10.0, 0, 1.2),
                         (8.4, 0, 1.0), (8.3, 0, 2.6)], 16)
        trunk = tube(X, Y, Z, tnodes, ramp(1.15, 0.42, 16, 1.4))
        tusks = []
        for s in (1, -1):
            nodes = bezier([(8.6, 1.1 * s, 9.3), (10.6, 2.6 * s, 6.4), (13.0, 3.2 * s, 5.2),
                            (15.2, 2.6 * s, 7.4), (14.6, 1.2 * s, 10.0)], 16)
            tusks.append(tube(X, Y, Z, nodes, ramp(0.55, 0.22, 16, 1.2)))
        ears = [flat_tube(X, Y, Z, [(6.0, 2.0 * s, 11.8), (5.5, 2.4 * s, 10.2)], [0.9, 0.6],
                          (0.15, 1.0 * s, 0.0), 0.35) for s in (1, -1)]
        legs = []
        for x in (4.0, -4.3):
            for s in (1, -1):
                legs.append(smin(tube(X, Y, Z, [(x, 2.15 * s, 7.5), (x + 0.1, 2.2 * s, 3.5),
                                                (x, 2.2 * s, 1.2)], [1.6, 1.35, 1.35]),
                                 capsule(X, Y, Z, (x + 0.1, 2.2 * s, 0.7), (x + 0.1, 2.2 * s, 1.0),
                                         1.45, 1.45), 0.5))   # leg and foot
        tail = tube(X, Y, Z, bezier([(-6.8, 0, 10.4), (-7.6, 0, 9.4), (-7.8, 0, 7.0)], 6),
                    ramp(0.5, 0.3, 6))
        tuft = ellipsoid(X, Y, Z, (-7.8, 0, 6.6), (0.45, 0.45, 0.7))
        f = smin(body, head, 1.6)
        f = smin(f, trunk, 0.8)
        f = smin(f, union(tusks, 0.0), 0.5)
        f = smin(f, union(ears, 0.0), 0.5)
        f = smin(f, union(legs, 0.0), 1.0)
        f = smin(f, smin(tail, tuft, 0.3), 0.5)
        return smax(f, -Z, 0.2)   # flat soles at z = 0

    return F, (-9.0, -4.8, -0.5), (16.5, 4.8, 15.6)


def shark_field():
    """Shark facing +x: torpedo body with a pointed snout, first and second
    dorsal fin, two pectoral fins, two pelvic fins, anal fin and a crescent
    (heterocercal) caudal fin, upper lobe longer."""

    def F(X, Y, Z):
        bx = [9.9, 9.2, 8.0, 6.0, 3.5, 1.0, -1.5, -3.8, -5.6, -6.9]
        bz = [-0.15, 0.0, 0.1, 0.15, 0.15, 0.1, 0.05, 0.05, 0.1, 0.15]
        br = [0.15, 0.6, 1.1, 1.6, 1.9, 1.95, 1.75, 1.25, 0.7, 0.42]
        # the cross-section is slightly wider than tall
        body = tube(X, Y / 1.08, Z, [(x, 0, z) for x, z in zip(bx, bz)], br)
        first_dorsal = flat_tube(X, Y, Z, bezier([(2.4, 0, 1.2), (0.9, 0, 3.0), (-0.4, 0, 4.6)], 6),
                                 ramp(1.25, 0.4, 6), (0, 1, 0), 0.24)
        second_dorsal = flat_tube(X, Y, Z, bezier([(-4.4, 0, 1.0), (-4.9, 0, 1.6), (-5.5, 0, 2.0)], 3),
                                  ramp(0.45, 0.25, 3), (0, 1, 0), 0.4)
        anal = flat_tube(X, Y, Z, bezier([(-4.6, 0, -0.8), (-5.0, 0, -1.3), (-5.5, 0, -1.6)], 3),
                         ramp(0.42, 0.25, 3), (0, 1, 0), 0.4)
        pecs, pelvics = [], []
        for s in (1, -1):
            # pectoral: out, down and back, in a plane tilted 25 degrees
            nrm = (0.0, 0.42 * s, 0.91)
            pecs.append(flat_tube(X, Y, Z, bezier([(4.2, 1.2 * s, -0.8), (3.0, 3.0 * s, -1.6),
                                                   (1.2, 4.4 * s, -2.3)], 6),
                                  ramp(1.0, 0.42, 6), nrm, 0.25))
            pelvics.append(flat_tube(X, Y, Z, bezier([(-2.6, 0.6 * s, -1.0), (-3.2, 1.2 * s, -1.5),
                                                      (-3.8, 1.5 * s, -1.8)], 3),
                                     ramp(0.5, 0.26, 3), (0.0, 0.6 * s, 0.8), 0.38))
        upper = flat_tube(X, Y, Z, bezier([(-6.6, 0, 0.3), (-8.0, 0, 1.5), (-9.0, 0, 2.9),
                                           (-10.0, 0, 4.1)], 8),
                          ramp(0.75, 0.3, 8), (0, 1, 0), 0.32)
        lower = flat_tube(X, Y, Z, bezier([(-6.8, 0, 0.0), (-7.8, 0, -1.0), (-8.6, 0, -2.2)], 6),
                          ramp(0.6, 0.3, 6), (0, 1, 0), 0.34)
        f = smin(body, first_dorsal, 0.6)
        f = smin(f, union([second_dorsal, anal], 0.0), 0.3)
        f = smin(f, union(pecs, 0.0), 0.5)
        f = smin(f, union(pelvics, 0.0), 0.3)
        f = smin(f, union([upper, lower], 0.3), 0.4)
        return f

    return F, (-10.6, -5.0, -3.2), (10.5, 5.0, 5.1)


# Horse (design coordinates; x forward, hooves at z = 0): the joints, shared
# by the implicit model and the skeleton.
HORSE_LEGS = {
    # name: (shoulder or hip, knee or hock, hoof), y > 0 is the left side
    "fl": ((3.6, 1.0, 7.0), (3.75, 1.0, 3.4), (3.6, 1.0, 0.25)),
    "fr": ((3.6, -1.0, 7.0), (3.75, -1.0, 3.4), (3.6, -1.0, 0.25)),
    "hl": ((-3.5, 1.0, 7.2), (-4.5, 1.0, 3.6), (-4.1, 1.0, 0.25)),
    "hr": ((-3.5, -1.0, 7.2), (-4.5, -1.0, 3.6), (-4.1, -1.0, 0.25)),
}
HORSE_NECK = ((4.0, 0, 8.6), (6.2, 0, 11.4))
HORSE_HEAD = ((6.4, 0, 12.0), (8.7, 0, 9.9))
HORSE_TAIL = [(-5.2, 0, 8.9), (-6.5, 0, 8.5), (-7.5, 0, 7.3), (-8.2, 0, 5.6)]   # carried back


def horse_field():
    """Horse facing +x, hooves at z = 0: barrel, chest and hindquarters,
    neck, long head with muzzle and ears, tail, four legs (upper segment,
    lower segment, fetlock and hoof)."""

    def F(X, Y, Z):
        body = union([
            ellipsoid(X, Y, Z, (0.0, 0, 7.6), (4.6, 1.9, 2.1)),
            ellipsoid(X, Y, Z, (3.2, 0, 7.6), (1.9, 1.8, 2.2), pitch=10),    # chest
            ellipsoid(X, Y, Z, (-3.4, 0, 8.0), (2.2, 1.95, 2.0)),              # hindquarters
        ], 1.2)
        neck = capsule(X, Y, Z, HORSE_NECK[0], HORSE_NECK[1], 1.35, 0.75)
        crest = ellipsoid(X, Y, Z, (4.8, 0, 10.4), (1.0, 0.55, 1.7), pitch=-40)
        head = union([
            capsule(X, Y, Z, HORSE_HEAD[0], HORSE_HEAD[1], 0.72, 0.48),
            ellipsoid(X, Y, Z, (6.9, 0, 11.3), (0.9, 0.62, 0.75), pitch=-40),   # cheek
            sphere(X, Y, Z, (8.55, 0, 9.85), 0.55),                              # muzzle
        ], 0.4)
        ears = [capsule(X, Y, Z, (6.3, 0.32 * s, 12.5), (6.1, 0.45 * s, 13.4), 0.24, 0.16)
                for s in (1, -1)]
        legs = []
        for name, (top, mid, hoof) in HORSE_LEGS.items():
            hind = name[0] == "h"
            fet = (hoof[0] + (0.1 if hind else 0.15), hoof[1], 0.95)
            legs.append(union([
                capsule(X, Y, Z, top, mid, 0.85 if hind else 0.7, 0.36),
                capsule(X, Y, Z, mid, fet, 0.32, 0.27),
                capsule(X, Y, Z, fet, (hoof[0], hoof[1], 0.35), 0.3, 0.34),
            ], 0.25))
        thighs = [ellipsoid(X, Y, Z, (-3.7, 1.05 * s, 6.6), (1.2, 0.85, 1.6), pitch=-20)
                  for s in (1, -1)]
        tail = tube(X, Y, Z, HORSE_TAIL, [0.42, 0.4, 0.36, 0.28])
        f = smin(body, smin(neck, crest, 0.6), 0.9)
        f = smin(f, head, 0.5)
        f = smin(f, union(ears, 0.0), 0.2)
        f = smin(f, union(thighs, 0.0), 0.8)
        f = smin(f, union(legs, 0.0), 0.5)
        f = smin(f, tail, 0.4)
        return np.maximum(f, -Z)   # flat hoof soles at z = 0

    return F, (-9.0, -2.6, -0.4), (9.6, 2.6, 14.2)


def horse_bones():
    """Bones: name -> (parent, pivot, segment start, segment end, radius)."""
    b = {
        "torso": (None, (0.0, 0, 7.6), (-3.6, 0, 7.8), (3.4, 0, 7.8), 1.9),
        "neck": ("torso", HORSE_NECK[0], HORSE_NECK[0], HORSE_NECK[1], 1.0),
        "head": ("neck", HORSE_HEAD[0], HORSE_HEAD[0], HORSE_HEAD[1], 0.65),
        "tail": ("torso", HORSE_TAIL[0], HORSE_TAIL[0], HORSE_TAIL[-1], 0.4),
    }
    for name, (top, mid, hoof) in HORSE_LEGS.items():
        b[name + "_up"] = ("torso", top, top, mid, 0.6)
        b[name + "_low"] = (name + "_up", mid, mid, hoof, 0.33)
    return b


def gallop_angles(phase):
    """Joint angles (degrees, rotation about the y axis; positive lifts the
    bone's forward side, so a leg bone swings its lower end forwards) at
    gallop phase 0 <= phase < 1, and the torso's vertical offset (m).
    Rotary gallop footfalls: left hind, right hind, left fore, right fore,
    then the suspension with the legs gathered under the body. Each leg
    strikes at its most forward reach, pushes back during the stance (a
    third of the cycle) and swings forward again with the lower segment
    folded (fore knees fold the hoof backwards, hind hocks forwards)."""
    tau = 2.0 * math.pi
    duty = 0.34
    a = {}
    # leg: (phase of the strike, upper amplitude, upper bias, lower fold)
    legs = {"hl": (0.00, 27.0, 3.0, 35.0), "hr": (0.08, 27.0, 3.0, 35.0),
            "fl": (0.22, 30.0, 4.0, 75.0), "fr": (0.30, 30.0, 4.0, 75.0)}
    for name, (p0, amp, bias, flex) in legs.items():
        u = (phase - p0) % 1.0
        s = u / duty if u < duty else 1.0 + (u - duty) / (1.0 - duty)   # 0-1 stance, 1-2 swing
        a[name + "_up"] = bias + amp * math.cos(math.pi * s)
        fold = flex * max(0.0, math.sin(math.pi * (s - 1.0))) ** 1.5 if s > 1.0 else 0.0
        a[name + "_low"] = -fold if name[0] == "f" else fold
    a["torso"] = 4.0 * math.sin(tau * (phase - 0.15))
    a["neck"] = -7.0 * math.sin(tau * (phase - 0.15))
    a["head"] = 4.0 * math.sin(tau * (phase - 0.3))
    a["tail"] = -4.0 + 9.0 * math.sin(tau * (phase - 0.4))
    return a, 0.35 * math.sin(tau * (phase - 0.4))


def rot_y(deg, pivot):
    """Affine map (R, t) rotating by `deg` about the y axis through pivot,
    positive lifting +x: R = [[c, 0, -s], [0, 1, 0], [s, 0, c]]."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    R = ((c, 0.0, -s), (0.0, 1.0, 0.0), (s, 0.0, c))
    t = tuple(pivot[i] - sum(R[i][j] * pivot[j] for j in range(3)) for i in range(3))
    return (R, t)


def compose(A, B):
    """Affine A after B."""
    (Ra, ta), (Rb, tb) = A, B
    R = tuple(tuple(sum(Ra[i][k] * Rb[k][j] for k in range(3)) for j in range(3)) for i in range(3))
    t = tuple(sum(Ra[i][k] * tb[k] for k in range(3)) + ta[i] for i in range(3))
    return (R, t)


def segment_distance(P, a, b):
    ba = [float(b[i]) - float(a[i]) for i in range(3)]
    q = P - np.array(a, dtype=np.float64)
    t = np.clip((q[:, 0] * ba[0] + q[:, 1] * ba[1] + q[:, 2] * ba[2])
                / (ba[0] * ba[0] + ba[1] * ba[1] + ba[2] * ba[2]), 0.0, 1.0)
    dx, dy, dz = q[:, 0] - t * ba[0], q[:, 1] - t * ba[1], q[:, 2] - t * ba[2]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


def skin_weights(P, bones, power=6.0):
    """Smooth weights (vertices x bones) from the distance to each bone's
    segment relative to its radius (inverse 6th power, normalised); a leg's
    bones only influence their own side of the body (blended across a 0.4 m
    band about the midplane)."""
    names = list(bones)
    W = np.zeros((len(P), len(names)))
    y = P[:, 1]
    left = np.clip((y + 0.1) / 0.4, 0.0, 1.0)
    left = left * left * (3.0 - 2.0 * left)
    for j, n in enumerate(names):
        _parent, _pivot, a, b, r = bones[n]
        d = segment_distance(P, a, b) / r
        w = 1.0 / np.maximum(d, 0.05) ** power
        if n[:2] in ("fl", "hl"):
            w = w * left
        elif n[:2] in ("fr", "hr"):
            w = w * (1.0 - left)
        W[:, j] = w
    return W / W.sum(axis=1)[:, None]


def skin(P, W, bones, angles, lift):
    """Linear-blend skinning of rest positions P (n x 3)."""
    glob = {}
    for n in bones:   # parents come before their children in the dict
        parent, pivot = bones[n][0], bones[n][1]
        local = rot_y(angles.get(n, 0.0), pivot)
        if parent is None:
            local = compose(((((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))), (0.0, 0.0, lift)),
                            local)
            glob[n] = local
        else:
            glob[n] = compose(glob[parent], local)
    out = np.zeros_like(P)
    x, y, z = P[:, 0], P[:, 1], P[:, 2]
    for j, n in enumerate(bones):
        R, t = glob[n]
        w = W[:, j]
        for i in range(3):
            out[:, i] += w * (R[i][0] * x + R[i][1] * y + R[i][2] * z + t[i])
    return out


# ----------------------------------------------------------------------------
# Marching cubes and mesh cleaning
# ----------------------------------------------------------------------------

def polygonize(field, lo, hi, h):
    """Marching cubes of field(X, Y, Z) < 0 on a grid of spacing h covering
    [lo, hi] (plus a margin). Returns float vertices (n x 3) and triangles
    (m x 3); weld() makes them face outwards."""
    ax = [np.arange(math.floor(lo[i] / h) - 2, math.ceil(hi[i] / h) + 3) * h for i in range(3)]
    X, Y, Z = np.meshgrid(*ax, indexing="ij")
    F = field(X, Y, Z)
    # no grid value (too close to) zero: keeps every surface vertex at least
    # about 1 % of a cell away from the grid points, so that no two vertices
    # of a triangle merge when welded on the 0.1 mm lattice
    eps = 0.02 * h
    F = np.where(F >= 0, np.maximum(F, eps), np.minimum(F, -eps))
    F[0, :, :] = F[-1, :, :] = F[:, 0, :] = F[:, -1, :] = F[:, :, 0] = F[:, :, -1] = h
    verts, faces, _n, _v = measure.marching_cubes((-F).astype(np.float32), 0.0,
                                                  spacing=(h, h, h), method="lewiner")
    verts = verts.astype(np.float64) + np.array([ax[0][0], ax[1][0], ax[2][0]])
    return verts, faces.astype(np.int64)


def weld(V, T):
    """Merge vertices with equal integer positions (keeping the order of first
    use), drop triangles that lose a corner or have zero area (exact, in
    integers), keep the largest connected component, renumber, and orient
    outward (positive signed volume). V holds integers (0.1 mm)."""
    uniq, inv = np.unique(V, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    T = inv[T]
    keep = (T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])
    T = T[keep]
    e1 = uniq[T[:, 1]] - uniq[T[:, 0]]
    e2 = uniq[T[:, 2]] - uniq[T[:, 0]]
    cr = np.cross(e1, e2)
    T = T[np.any(cr != 0, axis=1)]
    T = largest_component(T, len(uniq))
    used, first = np.unique(T.reshape(-1), return_index=True)
    order = used[np.argsort(first, kind="stable")]      # order of first use
    remap = np.full(len(uniq), -1, dtype=np.int64)
    remap[order] = np.arange(len(order))
    V2, T2 = uniq[order], remap[T]
    if signed_volume(V2.astype(np.float64), T2) < 0:
        T2 = T2[:, [0, 2, 1]]
    return V2, T2


def decimate(V, T, target):
    """Quadric-error edge collapse (Garland and Heckbert 1997) of the closed
    mesh V (floats), T down to at most `target` triangles. A collapse merges
    the two ends of an edge into the point that minimises the summed squared
    distance to the planes of their original triangles (area weighted); it is
    skipped when it would change the topology (link condition), flip or fold a
    triangle, or create a needle. Pure Python floats, so deterministic."""
    P = [list(p) for p in V.tolist()]
    F = [list(f) for f in T.tolist()]
    nv = len(P)
    vf = [set() for _ in range(nv)]
    Q = [[0.0] * 10 for _ in range(nv)]
    for fi, (a, b, c) in enumerate(F):
        vf[a].add(fi)
        vf[b].add(fi)
        vf[c].add(fi)
        n = _normal(P[a], P[b], P[c])
        ln = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
        if ln == 0.0:
            continue
        x, y, z = n[0] / ln, n[1] / ln, n[2] / ln
        d = -(x * P[a][0] + y * P[a][1] + z * P[a][2])
        w = 0.5 * ln
        q = (x * x, x * y, x * z, x * d, y * y, y * z, y * d, z * z, z * d, d * d)
        for v in (a, b, c):
            Qv = Q[v]
            for i in range(10):
                Qv[i] += w * q[i]
    alive_f = [True] * len(F)
    alive_v = [True] * nv
    stamp = [0] * nv
    n_faces = len(F)

    def neighbours(v):
        s = set()
        for fi in vf[v]:
            s.update(F[fi])
        s.discard(v)
        return s

    def best(a, b):
        q = [Q[a][i] + Q[b][i] for i in range(10)]
        pa, pb = P[a], P[b]
        mid = [(pa[i] + pb[i]) * 0.5 for i in range(3)]
        cands = [mid, pa, pb]
        a00, a01, a02, a11, a12, a22 = q[0], q[1], q[2], q[4], q[5], q[7]
        det = (a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02)
               + a02 * (a01 * a12 - a11 * a02))
        scale = (a00 + a11 + a22) ** 3
        if scale > 0 and abs(det) > 1e-9 * scale:
            r0, r1, r2 = -q[3], -q[6], -q[8]
            x = (r0 * (a11 * a22 - a12 * a12) - a01 * (r1 * a22 - a12 * r2)
                 + a02 * (r1 * a12 - a11 * r2)) / det
            y = (a00 * (r1 * a22 - a12 * r2) - r0 * (a01 * a22 - a12 * a02)
                 + a02 * (a01 * r2 - r1 * a02)) / det
            z = (a00 * (a11 * r2 - r1 * a12) - a01 * (a01 * r2 - r1 * a02)
                 + r0 * (a01 * a12 - a11 * a02)) / det
            e2 = sum((pa[i] - pb[i]) ** 2 for i in range(3))
            if (x - mid[0]) ** 2 + (y - mid[1]) ** 2 + (z - mid[2]) ** 2 <= e2:
                cands.insert(0, [x, y, z])
        bestc, beste = None, None
        for p in cands:
            x, y, z = p
            e = (q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x
                 + q[4] * y * y + 2 * q[5] * y * z + 2 * q[6] * y
                 + q[7] * z * z + 2 * q[8] * z + q[9])
            if beste is None or e < beste - 1e-15:
                bestc, beste = p, e
        return max(beste, 0.0), bestc

    heap = []

    def push(a, b):
        if a > b:
            a, b = b, a
        cost, p = best(a, b)
        heapq.heappush(heap, (cost, a, b, stamp[a], stamp[b], p))

    for a in range(nv):
        for b in neighbours(a):
            if a < b:
                push(a, b)

    while n_faces > target and heap:
        _cost, a, b, sa, sb, x = heapq.heappop(heap)
        if not (alive_v[a] and alive_v[b]) or stamp[a] != sa or stamp[b] != sb:
            continue
        shared = vf[a] & vf[b]
        if len(shared) != 2:
            continue
        na, nb = neighbours(a), neighbours(b)
        opp = set()
        for fi in shared:
            opp.update(F[fi])
        opp -= {a, b}
        if na & nb != opp or len(na) + len(nb) < 7:
            continue
        ok = True
        for v in (a, b):
            for fi in vf[v]:
                if fi in shared:
                    continue
                f = F[fi]
                old = [P[i] for i in f]
                new = [x if i in (a, b) else P[i] for i in f]
                no, nn = _normal(*old), _normal(*new)
                lo2 = no[0] ** 2 + no[1] ** 2 + no[2] ** 2
                ln2 = nn[0] ** 2 + nn[1] ** 2 + nn[2] ** 2
                dot = no[0] * nn[0] + no[1] * nn[1] + no[2] * nn[2]
                if ln2 == 0.0 or dot <= 0.3 * math.sqrt(lo2 * ln2):
                    ok = False
                    break
                # needle / sliver: quality 4 sqrt(3) A / (sum of squared edges)
                s2 = _sq_edges(*new)
                if 2.0 * math.sqrt(3.0) * math.sqrt(ln2) < 0.15 * s2:
                    so2 = _sq_edges(*old)
                    if math.sqrt(ln2) / s2 < math.sqrt(lo2) / so2:
                        ok = False
                        break
            if not ok:
                break
        if not ok:
            continue
        # collapse b into a at x
        for fi in shared:
            alive_f[fi] = False
            n_faces -= 1
            for v in F[fi]:
                vf[v].discard(fi)
        for fi in vf[b]:
            f = F[fi]
            f[f.index(b)] = a
            vf[a].add(fi)
        vf[b] = set()
        alive_v[b] = False
        P[a] = list(x)
        Q[a] = [Q[a][i] + Q[b][i] for i in range(10)]
        stamp[a] += 1
        for n in sorted(neighbours(a)):
            push(a, n)

    keep = [i for i in range(nv) if alive_v[i]]
    remap = {v: i for i, v in enumerate(keep)}
    V2 = np.array([P[i] for i in keep], dtype=np.float64)
    T2 = np.array([[remap[v] for v in F[fi]] for fi in range(len(F)) if alive_f[fi]],
                  dtype=np.int64)
    return V2, T2


def _sq_edges(a, b, c):
    """Sum of the squared edge lengths of triangle a, b, c."""
    s = 0.0
    for p, q in ((a, b), (b, c), (c, a)):
        dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
        s += dx * dx + dy * dy + dz * dz
    return s


def _normal(a, b, c):
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    return (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)


def components(T, nv):
    """Component label per vertex (union-find over the triangles' corners)."""
    parent = np.arange(nv)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b, c in T.tolist():
        ra = find(a)
        for u in (b, c):
            ru = find(u)
            if ru != ra:
                parent[ru] = ra
    return np.array([find(i) for i in range(nv)])


def largest_component(T, nv):
    lab = components(T, nv)
    tl = lab[T[:, 0]]
    vals, counts = np.unique(tl, return_counts=True)
    if len(vals) > 1:
        big = vals[np.argmax(counts)]
        sys.stderr.write("make_shapes: dropped %d small pieces (%d triangles)\n"
                         % (len(vals) - 1, int(len(T) - counts.max())))
        T = T[tl == big]
    return T


def signed_volume(V, T):
    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    return float(np.sum(a * np.cross(b, c)) / 6.0)


def to_lattice(V):
    return np.rint(V * UNIT).astype(np.int64)


def centre(Vi):
    """Shift integer vertices so that the bounding-box centre is the origin."""
    shift = (Vi.min(axis=0) + Vi.max(axis=0)) // 2
    return Vi - shift


def scaled(V, axis, length):
    """Scale float vertices uniformly so that the extent along axis is length."""
    ext = V[:, axis].max() - V[:, axis].min()
    return V * (length / ext)


# ----------------------------------------------------------------------------
# The meshes
# ----------------------------------------------------------------------------

def clean_mesh(field_fn, h, target):
    """Marching cubes of a shape, welded and cleaned, then decimated to at most
    `target` triangles. Float vertices in design coordinates."""
    field, lo, hi = field_fn()
    V, T = polygonize(field, lo, hi, h)
    Vi, T = weld(to_lattice(V), T)
    V = Vi.astype(np.float64) / UNIT
    if target and len(T) > target:
        V, T = decimate(V, T, target)
    return V, T


def build_static(field_fn, h, target, axis, length):
    V, T = clean_mesh(field_fn, h, target)
    if length is not None:
        V = scaled(V, axis, length)
    Vi, T = weld(to_lattice(V), T)
    return centre(Vi), T


def build_horse(h, target):
    """Rest mesh (16 m long) and its eight gallop keyframes."""
    V, T = clean_mesh(horse_field, h, target)
    s = HORSE_REST_LENGTH / (V[:, 0].max() - V[:, 0].min())
    Vi, T = weld(to_lattice(V * s), T)
    P = Vi.astype(np.float64) / (UNIT * s)       # rest pose, design coordinates
    bones = horse_bones()
    W = skin_weights(P, bones)
    frames = []
    for k in range(8):
        angles, lift = gallop_angles(k / 8.0)
        Q = skin(P, W, bones, angles, lift) * s
        frames.append(centre(to_lattice(Q)))
    return frames, T


# name -> description, intended bounding-box size (m), relative tolerance per axis
SPECS = {
    "moon": ("crescent moon standing upright in the x-z plane, horns towards +x, "
             "4 m thick (y)", (13.7, 4.0, 20.0), (0.05, 0.01, 1e-3)),
    "sphere": ("sphere of radius 8 m", (16.0, 16.0, 16.0), (3e-3, 3e-3, 3e-3)),
    "mammoth": ("woolly mammoth facing +x: body with shoulder hump, head with domed skull, "
                "curled trunk, two curved tusks, four legs, small ears and tail",
                (20.0, 6.85, 13.0), (1e-3, 0.05, 0.05)),
    "shark": ("shark facing +x: torpedo body, pointed snout, dorsal, pectoral, pelvic, "
              "anal and crescent caudal fins", (20.0, 9.4, 7.4), (1e-3, 0.05, 0.05)),
}
for _k in range(8):
    SPECS["horse_%02d" % _k] = (
        "galloping horse facing +x, keyframe %d of 8 (same vertices and triangles in every "
        "frame): body, neck, head, ears, tail, four legs" % _k,
        (16.2, 3.83, 11.8), (0.04, 0.02, 0.08))
HORSE_REST_LENGTH = 16.0

# marching-cubes grid spacing (m) and triangle budget after decimation, per shape
RESOLUTION = {"moon": (0.28, 6000), "sphere": (0.6, None), "mammoth": (0.3, 11500),
              "shark": (0.12, 10000), "horse": (0.12, 8500)}


def build_all():
    """name -> (integer vertices, triangles), in file order."""
    out = {}
    out["moon"] = build_static(moon_field, *RESOLUTION["moon"], 2, 20.0)
    out["sphere"] = build_static(sphere_field, *RESOLUTION["sphere"], 0, None)
    out["mammoth"] = build_static(mammoth_field, *RESOLUTION["mammoth"], 0, 20.0)
    out["shark"] = build_static(shark_field, *RESOLUTION["shark"], 0, 20.0)
    frames, T = build_horse(*RESOLUTION["horse"])
    for k, Vi in enumerate(frames):
        out["horse_%02d" % k] = (Vi, T)
    return out


# ----------------------------------------------------------------------------
# OBJ writing and reading
# ----------------------------------------------------------------------------

def fmt(i):
    i = int(i)
    return "%s%d.%04d" % ("-" if i < 0 else "", abs(i) // UNIT, abs(i) % UNIT)


def obj_text(name, Vi, T):
    desc = SPECS[name][0]
    lines = ["# %s.obj: %s" % (name, desc),
             "# Generated by scripts/make_shapes.py; do not edit, rerun the script.",
             "# Closed triangle mesh, counter-clockwise seen from outside; z up, metres,",
             "# bounding-box centre at the origin.",
             "# %d vertices, %d triangles" % (len(Vi), len(T))]
    lines += ["v %s %s %s" % (fmt(a), fmt(b), fmt(c)) for a, b, c in Vi.tolist()]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in T.tolist()]
    return "\n".join(lines) + "\n"


def parse_obj(text):
    """Read back v and f lines (the only kinds this script writes)."""
    V, T = [], []
    for n, line in enumerate(text.splitlines(), 1):
        s = line.split()
        if not s or s[0].startswith("#"):
            continue
        if s[0] == "v" and len(s) == 4:
            V.append(tuple(float(c) for c in s[1:]))
        elif s[0] == "f" and len(s) == 4:
            T.append(tuple(int(c) - 1 for c in s[1:]))
        else:
            raise ValueError("line %d: unexpected %r" % (n, line))
    return np.array(V, dtype=np.float64).reshape(-1, 3), np.array(T, dtype=np.int64).reshape(-1, 3)


def readme_text(meshes):
    rows = []
    for name, (Vi, T) in meshes.items():
        ext = (Vi.max(axis=0) - Vi.min(axis=0)) / UNIT
        desc = SPECS[name][0]
        if name.startswith("horse_"):
            desc = "galloping horse, keyframe %d of 8" % int(name[6:])
        rows.append("| `%s.obj` | %s | %.2f x %.2f x %.2f | %d | %d |"
                    % (name, desc, ext[0], ext[1], ext[2], len(Vi), len(T)))
    return """# data/shapes/

Target shapes for the shape-constrained flying-insects model (Chen et al. 2019): the swarm
forms these meshes and morphs from one to the next (moon; mammoth to shark; the running horse
keyframes). They are ours, generated by `scripts/make_shapes.py` (no third-party models or
data): implicit functions (smooth unions of ellipsoids and tapered capsules, smooth
differences of spheres) turned into triangles by marching cubes, then decimated by
quadric-error edge collapses. This file is written by the script too; edit the script, not
the files here.

Regenerate them (byte-identical output) with

    scripts/make_shapes.py

and check them with `scripts/make_shapes.py --check` (each mesh closed, watertight, one piece
of genus 0, oriented outward, no duplicate vertices or zero-area triangles, the intended size,
the horse frames sharing their triangles, and the files equal to what the script writes).
The script needs Debian's `python3-numpy` and `python3-skimage` (the script installs
them) and runs with `/usr/bin/python3`.

Wavefront OBJ, triangles only, counter-clockwise seen from outside, z up, x forward for the
animals, metres (4 decimals), each mesh centred so that its bounding-box centre is the origin.

`horse_00.obj` ... `horse_07.obj` are eight keyframes of one gallop cycle (frame 7 is followed
by frame 0): the same vertices in the same order and the same triangles, only the positions
differ (the rest-pose mesh deformed by linear-blend skinning). The horse is 16 m long in its
rest pose (body, neck, head, ears, tail, four legs with upper and lower segments); each frame
is centred on its own bounding box.

| File | Shape | Size x, y, z (m) | Vertices | Triangles |
|---|---|---|---|---|
%s
""" % "\n".join(rows)


def write_all(outdir, meshes):
    os.makedirs(outdir, exist_ok=True)
    for name, (Vi, T) in meshes.items():
        path = os.path.join(outdir, name + ".obj")
        with open(path, "w", encoding="ascii", newline="\n") as fh:
            fh.write(obj_text(name, Vi, T))
        print("wrote %s (%d vertices, %d triangles)" % (path, len(Vi), len(T)))
    path = os.path.join(outdir, "README.md")
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(readme_text(meshes))
    print("wrote %s" % path)


# ----------------------------------------------------------------------------
# Checks
# ----------------------------------------------------------------------------

def check_mesh(V, T, size, tol):
    """V float vertices (m), T triangles. Return (list of problems, stats)."""
    bad = []
    nv = len(V)
    if len(T) == 0 or T.min() < 0 or T.max() >= nv:
        return ["no triangles, or an index out of range"], {}
    rep = (T[:, 0] == T[:, 1]) | (T[:, 1] == T[:, 2]) | (T[:, 2] == T[:, 0])
    if rep.any():
        bad.append("%d triangles repeat a vertex" % int(rep.sum()))
    n_used = len(np.unique(T))
    if n_used != nv:
        bad.append("%d vertices are not used by any triangle" % (nv - n_used))
    n_pos = len(np.unique(V, axis=0))
    if n_pos != nv:
        bad.append("%d vertices duplicate another vertex's position" % (nv - n_pos))

    # edges: each directed edge exactly once, and its reverse exactly once
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    key = E[:, 0] * nv + E[:, 1]
    ukey, cnt = np.unique(key, return_counts=True)
    n_dup = int(np.sum(cnt > 1))
    rkey = E[:, 1] * nv + E[:, 0]
    n_open = int(np.sum(~np.isin(rkey, ukey)))
    if n_dup:
        bad.append("%d directed edges used by more than one triangle "
                   "(inconsistent orientation or non-manifold)" % n_dup)
    if n_open:
        bad.append("%d edges without an oppositely oriented partner (open or flipped)" % n_open)
    n_edges = len(np.unique(np.minimum(E[:, 0], E[:, 1]) * nv + np.maximum(E[:, 0], E[:, 1])))

    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    area2 = np.sqrt(np.sum(np.cross(b - a, c - a) ** 2, axis=1))
    n_zero = int(np.sum(area2 < 1e-12))
    if n_zero:
        bad.append("%d triangles have zero area" % n_zero)

    lab = components(T, nv)
    ncomp = len(np.unique(lab[np.unique(T)]))
    vol = signed_volume(V, T)
    if ncomp != 1:
        bad.append("%d connected components, expected one" % ncomp)
    if not vol > 0:
        bad.append("signed volume %.6g <= 0 (inward orientation)" % vol)
    euler = nv - n_edges + len(T)
    if euler != 2:
        bad.append("Euler characteristic %d, expected 2 (one sphere-like surface)" % euler)
    if not MIN_TRIS <= len(T) <= MAX_TRIS:
        bad.append("%d triangles, outside %d-%d" % (len(T), MIN_TRIS, MAX_TRIS))

    bmin, bmax = V.min(axis=0), V.max(axis=0)
    ext, mid = bmax - bmin, (bmin + bmax) / 2
    if np.any(np.abs(mid) > 1e-4 + 1e-9):
        bad.append("bounding-box centre (%g, %g, %g), not the origin" % tuple(mid))
    for i in range(3):
        if abs(ext[i] - size[i]) > tol[i] * size[i]:
            bad.append("size along %s is %.4f m, intended %.4g m (+-%g %%)"
                       % ("xyz"[i], ext[i], size[i], 100 * tol[i]))
    stats = {"vertices": nv, "triangles": len(T), "edges": n_edges, "volume": vol,
             "area": float(np.sum(area2) / 2), "size": tuple(ext)}
    return bad, stats


def run_check(outdir):
    meshes = build_all()
    ok = True
    total = 0
    sphere_vol = 4.0 / 3.0 * math.pi * 8.0 ** 3
    horse0 = None
    for name, (Vi, T) in meshes.items():
        _desc, size, tol = SPECS[name]
        V = Vi.astype(np.float64) / UNIT
        problems, st = check_mesh(V, T, size, tol)
        problems = ["built: " + p for p in problems]
        if name == "sphere" and st and abs(st["volume"] - sphere_vol) > 0.01 * sphere_vol:
            problems.append("built: volume %.6g, a sphere of radius 8 has %.6g"
                            % (st["volume"], sphere_vol))
        if name.startswith("horse_"):
            if horse0 is None:
                horse0 = (len(Vi), T)
            elif len(Vi) != horse0[0] or not np.array_equal(T, horse0[1]):
                problems.append("built: vertex count or triangles differ from horse_00")
        expected = obj_text(name, Vi, T)
        path = os.path.join(outdir, name + ".obj")
        try:
            with open(path, encoding="ascii") as fh:
                text = fh.read()
        except (OSError, UnicodeDecodeError) as e:
            problems.append("cannot read %s: %s" % (path, e))
            text = None
        if text is not None:
            total += len(text.encode("ascii"))
            if text != expected:
                problems.append("%s differs from what the script writes (stale: rerun it)" % path)
            try:
                Vf, Tf = parse_obj(text)
                fp, st = check_mesh(Vf, Tf, size, tol)
                problems += ["file: " + p for p in fp]
                if name.startswith("horse_") and (
                        len(Vf) != horse0[0] or not np.array_equal(Tf, horse0[1])):
                    problems.append("file: vertex count or triangles differ from horse_00")
            except ValueError as e:
                problems.append("file: %s" % e)
        if st:
            x, y, z = st["size"]
            print("%-13s %5d vertices %6d triangles  volume %8.1f m^3  area %7.1f m^2  "
                  "size %.2f x %.2f x %.2f m"
                  % (name + ".obj", st["vertices"], st["triangles"], st["volume"], st["area"],
                     x, y, z))
        for p in problems:
            print("  FAIL: " + p)
        ok = ok and not problems
    path = os.path.join(outdir, "README.md")
    try:
        with open(path, encoding="ascii") as fh:
            if fh.read() != readme_text(meshes):
                print("  FAIL: %s differs from what the script writes (stale: rerun it)" % path)
                ok = False
    except (OSError, UnicodeDecodeError) as e:
        print("  FAIL: cannot read %s: %s" % (path, e))
        ok = False
    if total > MAX_TOTAL_BYTES:
        print("  FAIL: the .obj files take %d bytes, more than %d" % (total, MAX_TOTAL_BYTES))
        ok = False
    print("total %.2f MB of .obj files" % (total / 1e6))
    print("check: %s" % ("all meshes closed, genus 0, consistently oriented outward, up to date"
                         if ok else "FAILED"))
    return 0 if ok else 1


def main(argv):
    ap = argparse.ArgumentParser(description="Generate (or --check) the target-shape meshes "
                                             "in data/shapes/.")
    ap.add_argument("--check", action="store_true",
                    help="check the built meshes and the files instead of writing")
    ap.add_argument("--outdir", default=OUTDIR,
                    help="folder of the .obj files (default: data/shapes/)")
    args = ap.parse_args(argv)
    if args.check:
        return run_check(args.outdir)
    write_all(args.outdir, build_all())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
