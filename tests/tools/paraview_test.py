#!/usr/bin/python3
"""ParaView opens `swarmsim export` output as it is (docs/tools.md#paraview).

A two-swarm run with three obstacles (tests/data/scene.json) is exported as XDMF and PLY; pvpython opens
the default .xmf2 by its bare name from its folder (OpenDataFile chooses the reader by the extension, as
the GUI's File > Open does: XDMF Reader, the only reader for .xmf2), the .xmf dialect (Xdmf3ReaderS), and
both with --relative after moving them with the .h5 (the .xmf through ./NAME.xmf); the points, velocities, ids and swarm indices ParaView reads at
three frames, its time steps and the obstacle meshes must equal the .h5. ParaView's PLY reader reads
the PLY files back: the same positions. Exit 77 (skipped) without pvpython.
"""
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

SWARMSIM = os.environ.get("SWARMSIM", "swarmsim")
SRC = os.environ.get("SWARMSIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
HERE = os.path.dirname(os.path.abspath(__file__))


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run(cmd, cwd=None):
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=240)
    if p.returncode != 0:
        fail("%s exited %d:\n%s%s" % (" ".join(cmd), p.returncode, p.stdout, p.stderr))
    return p


def pvpython(args, cwd):
    # pvpython renders nothing here; offscreen keeps it from looking for a display
    run(["pvpython", "--force-offscreen-rendering", os.path.join(HERE, "paraview_read.py")] + args, cwd=cwd)


def check_xmf(h5, npz, frames, label, reader, alone=False):
    got = np.load(npz)
    if str(got["reader"]) != reader:
        fail("%s: ParaView chose the reader %s, expected %s" % (label, got["reader"], reader))
    if alone and list(got["listed"]) != [reader]:
        fail("%s: the readers for its name are %s: the GUI would ask which one (expected %s alone)" %
             (label, list(got["listed"]), reader))
    times = h5["time"][:]
    if len(got["times"]) != len(times) or not np.allclose(got["times"], times, rtol=0, atol=1e-12):
        fail("%s: ParaView has %d time steps %s, the file %d %s" % (label, len(got["times"]), got["times"][:4],
                                                                     len(times), times[:4]))
    swarms = [s["name"] for s in __import__("json").loads(h5.attrs["scenario"])["swarms"]]
    obstacles = sorted(h5["scene/obstacles"].keys())
    for f in frames:
        for k, name in enumerate(swarms):
            pre = "f%d_b%d_" % (f, k)
            if pre + "points" not in got:
                fail("%s: frame %d has no block %d (swarm %s)" % (label, f, k, name))
            pos = h5["swarms/%s/position" % name][f]
            if got[pre + "points"].shape != pos.shape or not np.array_equal(got[pre + "points"].astype(np.float32), pos):
                fail("%s: frame %d swarm %s: ParaView's points differ from the .h5" % (label, f, name))
            if int(got[pre + "cells"]) != len(pos):
                fail("%s: frame %d swarm %s: %d vertex cells for %d points" % (label, f, name, got[pre + "cells"], len(pos)))
            if not np.array_equal(got[pre + "velocity"], h5["swarms/%s/velocity" % name][f]):
                fail("%s: frame %d swarm %s: velocity differs" % (label, f, name))
            if not np.array_equal(got[pre + "id"], h5["swarms/%s/id" % name][:]):
                fail("%s: frame %d swarm %s: id differs" % (label, f, name))
            if not np.all(got[pre + "swarm"] == k):
                fail("%s: frame %d swarm %s: swarm attribute is not %d" % (label, f, name, k))
        for j, ob in enumerate(obstacles):
            pre = "f%d_b%d_" % (f, len(swarms) + j)
            v = h5["scene/obstacles/%s/vertices" % ob][:]
            faces = h5["scene/obstacles/%s/faces" % ob].shape[0]
            if pre + "points" not in got or not np.allclose(got[pre + "points"], v, rtol=0, atol=1e-12):
                fail("%s: frame %d: obstacle %s differs from /scene" % (label, f, ob))
            if int(got[pre + "cells"]) != faces:
                fail("%s: obstacle %s has %d triangles in ParaView, %d in the file" % (label, ob, got[pre + "cells"], faces))
        extra = "f%d_b%d_points" % (f, len(swarms) + len(obstacles))
        if extra in got:
            fail("%s: frame %d has more blocks than swarms and obstacles" % (label, f))


