"""Import a swarmsim trajectory file (HDF5) into Blender.

Command line (recommended form; Blender 3.4+, Blender's Python must import h5py,
which Debian's blender package gets from python3-h5py):

    blender -b [FILE.blend] --factory-startup --python-exit-code 1 \
        --python scripts/blender_import.py -- OUT.h5 \
        [--swarm NAME ...] [--frames A:B] [--clear] [--render-setup] \
        [--point-radius R] [--save OUT.blend]

    Without -b Blender opens its window with the imported scene. --factory-startup
    ignores the user's startup file and add-ons (drop it to import into your own
    startup scene). Errors found by this script (missing file, not a swarmsim file,
    unknown swarm, no h5py) print "blender_import.py: error: ..." and exit with
    status 2 at once; --python-exit-code 1 makes any other Python exception exit
    with 1 too (without it Blender ignores it and exits 0).

From Blender's window: open this file in the Text Editor, set H5_PATH (and the
other settings) below and press Run Script. With H5_PATH empty it opens a file
browser (File > Import > swarmsim trajectory (.h5) is also registered then).

What it makes, all in a new collection named after the scenario (root attribute
scenario_name):
  * one object per swarm, named after the swarm: a mesh of vertices only (a point
    cloud), vertex r = agent r of /swarms/<name>/position;
  * Blender frame f shows HDF5 frame f - 1: frame_start = 1 is HDF5 frame 0 (with
    --frames A:B, HDF5 frames A..B-1 are imported on Blender frames A+1..B, so the
    numbering does not depend on the range). Before frame_start the first imported
    frame is shown and after frame_end the last one;
  * positions are animated with shape keys: the basis is the first imported frame
    and key "frame_NNNN" (NNNN = Blender frame) has value 1 on its frame and 0
    elsewhere (constant interpolation). Plain Blender data: it renders, exports and
    survives saving and re-opening without this script;
  * point attributes: id (INT, /swarms/<name>/id, static), velocity (FLOAT_VECTOR,
    m/s, only if the file has /swarms/<name>/velocity) and present (INT, 1 if the
    agent is in the frame). velocity and present are per frame: the frames are kept
    as attributes velocity_NNNN / present_NNNN and a Geometry Nodes modifier
    "swarmsim frame attributes" copies the current frame's ones into velocity and
    present (no handler; works after re-opening). present_NNNN is only stored when
    some agent of the swarm is absent in some frame; otherwise present is 1;
  * an absent agent (NaN row of position) keeps its last known position (before
    its first appearance: its first known position; never present at all: the
    origin), has present = 0 and velocity = 0. No NaN reaches Blender;
  * one mesh object per /scene/obstacles/NNNN group, named obstacle_NNNN_<type>
    (e.g. obstacle_0000_mesh), in a sub-collection "obstacles";
  * scene frame range, fps = round(1 / frame_dt) and fps_base = fps * frame_dt
    (so fps / fps_base = 1 / frame_dt exactly).
Objects carry custom properties (swarmsim_swarm, swarmsim_obstacle, ...) naming
what they came from, so they can be found again after Blender renamed one
(e.g. "midges.001" on a second import).

--clear deletes the objects of the current scene first (the default startup file
has a cube, a camera and a light). --render-setup adds what a render needs: a
camera looking at the swarms' bounding box (over all imported frames), a sun, a
ground plane, materials and a Geometry Nodes modifier "swarmsim spheres" that puts
a small sphere (radius --point-radius, default from the swarms' size) on every
present agent; the vertices stay, so the evaluated mesh still holds the points.
It uses Cycles (CPU, 32 samples) at 640x360. Render a frame with
    blender -b OUT.blend -o /tmp/frame_#### -f 12
"""

