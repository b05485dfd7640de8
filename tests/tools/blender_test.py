#!/usr/bin/python3
"""Blender reads a swarmsim run: scripts/blender_import.py imports a two-swarm run
with obstacles into a .blend, then a second Blender (without the import script)
opens that .blend, evaluates three frames and writes what it sees; this script
compares that with the HDF5 file.

Environment: SWARMSIM (built binary), SWARMSIM_SOURCE_DIR (repository).
Exit 0 = pass, 1 = mismatch or failure, 77 = Blender not installed (skipped).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

# Blender frame = HDF5 frame index + 1 (scripts/blender_import.py)
FRAME_OFFSET = 1
POS_TOL = 1e-5  # metres: float32 positions through a shape key (basis + 1 * (key - basis))
VEL_TOL = 1e-6

CHECK_SCRIPT = r'''
import bpy, json, sys
import numpy as np
out_path = sys.argv[sys.argv.index("--") + 1]
frames = [int(x) for x in sys.argv[sys.argv.index("--") + 2].split(",")]
scene = bpy.context.scene
res = {"frame_start": scene.frame_start, "frame_end": scene.frame_end,
       "fps": scene.render.fps, "fps_base": scene.render.fps_base,
       "swarms": {}, "obstacles": {}, "handlers": len(bpy.app.handlers.frame_change_post)
                                                  + len(bpy.app.handlers.frame_change_pre)}
swarm_obs = [o for o in scene.objects if "swarmsim_swarm" in o]
for ob in swarm_obs:
    res["swarms"][ob["swarmsim_swarm"]] = {"object": ob.name, "type": ob.type,
        "collection": [c.name for c in ob.users_collection], "frames": {}}
for f in frames:
    scene.frame_set(f)
    dg = bpy.context.evaluated_depsgraph_get()
    for ob in swarm_obs:
        ev = ob.evaluated_get(dg)
        me = ev.to_mesh()
        n = len(me.vertices)
        co = np.empty(3 * n, dtype=np.float32)
        me.vertices.foreach_get("co", co)
        d = {"n": n, "edges": len(me.edges), "faces": len(me.polygons), "co": co.tolist()}
        for name, field, dim in (("id", "value", 1), ("velocity", "vector", 3), ("present", "value", 1)):
            a = me.attributes.get(name)
            if a is None:
                continue
            buf = np.empty(dim * n, dtype=np.float32 if field == "vector" else np.int32)
            a.data.foreach_get(field, buf)
            d[name] = {"type": a.data_type, "domain": a.domain, "data": buf.tolist()}
        res["swarms"][ob["swarmsim_swarm"]]["frames"][str(f)] = d
        ev.to_mesh_clear()
for ob in scene.objects:
    if "swarmsim_obstacle" in ob:
        res["obstacles"][ob["swarmsim_obstacle"]] = {
            "object": ob.name, "type": ob.get("swarmsim_type"), "vertices": len(ob.data.vertices),
            "faces": len(ob.data.polygons),
            "triangles": all(len(p.vertices) == 3 for p in ob.data.polygons),
            "collection": [c.name for c in ob.users_collection]}
        co = np.empty(3 * len(ob.data.vertices), dtype=np.float32)
        ob.data.vertices.foreach_get("co", co)
        res["obstacles"][ob["swarmsim_obstacle"]]["co"] = co.tolist()
with open(out_path, "w") as fh:
    json.dump(res, fh)
print("check script: wrote", out_path)
'''


class Mismatch(Exception):
    pass


def run(cmd, what, timeout=120):
    t0 = time.monotonic()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout)
    dt = time.monotonic() - t0
    if p.returncode != 0:
        sys.stdout.write(p.stdout)
        raise Mismatch("%s failed (exit %d): %s" % (what, p.returncode, " ".join(cmd)))
    print("%s: %.1f s" % (what, dt))
    return p.stdout


def compare(h5_path, res, frames_h5):
    import h5py
    import numpy as np
    errors = []
    with h5py.File(h5_path, "r") as f:
        nframes = f["time"].shape[0]
        if res["frame_start"] != 1 or res["frame_end"] != nframes:
            errors.append("scene frame range %d..%d, expected 1..%d"
                          % (res["frame_start"], res["frame_end"], nframes))
        fps = res["fps"] / res["fps_base"]
        want_fps = 1.0 / float(f.attrs["frame_dt"])
        if abs(fps - want_fps) > 1e-6 * want_fps:
            errors.append("scene fps %r / %r = %r, expected 1/frame_dt = %r"
                          % (res["fps"], res["fps_base"], fps, want_fps))
        if res["handlers"]:
            errors.append("the saved file registered %d frame-change handlers" % res["handlers"])
        names = sorted(f["swarms"].keys())
        if sorted(res["swarms"]) != names:
            errors.append("swarm objects %s, file has swarms %s" % (sorted(res["swarms"]), names))
        scen = f.attrs["scenario_name"]
        scen = scen.decode() if isinstance(scen, bytes) else str(scen)
        for name in names:
            if name not in res["swarms"]:
                continue
            b = res["swarms"][name]
            g = f["swarms"][name]
            if b["object"] != name:
                errors.append("swarm %s: object named %r" % (name, b["object"]))
            if b["type"] != "MESH" or scen not in b["collection"]:
                errors.append("swarm %s: object type %s in collections %s (expected MESH in %r)"
                              % (name, b["type"], b["collection"], scen))
            ids = g["id"][:]
            for fi in frames_h5:
                bf = str(fi + FRAME_OFFSET)
                fr = b["frames"].get(bf)
                if fr is None:
                    errors.append("swarm %s: Blender frame %s not evaluated" % (name, bf))
                    continue
                where = "swarm %s, Blender frame %s (HDF5 frame %d)" % (name, bf, fi)
                pos = g["position"][fi]
                n = pos.shape[0]
                if fr["n"] != n or fr["edges"] or fr["faces"]:
                    errors.append("%s: %d vertices, %d edges, %d faces; expected %d vertices only"
                                  % (where, fr["n"], fr["edges"], fr["faces"], n))
                    continue
                if np.isnan(pos).any():
                    errors.append("%s: the test scenario has absent agents; the test expects none" % where)
                co = np.array(fr["co"], dtype=np.float64).reshape(-1, 3)
                err = np.abs(co - pos.astype(np.float64)).max()
                if not err <= POS_TOL:
                    i = int(np.abs(co - pos).max(axis=1).argmax())
                    errors.append("%s: positions differ by up to %.3g m (agent %d: Blender %s, HDF5 %s)"
                                  % (where, err, i, co[i].tolist(), pos[i].tolist()))
                a = fr.get("id")
                if a is None or a["type"] != "INT" or a["domain"] != "POINT":
                    errors.append("%s: no INT point attribute id (%s)" % (where, a and a["type"]))
                elif not np.array_equal(np.array(a["data"]), ids.astype(np.int64)):
                    errors.append("%s: id attribute differs from /swarms/%s/id" % (where, name))
                a = fr.get("present")
                if a is None or np.any(np.array(a["data"]) != 1):
                    errors.append("%s: present attribute missing or not all 1" % where)
                if "velocity" in g:
                    a = fr.get("velocity")
                    if a is None or a["type"] != "FLOAT_VECTOR" or a["domain"] != "POINT":
                        errors.append("%s: no FLOAT_VECTOR point attribute velocity" % where)
                    else:
                        v = np.array(a["data"], dtype=np.float64).reshape(-1, 3)
                        err = np.abs(v - g["velocity"][fi]).max()
                        if not err <= VEL_TOL:
                            errors.append("%s: velocity differs from HDF5 velocity[%d] by up to %.3g m/s"
                                          % (where, fi, err))
        obst = f["scene/obstacles"] if "scene" in f and "obstacles" in f["scene"] else {}
        keys = sorted(obst.keys())
        if not keys:
            errors.append("%s has no /scene/obstacles: the test scenario has three" % h5_path)
        if sorted(res["obstacles"]) != keys:
            errors.append("obstacle objects %s, file has /scene/obstacles/%s"
                          % (sorted(res["obstacles"]), keys))
        for k in keys:
            o = res["obstacles"].get(k)
            if o is None:
                continue
            g = obst[k]
            t = g.attrs["type"]
            t = t.decode() if isinstance(t, bytes) else str(t)
            V, F = g["vertices"].shape[0], g["faces"].shape[0]
            if o["vertices"] != V or o["faces"] != F or not o["triangles"]:
                errors.append("obstacle %s: %d vertices, %d faces (triangles: %s); HDF5 %d, %d"
                              % (k, o["vertices"], o["faces"], o["triangles"], V, F))
            if o["object"] != "obstacle_%s_%s" % (k, t) or "obstacles" not in o["collection"]:
                errors.append("obstacle %s: object %r in %s, expected obstacle_%s_%s in 'obstacles'"
                              % (k, o["object"], o["collection"], k, t))
            if o["vertices"] == V:
                err = np.abs(np.array(o["co"]).reshape(-1, 3) - g["vertices"][:]).max() if V else 0.0
                if not err <= POS_TOL:
                    errors.append("obstacle %s: vertices differ by up to %.3g m" % (k, err))
    return errors


def main():
    blender = shutil.which("blender")
    if blender is None:
        print("SKIP: blender not installed (Debian package blender; scripts/setup.sh --tools installs it)")
        return 77
    try:
        import h5py
    except ImportError:
        print("FAIL: /usr/bin/python3 cannot import h5py (Debian package python3-h5py)")
        return 1
    exe = os.environ.get("SWARMSIM")
    src = os.environ.get("SWARMSIM_SOURCE_DIR")
    if not exe or not src:
        print("FAIL: set SWARMSIM (built binary) and SWARMSIM_SOURCE_DIR (repository)")
        return 1
    importer = os.path.join(src, "scripts", "blender_import.py")
    tmp = tempfile.mkdtemp(prefix="swarmsim_blender_")
    ok = False
    try:
        h5 = os.path.join(tmp, "scene.h5")
        blend = os.path.join(tmp, "scene.blend")
        run([exe, "run", os.path.join(src, "tests", "data", "scene.json"), "-o", h5, "--quiet"],
            "swarmsim run tests/data/scene.json")
        out = run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", importer,
                   "--", h5, "--save", blend], "blender: import and save")
        for line in out.splitlines():
            if line.startswith("blender_import.py:"):
                print("  " + line)
        if not os.path.isfile(blend):
            raise Mismatch("the import did not write %s" % blend)

        with h5py.File(h5, "r") as f:
            nframes = f["time"].shape[0]
        frames_h5 = sorted({0, nframes // 2, nframes - 1})
        check = os.path.join(tmp, "check_blend.py")
        with open(check, "w") as fh:
            fh.write(CHECK_SCRIPT)
        res_path = os.path.join(tmp, "blender_readback.json")
        run([blender, "-b", blend, "--factory-startup", "--python-exit-code", "1", "--python", check,
             "--", res_path, ",".join(str(fi + FRAME_OFFSET) for fi in frames_h5)],
            "blender: re-open the .blend and evaluate frames %s"
            % ", ".join(str(fi + FRAME_OFFSET) for fi in frames_h5))
        with open(res_path) as fh:
            res = json.load(fh)
        errors = compare(h5, res, frames_h5)
        if errors:
            print("FAIL: Blender's view of %s differs from the file:" % h5)
            for e in errors:
                print("  - " + e)
            return 1
        print("PASS: %d swarms (%s), %d obstacles; positions, ids, velocities at HDF5 frames %s "
              "(Blender frames +1) match the file"
              % (len(res["swarms"]), ", ".join(sorted(res["swarms"])), len(res["obstacles"]),
                 ", ".join(map(str, frames_h5))))
        ok = True
        return 0
    except (Mismatch, subprocess.TimeoutExpired) as e:
        print("FAIL: %s" % e)
        return 1
    finally:
        if ok or not os.environ.get("SWARMSIM_KEEP_TMP"):
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            print("kept %s (SWARMSIM_KEEP_TMP)" % tmp)


if __name__ == "__main__":
    sys.exit(main())