def main():
    if shutil.which("pvpython") is None:
        print("SKIP: pvpython not installed (Debian packages paraview, python3-paraview; scripts/setup.sh --tools)")
        sys.exit(77)
    tmp = tempfile.mkdtemp(prefix="swarmsim-paraview-")
    try:
        run([SWARMSIM, "run", os.path.join(SRC, "tests/data/scene.json"), "-o", os.path.join(tmp, "scene.h5"), "--quiet"])
        h5 = h5py.File(os.path.join(tmp, "scene.h5"), "r")
        frames = [0, 11, h5["time"].shape[0] - 1]
        if len(h5["scene/obstacles"]) != 3:
            fail("expected 3 obstacles in /scene, got %d" % len(h5["scene/obstacles"]))

        # the default .xmf2 (XDMF Reader, the only reader for the extension: the GUI opens it without
        # asking), opened by its bare name from its folder
        run([SWARMSIM, "export", "scene.h5", "--format", "xdmf"], cwd=tmp)
        pvpython(["xmf", "scene.xmf2", "xmf2.npz"] + [str(f) for f in frames], cwd=tmp)
        check_xmf(h5, os.path.join(tmp, "xmf2.npz"), frames, "scene.xmf2", "XdmfReader", alone=True)

        # .xmf: the Xdmf3 dialect, for OpenDataFile's choice (Xdmf3ReaderS); the .h5 by absolute path
        run([SWARMSIM, "export", "scene.h5", "--format", "xdmf", "-o", "scene.xmf"], cwd=tmp)
        pvpython(["xmf", "scene.xmf", "xmf.npz"] + [str(f) for f in frames], cwd=tmp)
        check_xmf(h5, os.path.join(tmp, "xmf.npz"), frames, "scene.xmf", "Xdmf3ReaderS")

        # --relative, moved together with its .h5 into another folder: .xmf2 by its bare name, .xmf through ./
        moved = os.path.join(tmp, "moved")
        os.mkdir(moved)
        for name in ("rel.xmf2", "rel.xmf"):
            run([SWARMSIM, "export", "scene.h5", "--format", "xdmf", "--relative", "-o", name], cwd=tmp)
            shutil.move(os.path.join(tmp, name), moved)
        shutil.copy(os.path.join(tmp, "scene.h5"), moved)
        pvpython(["xmf", "rel.xmf2", "rel2.npz"] + [str(f) for f in frames], cwd=moved)
        check_xmf(h5, os.path.join(moved, "rel2.npz"), frames, "moved/rel.xmf2 (--relative)", "XdmfReader")
        pvpython(["xmf", "./rel.xmf", "rel.npz"] + [str(f) for f in frames], cwd=moved)
        check_xmf(h5, os.path.join(moved, "rel.npz"), frames, "moved/rel.xmf (--relative)", "Xdmf3ReaderS")

        # PLY read back by ParaView's PLY reader
        run([SWARMSIM, "export", "scene.h5", "--format", "ply", "-o", "ply"], cwd=tmp)
        names = ["midges.0000.ply", "gnats.0011.ply", "midges.0023.ply", "obstacles.ply"]
        pvpython(["ply", "ply.npz"] + [os.path.join("ply", n) for n in names], cwd=tmp)
        got = np.load(os.path.join(tmp, "ply.npz"))
        for k, (swarm, f) in enumerate([("midges", 0), ("gnats", 11), ("midges", 23)]):
            pos = h5["swarms/%s/position" % swarm][f]
            if not np.array_equal(got["ply%d_points" % k].astype(np.float32), pos):
                fail("%s: ParaView's PLY points differ from the .h5" % names[k])
        v = np.concatenate([h5["scene/obstacles/%s/vertices" % o][:] for o in sorted(h5["scene/obstacles"])])
        faces = sum(h5["scene/obstacles/%s/faces" % o].shape[0] for o in h5["scene/obstacles"])
        if not np.allclose(got["ply3_points"], v, rtol=0, atol=1e-5) or int(got["ply3_cells"]) != faces:
            fail("obstacles.ply: ParaView reads %d points, %d cells; expected %d, %d" %
                 (len(got["ply3_points"]), got["ply3_cells"], len(v), faces))
        print("ok: ParaView read %d time steps; points, velocity, id, swarm at frames %s and %d obstacles equal the "
              ".h5 (.xmf2 and .xmf, absolute and --relative); PLY equal" % (h5["time"].shape[0], frames, len(h5["scene/obstacles"])))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