# ---- settings for running from Blender's Text Editor (ignored when arguments
# follow "--" on Blender's command line) -------------------------------------
H5_PATH = ""         # e.g. "/home/me/run.h5"; "" opens a file browser
SWARMS = []          # names of the swarms to import; [] = all
FRAMES = ""          # "A:B" = HDF5 frames A..B-1 (either side may be empty); "" = all
CLEAR = False        # delete the scene's objects first
RENDER_SETUP = False  # add camera, sun, ground, spheres on the points
POINT_RADIUS = 0.0   # sphere radius for RENDER_SETUP in metres; 0 = automatic
SAVE_PATH = ""       # save the .blend here after importing; "" = don't
# ---------------------------------------------------------------------------

import argparse
import math
import os
import sys
import time

import bpy
import numpy as np

FORMAT = "swarmsim-trajectory"
PROG = "blender_import.py"


class ImportFailure(Exception):
    """An error worth a one-line message (bad file, bad option)."""


# ---------------------------------------------------------------------------
# reading the file


def _import_h5py():
    try:
        import h5py  # noqa: F401
    except ImportError as e:
        raise ImportFailure(
            "cannot import h5py in Blender's Python %s: %s. On Debian/Ubuntu "
            "install python3-h5py (sudo apt-get install python3-h5py; Debian's "
            "blender uses the system Python). A blender.org build brings its own "
            "Python: install h5py into it (its python -m pip install h5py)."
            % (sys.version.split()[0], e))
    return h5py


def _str_attr(attrs, name, default=None):
    v = attrs.get(name, default)
    if isinstance(v, bytes):
        v = v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.shape == ():
        v = v[()]
        if isinstance(v, bytes):
            v = v.decode("utf-8", "replace")
    return v


def parse_frames(spec, nframes):
    """'A:B' (Python slice of HDF5 frame indices, no step) -> (a, b)."""
    if not spec:
        return 0, nframes
    if ":" not in spec:
        raise ImportFailure("--frames %r: expected A:B (HDF5 frame indices, B excluded)" % spec)
    a_s, b_s = spec.split(":", 1)
    try:
        a = int(a_s) if a_s.strip() else None
        b = int(b_s) if b_s.strip() else None
    except ValueError:
        raise ImportFailure("--frames %r: A and B must be integers" % spec)
    a, b, _ = slice(a, b).indices(nframes)
    if b <= a:
        raise ImportFailure("--frames %s selects no frame of the %d in the file" % (spec, nframes))
    return a, b


def read_trajectory(path, swarm_names, frames_spec):
    h5py = _import_h5py()
    if not os.path.exists(path):
        raise ImportFailure("%s: no such file" % path)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise ImportFailure("%s: not an HDF5 file (%s)" % (path, e))
    with f:
        fmt = _str_attr(f.attrs, "format")
        if fmt != FORMAT:
            raise ImportFailure("%s: not a swarmsim trajectory file (root attribute format is %r, "
                                "expected %r)" % (path, fmt, FORMAT))
        if "swarms" not in f or "frame_dt" not in f.attrs:
            raise ImportFailure("%s: swarmsim file without /swarms or frame_dt" % path)
        frame_dt = float(f.attrs["frame_dt"])
        names = sorted(f["swarms"].keys())
        if not names:
            raise ImportFailure("%s: the file has no swarm" % path)
        if swarm_names:
            unknown = [n for n in swarm_names if n not in names]
            if unknown:
                raise ImportFailure("%s: no swarm %s (the file has: %s)"
                                    % (path, ", ".join(unknown), ", ".join(names)))
            names = [n for n in names if n in swarm_names]
        # frames actually written (an interrupted run has fewer than the attribute says)
        nframes = min(f["swarms"][n]["position"].shape[0] for n in f["swarms"])
        if "time" in f:
            nframes = min(nframes, f["time"].shape[0])
        if nframes == 0:
            raise ImportFailure("%s: the file has no frame" % path)
        a, b = parse_frames(frames_spec, nframes)
        data = {
            "path": os.path.abspath(path),
            "scenario_name": _str_attr(f.attrs, "scenario_name", "") or
            os.path.splitext(os.path.basename(path))[0],
            "scenario": _str_attr(f.attrs, "scenario", ""),
            "frame_dt": frame_dt,
            "frames_in_file": nframes,
            "first": a,
            "stop": b,
            "swarms": [],
            "obstacles": [],
        }
        for n in names:
            g = f["swarms"][n]
            pos = np.asarray(g["position"][a:b], dtype=np.float32)
            if pos.ndim != 3 or pos.shape[2] != 3:
                raise ImportFailure("%s: /swarms/%s/position has shape %s, expected (frames, agents, 3)"
                                    % (path, n, pos.shape))
            vel = None
            if "velocity" in g:
                vel = np.asarray(g["velocity"][a:b], dtype=np.float32)
                if vel.shape != pos.shape:
                    raise ImportFailure("%s: /swarms/%s/velocity has shape %s, position %s"
                                        % (path, n, vel.shape, pos.shape))
            ids = (np.asarray(g["id"][:], dtype=np.int64) if "id" in g
                   else np.arange(pos.shape[1], dtype=np.int64))
            if ids.shape != (pos.shape[1],):
                raise ImportFailure("%s: /swarms/%s/id has %s entries for %d agents"
                                    % (path, n, ids.shape, pos.shape[1]))
            data["swarms"].append({"name": n, "position": pos, "velocity": vel, "id": ids,
                                   "model": _str_attr(g.attrs, "model", "")})
        if "scene" in f and "obstacles" in f["scene"]:
            for key in sorted(f["scene"]["obstacles"].keys()):
                g = f["scene"]["obstacles"][key]
                v = np.asarray(g["vertices"][:], dtype=np.float64).reshape(-1, 3)
                fc = np.asarray(g["faces"][:], dtype=np.int64).reshape(-1, 3)
                if fc.size and (fc.min() < 0 or fc.max() >= len(v)):
                    raise ImportFailure("%s: /scene/obstacles/%s/faces index a vertex out of range"
                                        % (path, key))
                data["obstacles"].append({"key": key, "type": _str_attr(g.attrs, "type", "mesh"),
                                          "params": _str_attr(g.attrs, "params", ""),
                                          "vertices": v, "faces": fc})
    return data


def fill_absent(pos):
    """(T, N, 3) with NaN rows -> (filled positions, present (T, N) bool).

    An absent agent keeps its last known position; before its first appearance it
    takes its first known position; an agent never present is put at the origin."""
    present = ~np.isnan(pos).any(axis=2)
    if present.all():
        return pos, present
    T, N = present.shape
    t = np.arange(T)[:, None]
    last = np.maximum.accumulate(np.where(present, t, -1), axis=0)
    first = np.argmax(present, axis=0)  # 0 when never present
    idx = np.where(last < 0, first[None, :], last)
    filled = pos[idx, np.arange(N)[None, :]]
    filled = np.nan_to_num(filled, nan=0.0)
    return np.ascontiguousarray(filled, dtype=np.float32), present


# ---------------------------------------------------------------------------
# Geometry Nodes helpers (Blender 3.x API, with the 4.x interface where it differs)


def _group_socket(ng, in_out, socket_type, name):
    if hasattr(ng, "interface"):  # Blender 4.0+
        return ng.interface.new_socket(name, in_out=in_out, socket_type=socket_type)
    coll = ng.inputs if in_out == "INPUT" else ng.outputs
    return coll.new(socket_type, name)


def _enabled(sockets, name):
    for s in sockets:
        if s.name == name and s.enabled:
            return s
    raise KeyError(name)


def _new_geometry_group(name):
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    _group_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
    _group_socket(ng, "OUTPUT", "NodeSocketGeometry", "Geometry")
    gin = ng.nodes.new("NodeGroupInput")
    gout = ng.nodes.new("NodeGroupOutput")
    gin.location = (-900, 0)
    gout.location = (700, 0)
    return ng, gin, gout


def frame_attributes_group(bases, first_frame, last_frame, width):
    """Node group copying attribute <base>_<frame> into <base> for each (base, type),
    frame = current Blender frame (floored, clamped to the imported range), written
    with `width` digits."""
    ng, gin, gout = _new_geometry_group("swarmsim frame attributes")
    L = ng.links
    t = ng.nodes.new("GeometryNodeInputSceneTime")
    t.location = (-900, -300)
    fl = ng.nodes.new("ShaderNodeMath")
    fl.operation = "FLOOR"
    L.new(t.outputs["Frame"], fl.inputs[0])
    lo = ng.nodes.new("ShaderNodeMath")
    lo.operation = "MAXIMUM"
    lo.inputs[1].default_value = first_frame
    L.new(fl.outputs[0], lo.inputs[0])
    hi = ng.nodes.new("ShaderNodeMath")
    hi.operation = "MINIMUM"
    hi.inputs[1].default_value = last_frame
    L.new(lo.outputs[0], hi.inputs[0])
    # zero padding: str(frame + 10**width)[1:]
    add = ng.nodes.new("ShaderNodeMath")
    add.operation = "ADD"
    add.inputs[1].default_value = 10 ** width
    L.new(hi.outputs[0], add.inputs[0])
    tostr = ng.nodes.new("FunctionNodeValueToString")
    tostr.inputs["Decimals"].default_value = 0
    L.new(add.outputs[0], tostr.inputs["Value"])
    sl = ng.nodes.new("FunctionNodeSliceString")
    sl.inputs["Position"].default_value = 1
    sl.inputs["Length"].default_value = width
    L.new(tostr.outputs["String"], sl.inputs["String"])
    for i, n in enumerate((t, fl, lo, hi, add, tostr, sl)):
        n.location = (-900 + 150 * i, -300)
    geo = gin.outputs["Geometry"]
    x = -150
    for base, dtype in bases:
        # "<base>_#" with # replaced by the padded frame (Join Strings would depend on
        # the order of the links of its multi-input socket)
        name = ng.nodes.new("FunctionNodeReplaceString")
        name.inputs["String"].default_value = base + "_#"
        name.inputs["Find"].default_value = "#"
        L.new(sl.outputs["String"], name.inputs["Replace"])
        read = ng.nodes.new("GeometryNodeInputNamedAttribute")
        read.data_type = dtype
        L.new(name.outputs["String"], read.inputs["Name"])
        store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = dtype
        store.domain = "POINT"
        store.inputs["Name"].default_value = base
        L.new(geo, store.inputs["Geometry"])
        L.new(_enabled(read.outputs, "Attribute"), _enabled(store.inputs, "Value"))
        name.location = (x - 150, -500)
        read.location = (x, -500)
        store.location = (x + 150, 0)
        geo = store.outputs["Geometry"]
        x += 400
    L.new(geo, gout.inputs["Geometry"])
    return ng


def spheres_group():
    """Node group: the points plus an ico sphere instanced on every present point."""
    ng, gin, gout = _new_geometry_group("swarmsim spheres")
    r_in = _group_socket(ng, "INPUT", "NodeSocketFloat", "Radius")
    m_in = _group_socket(ng, "INPUT", "NodeSocketMaterial", "Material")
    L = ng.links
    ico = ng.nodes.new("GeometryNodeMeshIcoSphere")
    ico.inputs["Subdivisions"].default_value = 2
    L.new(gin.outputs[r_in.name], ico.inputs["Radius"])
    smooth = ng.nodes.new("GeometryNodeSetShadeSmooth")
    L.new(ico.outputs["Mesh"], smooth.inputs["Geometry"])
    mat = ng.nodes.new("GeometryNodeSetMaterial")
    L.new(smooth.outputs["Geometry"], mat.inputs["Geometry"])
    L.new(gin.outputs[m_in.name], mat.inputs["Material"])
    present = ng.nodes.new("GeometryNodeInputNamedAttribute")
    present.data_type = "INT"
    present.inputs["Name"].default_value = "present"
    inst = ng.nodes.new("GeometryNodeInstanceOnPoints")
    L.new(gin.outputs["Geometry"], inst.inputs["Points"])
    L.new(_enabled(present.outputs, "Attribute"), inst.inputs["Selection"])
    L.new(mat.outputs["Geometry"], inst.inputs["Instance"])
    join = ng.nodes.new("GeometryNodeJoinGeometry")
    L.new(gin.outputs["Geometry"], join.inputs["Geometry"])
    L.new(inst.outputs["Instances"], join.inputs["Geometry"])
    L.new(join.outputs["Geometry"], gout.inputs["Geometry"])
    for i, n in enumerate((ico, smooth, mat)):
        n.location = (-700 + 200 * i, -300)
    present.location = (-300, -150)
    inst.location = (0, 0)
    join.location = (300, 0)
    return ng


def _set_modifier_input(mod, ng, name, value):
    if hasattr(ng, "interface"):
        ident = [s.identifier for s in ng.interface.items_tree
                 if getattr(s, "in_out", "") == "INPUT" and s.name == name][0]
    else:
        ident = ng.inputs[name].identifier
    mod[ident] = value


# ---------------------------------------------------------------------------
# building the scene


def _mesh_from_arrays(name, verts, faces=None):
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", np.ascontiguousarray(verts, dtype=np.float32).ravel())
    if faces is not None and len(faces):
        nf = len(faces)
        me.loops.add(3 * nf)
        me.loops.foreach_set("vertex_index", np.ascontiguousarray(faces, dtype=np.int32).ravel())
        me.polygons.add(nf)
        me.polygons.foreach_set("loop_start", np.arange(0, 3 * nf, 3, dtype=np.int32))
        try:
            me.polygons.foreach_set("loop_total", np.full(nf, 3, dtype=np.int32))
        except (AttributeError, TypeError):  # read-only in Blender 4.x (derived from loop_start)
            pass
    me.update(calc_edges=True)
    return me


def build_swarm(sw, first_frame, width, coll):
    name = sw["name"]
    pos, present = fill_absent(sw["position"])
    T, N = present.shape
    me = _mesh_from_arrays(name, pos[0])
    ob = bpy.data.objects.new(name, me)
    coll.objects.link(ob)
    ob["swarmsim_swarm"] = name
    ob["swarmsim_model"] = sw["model"]
    ob["swarmsim_frame_start"] = first_frame
    ob["swarmsim_frame_end"] = first_frame + T - 1

    ids = sw["id"]
    if ids.size and (ids.min() < -2**31 or ids.max() >= 2**31):
        raise ImportFailure("swarm %s: ids do not fit Blender's 32-bit INT attribute" % name)
    me.attributes.new("id", "INT", "POINT").data.foreach_set("value", ids.astype(np.int32))

    # positions: basis = first imported frame, one shape key per later frame
    if T > 1:
        ob.shape_key_add(name="Basis", from_mix=False)
        key = me.shape_keys
        key.use_relative = True
        key.name = name + " frames"
        names = []
        for t in range(1, T):
            kb = ob.shape_key_add(name="frame_%0*d" % (width, first_frame + t), from_mix=False)
            kb.data.foreach_set("co", pos[t].ravel())
            names.append(kb.name)
        key.animation_data_create()
        act = bpy.data.actions.new(name + " frames")
        key.animation_data.action = act
        for t, kname in enumerate(names, start=1):
            f = first_frame + t
            pts = [(f - 1, 0.0), (f, 1.0)]
            if t < T - 1:
                pts.append((f + 1, 0.0))
            fc = act.fcurves.new('key_blocks["%s"].value' % kname)
            fc.keyframe_points.add(len(pts))
            fc.keyframe_points.foreach_set("co", np.array(pts, dtype=np.float32).ravel())
            for kp in fc.keyframe_points:
                kp.interpolation = "CONSTANT"
            fc.update()

    # per-frame attributes
    bases = []
    vel = sw["velocity"]
    if vel is not None:
        vel = np.where(present[:, :, None], np.nan_to_num(vel, nan=0.0), 0.0).astype(np.float32)
        me.attributes.new("velocity", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", vel[0].ravel())
        if T > 1:
            for t in range(T):
                a = me.attributes.new("velocity_%0*d" % (width, first_frame + t), "FLOAT_VECTOR", "POINT")
                a.data.foreach_set("vector", vel[t].ravel())
            bases.append(("velocity", "FLOAT_VECTOR"))
    pres = present.astype(np.int32)
    me.attributes.new("present", "INT", "POINT").data.foreach_set("value", pres[0])
    if T > 1 and not present.all():
        for t in range(T):
            a = me.attributes.new("present_%0*d" % (width, first_frame + t), "INT", "POINT")
            a.data.foreach_set("value", pres[t])
        bases.append(("present", "INT"))
    if bases:
        ng = frame_attributes_group(bases, first_frame, first_frame + T - 1, width)
        mod = ob.modifiers.new("swarmsim frame attributes", "NODES")
        mod.node_group = ng
    return ob, pos, present


def build_obstacle(ob_data, coll):
    key, typ = ob_data["key"], ob_data["type"]
    name = "obstacle_%s_%s" % (key, typ)
    me = _mesh_from_arrays(name, ob_data["vertices"], ob_data["faces"])
    if len(me.polygons) and typ != "box":
        me.polygons.foreach_set("use_smooth", np.ones(len(me.polygons), dtype=bool))
        if hasattr(me, "use_auto_smooth"):  # up to Blender 4.0
            me.use_auto_smooth = True
            me.auto_smooth_angle = math.radians(35)
    ob = bpy.data.objects.new(name, me)
    coll.objects.link(ob)
    ob["swarmsim_obstacle"] = key
    ob["swarmsim_type"] = typ
    if ob_data["params"]:
        ob["swarmsim_params"] = ob_data["params"]
    return ob


def set_frame_rate(scene, frame_dt):
    if not (frame_dt > 0 and math.isfinite(frame_dt)):
        print("%s: warning: frame_dt = %r, keeping the scene's frame rate" % (PROG, frame_dt))
        return
    fps = min(max(int(round(1.0 / frame_dt)), 1), 1000)
    scene.render.fps = fps
    scene.render.fps_base = fps * frame_dt


def _material(name, rgb, roughness=0.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (rgb[0], rgb[1], rgb[2], 1.0)
        bsdf.inputs["Roughness"].default_value = roughness
    m.diffuse_color = (rgb[0], rgb[1], rgb[2], 1.0)
    return m


SWARM_COLOURS = [(0.9, 0.35, 0.05), (0.1, 0.35, 0.9), (0.15, 0.7, 0.2), (0.8, 0.1, 0.5),
                 (0.9, 0.8, 0.1), (0.1, 0.7, 0.8)]


def render_setup(scene, coll, swarms, obstacles, point_radius, ground_z):
    """Camera on the swarms' bounding box, sun, ground, spheres on the points."""
    pts = [pos[present] for (_, pos, present) in swarms if present.any()]
    if pts:
        allp = np.concatenate(pts)
        lo, hi = allp.min(axis=0).astype(float), allp.max(axis=0).astype(float)
    else:
        lo, hi = np.array([-1.0, -1, 0]), np.array([1.0, 1, 2])
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 0.05)
    if point_radius <= 0:
        point_radius = max(radius * 0.01, 1e-4)

    ng = spheres_group()
    for i, (ob, _, _) in enumerate(swarms):
        mat = _material(ob.name + " agents", SWARM_COLOURS[i % len(SWARM_COLOURS)], 0.4)
        mod = ob.modifiers.new("swarmsim spheres", "NODES")
        mod.node_group = ng
        _set_modifier_input(mod, ng, "Radius", point_radius)
        _set_modifier_input(mod, ng, "Material", mat)
    grey = _material("obstacle", (0.5, 0.5, 0.52), 0.6)
    for ob in obstacles:
        ob.data.materials.append(grey)

    # camera: from the south-west-ish, 20 degrees up, the box's bounding sphere in view
    from mathutils import Vector
    cam_data = bpy.data.cameras.new("swarmsim camera")
    cam_data.lens = 35
    cam = bpy.data.objects.new("swarmsim camera", cam_data)
    coll.objects.link(cam)
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.resolution_percentage = 100
    fov = 2 * math.atan(cam_data.sensor_width / 2 / cam_data.lens)  # horizontal
    fov_v = 2 * math.atan(math.tan(fov / 2) * 360 / 640)
    dist = radius / math.sin(min(fov, fov_v) / 2) * 1.05
    az, el = math.radians(-60), math.radians(20)
    d = Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)))
    cam.location = Vector(centre.tolist()) + d * dist
    cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
    cam_data.clip_start = max(dist / 1000, 1e-3)
    cam_data.clip_end = dist * 100
    scene.camera = cam

    sun_data = bpy.data.lights.new("swarmsim sun", "SUN")
    sun_data.energy = 2.5
    sun_data.angle = math.radians(5)
    sun = bpy.data.objects.new("swarmsim sun", sun_data)
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    coll.objects.link(sun)

    size = 6 * radius
    gv = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float) * size
    gv += [centre[0], centre[1], ground_z if ground_z is not None else lo[2]]
    gme = _mesh_from_arrays("swarmsim ground", gv, np.array([[0, 1, 2], [0, 2, 3]]))
    gme.materials.append(_material("ground", (0.3, 0.3, 0.28), 0.9))
    ground = bpy.data.objects.new("swarmsim ground", gme)
    coll.objects.link(ground)

    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg is not None:
        bg.inputs["Color"].default_value = (0.6, 0.7, 0.85, 1.0)
        bg.inputs["Strength"].default_value = 0.5

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.use_denoising = False
    scene.render.image_settings.file_format = "PNG"
    return point_radius


def _ground_from_scenario(text):
    """domain.min z of the scenario JSON kept in the file, or None."""
    if not text:
        return None
    try:
        import json
        return float(json.loads(text)["domain"]["min"][2])
    except Exception:
        return None


def import_trajectory(path, swarms=(), frames="", clear=False, setup_render=False,
                      point_radius=0.0, save=""):
    t0 = time.perf_counter()
    data = read_trajectory(path, list(swarms), frames)
    t_read = time.perf_counter() - t0
    scene = bpy.context.scene
    if clear:
        for ob in list(scene.objects):
            bpy.data.objects.remove(ob, do_unlink=True)
    first_frame = data["first"] + 1
    last_frame = data["stop"]
    width = max(4, len(str(last_frame)))

    coll = bpy.data.collections.new(data["scenario_name"])
    scene.collection.children.link(coll)
    coll["swarmsim_file"] = data["path"]
    coll["swarmsim_frame_dt"] = data["frame_dt"]
    built = []
    for sw in data["swarms"]:
        built.append(build_swarm(sw, first_frame, width, coll))
    obstacles = []
    if data["obstacles"]:
        ocoll = bpy.data.collections.new("obstacles")
        coll.children.link(ocoll)
        obstacles = [build_obstacle(o, ocoll) for o in data["obstacles"]]

    scene.frame_start = first_frame
    scene.frame_end = last_frame
    scene.frame_current = first_frame
    set_frame_rate(scene, data["frame_dt"])
    if setup_render:
        point_radius = render_setup(scene, coll, built, obstacles, point_radius,
                                    _ground_from_scenario(data["scenario"]))
    elapsed = time.perf_counter() - t0
    agents = sum(p.shape[1] for (_, _, p) in built)
    print("%s: imported %s: %d swarm(s) (%s; %d agents), HDF5 frames %d..%d on Blender frames %d..%d "
          "at %g fps, %d obstacle(s)%s in %.2f s (reading %.2f s)"
          % (PROG, data["path"], len(built), ", ".join(ob.name for ob, _, _ in built), agents,
             data["first"], data["stop"] - 1, first_frame, last_frame,
             scene.render.fps / scene.render.fps_base, len(obstacles),
             (", render setup (sphere radius %.4g m)" % point_radius) if setup_render else "",
             elapsed, t_read))
    if save:
        save = os.path.abspath(save)
        os.makedirs(os.path.dirname(save), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=save, check_existing=False)
        print("%s: saved %s" % (PROG, save))
    return coll


# ---------------------------------------------------------------------------
# File > Import operator (UI use)


class SWARMSIM_OT_import(bpy.types.Operator):
    """Import a swarmsim trajectory file (HDF5)"""
    bl_idname = "import_scene.swarmsim"
    bl_label = "Import swarmsim trajectory"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    filter_glob: bpy.props.StringProperty(default="*.h5;*.hdf5", options={"HIDDEN"})
    frames: bpy.props.StringProperty(name="Frames", description="A:B = HDF5 frames A..B-1; empty = all")
    render_setup: bpy.props.BoolProperty(name="Render setup", default=False)

    def execute(self, context):
        try:
            import_trajectory(self.filepath, frames=self.frames, setup_render=self.render_setup)
        except ImportFailure as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


def _menu_import(self, context):
    self.layout.operator(SWARMSIM_OT_import.bl_idname, text="swarmsim trajectory (.h5)")


def register_operator():
    try:
        bpy.utils.unregister_class(bpy.types.IMPORT_SCENE_OT_swarmsim)
    except (AttributeError, RuntimeError):
        pass
    bpy.utils.register_class(SWARMSIM_OT_import)
    menu = bpy.types.TOPBAR_MT_file_import
    for fn in list(menu._dyn_ui_initialize()):  # running the script again: one menu entry
        if getattr(fn, "__name__", "") == _menu_import.__name__:
            menu.remove(fn)
    menu.append(_menu_import)


# ---------------------------------------------------------------------------


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="blender -b [FILE.blend] --python-exit-code 1 --python scripts/blender_import.py --",
        description="Import a swarmsim trajectory (HDF5) into Blender: one animated point-cloud "
                    "object per swarm (Blender frame = HDF5 frame index + 1), obstacles as meshes.")
    p.add_argument("h5", help="swarmsim output file (build/swarmsim run SCENARIO -o OUT.h5)")
    p.add_argument("--swarm", action="append", default=[], metavar="NAME",
                   help="import this swarm only (repeatable; default: all)")
    p.add_argument("--frames", default="", metavar="A:B",
                   help="HDF5 frames A..B-1 (Python slice, either side may be empty); default: all")
    p.add_argument("--clear", action="store_true", help="delete the scene's objects first")
    p.add_argument("--render-setup", action="store_true",
                   help="add camera, sun, ground plane, materials and spheres on the points (Cycles, 640x360)")
    p.add_argument("--point-radius", type=float, default=0.0, metavar="R",
                   help="sphere radius in metres for --render-setup (default: from the swarms' size)")
    p.add_argument("--save", default="", metavar="OUT.blend", help="save the .blend file")
    return p.parse_args(argv)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else None
    try:
        if argv is not None:
            a = parse_args(argv)
            import_trajectory(a.h5, a.swarm, a.frames, a.clear, a.render_setup, a.point_radius, a.save)
        elif H5_PATH:
            import_trajectory(H5_PATH, SWARMS, FRAMES, CLEAR, RENDER_SETUP, POINT_RADIUS, SAVE_PATH)
        elif not bpy.app.background:
            register_operator()
            bpy.ops.import_scene.swarmsim("INVOKE_DEFAULT")
        else:
            raise ImportFailure("no file given: blender -b --python scripts/blender_import.py -- OUT.h5 "
                                "[--save OUT.blend] (or set H5_PATH at the top of the script)")
    except ImportFailure as e:
        print("%s: error: %s" % (PROG, e), file=sys.stderr)
        if bpy.app.background:
            sys.stderr.flush()
            sys.exit(2)
        raise  # in Blender's window sys.exit would close Blender: show the error instead


if __name__ == "__main__":
    main()
