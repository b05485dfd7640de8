#!/usr/bin/python3
"""Render a swarmsim trajectory file (HDF5) to an image (one frame) or an MP4 video (every frame).

Usage:
  scripts/preview.py OUT.h5 -o image.png [--frame N] [--trail K] [--swarm NAME]
                     [--view 3d|xy|xz|yz] [--bounds auto|domain|agents]
                     [--size W H] [--dpi DPI] [--no-obstacles]
  scripts/preview.py OUT.h5 --video movie.mp4 [--fps N] [--frames A:B] [--force]
                     [--trail K] [--swarm NAME] [--view ...] [--bounds ...]
                     [--size W H] [--dpi DPI] [--no-obstacles]

Needs Debian's python3-h5py and python3-matplotlib, hence /usr/bin/python3
(scripts/setup.sh installs them), and ffmpeg with libx264 for --video.
Positions are read one frame slice at a time (plus the trail frames), never the
whole dataset, so multi-GB files are fine; a video keeps only the last K+1
frames in memory. Above 50,000 agents in total, every k-th agent is drawn (the
same agents in every frame, so trails stay consistent) and the title says so.

The obstacles of the file's /scene group are drawn as translucent grey
triangles behind the insects, cut off at the axis limits (3d: the limits box;
xy/xz/yz: the two drawn axes, and the domain along the third).

Axis limits (--bounds): `domain` is the scenario's domain; `agents` the box
around the drawn agents (all drawn frames, trails included); `auto` (default)
zooms to the box around the agents and the parts of the obstacles inside the
domain when that box is less than half of the domain on every axis, and shows
the domain otherwise (obstacles outside the domain, e.g. a large ground plane,
never widen the limits). A video keeps the same limits in every frame.

--video renders the frames A..B-1 (default: all) in one process: one figure,
per frame only the insects, trails, stimuli and the frame label are redrawn
over a saved background, and the RGB frames are piped into one ffmpeg (H.264,
yuv420p, even pixel sizes; default 960x540 pixels: --size 9.6 5.4 at
--dpi 100). ffmpeg writes a temporary .NAME.*.part.mp4 beside the target,
renamed into place at the end; on an error or Ctrl-C it is removed. An
existing target is replaced only with --force, and never when it is not a
regular file (a directory, FIFO, device, or a symlink to one; a symlink to a
regular file has the file it points to replaced).

Exit codes: 0 success, 2 invalid input (missing file, swarm or frame, bad
option), 3 the image or video cannot be written (or the target exists without
--force, or is not a regular file, or ffmpeg is missing or fails),
130 interrupted (Ctrl-C), 143 terminated (SIGTERM).
"""

import argparse
import json
import math
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time as wallclock

import matplotlib

matplotlib.use("Agg")  # no display needed

import h5py  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from mpl_toolkits.mplot3d import proj3d  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

MAX_PLOT_AGENTS = 50_000
EXIT_INPUT = 2
EXIT_OUTPUT = 3
AXES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
AXIS_NAMES = "xyz"
STILL_SIZE = (8.0, 6.0)
VIDEO_SIZE = (9.6, 5.4)  # 960x540 pixels at the default 100 dpi
OBSTACLE_ALPHA = 0.35
# draw order (3-D axes draw by zorder, not by depth: obstacles always lie behind the insects)
Z_OBSTACLES, Z_DOMAIN, Z_TRAILS, Z_AGENTS, Z_STIMULI = 1.0, 1.5, 2.0, 3.0, 4.0


class PreviewError(Exception):
    def __init__(self, message, code=EXIT_INPUT):
        super().__init__(message)
        self.code = code


class Interrupted(Exception):
    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.code = 128 + signum


def frame_range(text):
    """--frames A:B, Python slice style: A..B-1; either side may be empty or negative (from the end)."""
    parts = text.split(":")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError("expected A:B (frames A..B-1, e.g. 0:100, 50:, :-10), got '%s'" % text)
    try:
        return tuple(int(p) if p.strip() else None for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError("expected integers in A:B, got '%s'" % text)


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="preview.py",
        description="Render one frame of a swarmsim HDF5 trajectory to an image (PNG, SVG, PDF, ...), "
                    "or every frame to an MP4 video (--video).",
    )
    p.add_argument("file", metavar="OUT.h5", help="swarmsim output file")
    p.add_argument("-o", "--output", metavar="IMAGE",
                   help="image to write; the format follows the extension")
    p.add_argument("--video", metavar="OUT.mp4",
                   help="write an MP4 video (H.264) of the run instead of an image (needs ffmpeg)")
    p.add_argument("--frame", type=int, default=None, metavar="N",
                   help="image: frame to draw; negative counts from the end (default: -1, the last)")
    p.add_argument("--frames", type=frame_range, default=None, metavar="A:B",
                   help="video: render frames A..B-1 (default: all; empty or negative ends as in Python slices)")
    p.add_argument("--fps", type=float, default=None, metavar="N",
                   help="video: frames per second (default: the run's, round(1/frame_dt))")
    p.add_argument("--force", action="store_true",
                   help="video: replace an existing regular file")
    p.add_argument("--trail", type=int, default=0, metavar="K",
                   help="also draw the K previous frames as fading trails (default: 0)")
    p.add_argument("--swarm", action="append", metavar="NAME",
                   help="draw only this swarm (repeatable; default: all swarms)")
    p.add_argument("--view", choices=["3d", "xy", "xz", "yz"], default="3d",
                   help="3-D perspective or an orthographic projection onto two axes (default: 3d)")
    p.add_argument("--bounds", choices=["auto", "domain", "agents"], default="auto",
                   help="axis limits: the scenario's domain, the drawn agents' bounding box, or auto: the "
                        "box around the agents and the obstacles inside the domain when it is less than half "
                        "of the domain on every axis, else the domain (default: auto)")
    p.add_argument("--size", type=float, nargs=2, default=None, metavar=("W", "H"),
                   help="figure size in inches, times --dpi gives pixels (default: 8 6; video: 9.6 5.4)")
    p.add_argument("--dpi", type=int, default=100, help="resolution in dots per inch (default: 100)")
    p.add_argument("--no-obstacles", action="store_true", help="do not draw the obstacles of /scene")
    args = p.parse_args(argv)
    if (args.output is None) == (args.video is None):
        p.error("give either -o IMAGE (one frame) or --video OUT.mp4 (every frame)")
    if args.video is not None and args.frame is not None:
        p.error("--frame is for images; a video takes --frames A:B")
    if args.video is None:
        for name, value in (("--frames", args.frames), ("--fps", args.fps)):
            if value is not None:
                p.error("%s is for videos (--video OUT.mp4)" % name)
        if args.frame is None:
            args.frame = -1
    if args.fps is not None and not (math.isfinite(args.fps) and 0 < args.fps <= 1000):
        p.error("--fps: expected a number in (0, 1000], got %g" % args.fps)
    if args.trail < 0:
        p.error("--trail: expected K >= 0, got %d" % args.trail)
    if args.size is None:
        args.size = list(VIDEO_SIZE if args.video is not None else STILL_SIZE)
    if not (args.size[0] > 0 and args.size[1] > 0):
        p.error("--size: expected two positive numbers")
    if args.dpi <= 0:
        p.error("--dpi: expected a positive integer")
    return args


def text_attr(obj, name, default=None):
    if name not in obj.attrs:
        return default
    v = obj.attrs[name]
    if isinstance(v, bytes):
        v = v.decode("utf-8", "replace")
    return str(v)


def open_trajectory(path):
    if not os.path.exists(path):
        raise PreviewError("%s: no such file" % path)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise PreviewError("%s: cannot open as HDF5 (%s)" % (path, e))
    if text_attr(f, "format") != "swarmsim-trajectory":
        f.close()
        raise PreviewError("%s: not a swarmsim trajectory (no format attribute 'swarmsim-trajectory')" % path)
    return f


def scenario_of(f):
    try:
        return json.loads(text_attr(f, "scenario", "{}"))
    except ValueError:
        return {}


def domain_of(scenario):
    try:
        lo = np.array(scenario["domain"]["min"], dtype=float)
        hi = np.array(scenario["domain"]["max"], dtype=float)
        if lo.shape == (3,) and hi.shape == (3,) and np.all(hi > lo):
            return lo, hi
    except (KeyError, TypeError, ValueError):
        pass
    return None


def swarm_names(f, scenario):
    """Swarms in scenario order (falls back to the group order)."""
    if "swarms" not in f:
        return []
    names = [s.get("name") for s in scenario.get("swarms", []) if isinstance(s, dict)]
    names = [n for n in names if n in f["swarms"]]
    return names or list(f["swarms"].keys())


def pick_frame(requested, frames, path):
    f = requested + frames if requested < 0 else requested
    if not 0 <= f < frames:
        raise PreviewError("%s: no frame %d (the file has %d frames: 0..%d, or -1..-%d from the end)"
                           % (path, requested, frames, frames - 1, frames))
    return f


def domain_edges(lo, hi):
    """The 12 edges of the domain box as pairs of 3-D points."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    edges = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(corners[i] != corners[j]) == 1:
                edges.append((corners[i], corners[j]))
    return edges


# ---------------------------------------------------------------------------------------------- input


class Source:
    """The open file: the chosen swarms' position datasets, frame count, scene and metadata."""

    def __init__(self, args):
        self.path = args.file
        self.f = open_trajectory(args.file)
        try:
            self._load(args)
        except BaseException:
            self.f.close()
            raise

    def _load(self, args):
        f = self.f
        self.scenario = scenario_of(f)
        available = swarm_names(f, self.scenario)
        if not available:
            raise PreviewError("%s: no swarms in the file" % self.path)
        self.chosen = list(dict.fromkeys(args.swarm)) if args.swarm else available
        for name in self.chosen:
            if name not in available:
                raise PreviewError("%s: no swarm '%s' (the file has: %s)" % (self.path, name, ", ".join(available)))
        self.datasets = []
        for name in self.chosen:
            group = f["swarms"][name]
            if "position" not in group:
                raise PreviewError("%s: swarm '%s' has no position dataset (the run's output.quantities left it out)"
                                   % (self.path, name))
            ds = group["position"]
            if len(ds.shape) != 3 or ds.shape[2] != 3:
                raise PreviewError("%s: swarm '%s': position has shape %s, expected (frames, agents, 3)"
                                   % (self.path, name, ds.shape))
            self.datasets.append((name, ds))
        self.frames = min(ds.shape[0] for _, ds in self.datasets)
        self.time = f["time"] if "time" in f else None
        if self.time is not None:
            self.frames = min(self.frames, self.time.shape[0])
        if self.frames == 0:
            raise PreviewError("%s: the file holds no frames" % self.path)
        self.total = sum(ds.shape[1] for _, ds in self.datasets)
        self.stride = max(1, math.ceil(self.total / MAX_PLOT_AGENTS))
        self.counts = [ds.shape[1] for _, ds in self.datasets]
        self.title_name = text_attr(f, "scenario_name", self.scenario.get("name", os.path.basename(self.path)))
        self.complete = text_attr(f, "complete", "1") != "0"
        self.domain = domain_of(self.scenario)
        try:
            self.frame_dt = float(f.attrs["frame_dt"])
        except (KeyError, TypeError, ValueError):
            self.frame_dt = float("nan")
        self.obstacles = [] if args.no_obstacles else read_obstacles(f, self.path)

    def close(self):
        self.f.close()

    def block(self, first, last):
        """Frames first..last (inclusive) of every chosen swarm, every stride-th agent: [(frames, n, 3)]."""
        return [np.asarray(ds[first:last + 1, ::self.stride, :], dtype=np.float64) for _, ds in self.datasets]

    def time_at(self, frame):
        return float(self.time[frame]) if self.time is not None else float("nan")

    def agent_box(self, first, last):
        """Raw (unpadded) bounding box of the drawn agents over frames first..last, one frame at a time."""
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        for i in range(first, last + 1):
            for pts in self.block(i, i):
                pts = pts.reshape(-1, 3)
                pts = pts[np.all(np.isfinite(pts), axis=1)]
                if len(pts):
                    lo = np.minimum(lo, pts.min(0))
                    hi = np.maximum(hi, pts.max(0))
        return (lo, hi) if np.all(hi >= lo) else None


def read_obstacles(f, path):
    """/scene/obstacles/<NNNN>: a list of (type, triangles (F, 3, 3)) in scenario order."""
    out = []
    if "scene" not in f or "obstacles" not in f["scene"]:
        return out
    for key in sorted(f["scene"]["obstacles"].keys()):
        g = f["scene"]["obstacles"][key]
        if not isinstance(g, h5py.Group) or "vertices" not in g or "faces" not in g:
            continue
        v = np.asarray(g["vertices"][()], dtype=np.float64)
        faces = np.asarray(g["faces"][()], dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
            print("preview.py: warning: %s: obstacle %s has vertices %s and faces %s, not drawn"
                  % (path, key, v.shape, faces.shape), file=sys.stderr)
            continue
        if faces.size and (faces.min() < 0 or faces.max() >= len(v)):
            print("preview.py: warning: %s: obstacle %s has face indices outside its %d vertices, not drawn"
                  % (path, key, len(v)), file=sys.stderr)
            continue
        tris = v[faces]
        tris = tris[np.all(np.isfinite(tris), axis=(1, 2))]
        if len(tris):
            out.append((text_attr(g, "type", "mesh"), tris))
    return out


def stimuli_at(scenario, swarms, time):
    """The bswarm stimuli of the drawn swarms at `time`: (kind, centre, radius) each."""
    out = []
    for sw in scenario.get("swarms", []):
        if sw.get("name") not in swarms or math.isnan(time):
            continue
        for st in sw.get("params", {}).get("stimuli", []) or []:
            keys = st.get("keyframes") or [{"time": 0.0, "center": st.get("center", [0, 0, 0])}]
            times = [float(k["time"]) for k in keys]
            centre = np.array([np.interp(time, times, [float(k["center"][a]) for k in keys]) for a in range(3)])
            out.append((st.get("type", "attractor"), centre, float(st.get("radius", 0.0))))
    return out


# --------------------------------------------------------------------------------------------- bounds


def pad_box(lo, hi):
    # pad by 8% of the largest extent so a flat or thin swarm still gets a box
    pad = max(0.08 * float(np.max(hi - lo)), 1e-3)
    return lo - pad, hi + pad


def obstacle_box(obstacles, domain):
    """Bounding box of the obstacles' parts inside the domain (all of them without a domain), or None."""
    if not obstacles:
        return None
    polys = [t for _, tris in obstacles for t in tris]
    if domain is not None:
        polys = clip_polygons(polys, domain[0], domain[1], (0, 1, 2))
    if not polys:
        return None
    pts = np.concatenate(polys)
    return pts.min(0), pts.max(0)


def choose_bounds(mode, raw_agents, obstacles, domain):
    """(lo, hi, is_domain, note): the axis limits; raw_agents is the agents' unpadded box or None."""
    if domain is not None and (mode == "domain" or (raw_agents is None and mode == "agents")):
        return domain[0], domain[1], True, None
    box = raw_agents
    note = "zoomed to the agents"
    if mode == "auto":
        obox = obstacle_box(obstacles, domain)
        if obox is not None:
            box = obox if box is None else (np.minimum(box[0], obox[0]), np.maximum(box[1], obox[1]))
            note = "zoomed to the agents and obstacles"
    if box is None:
        return (domain[0], domain[1], True, None) if domain is not None else (np.zeros(3), np.ones(3), False, None)
    lo, hi = pad_box(*box)
    if mode == "auto" and domain is not None:
        small = np.all((hi - lo) < 0.5 * (domain[1] - domain[0]))
        if not small:
            return domain[0], domain[1], True, None
    return lo, hi, False, note


def raw_box_of(blocks):
    pts = np.concatenate([b.reshape(-1, 3) for b in blocks])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    return (pts.min(0), pts.max(0)) if len(pts) else None


def clip_polygons(polys, lo, hi, axes):
    """Cut polygons (an (F, n, 3) array or a list of (n, 3) arrays) to lo <= p[a] <= hi for a in axes.

    Returns a list of polygons with at least 3 vertices: the ones inside as they are, the ones crossing
    a limit cut (Sutherland-Hodgman), the ones outside left out."""
    axes = list(axes)
    out = []
    if isinstance(polys, np.ndarray):  # triangles: sort out the ones inside and outside at once
        if not len(polys):
            return out
        pmin = polys[:, :, axes].min(1)
        pmax = polys[:, :, axes].max(1)
        outside = np.any((pmax < lo[axes]) | (pmin > hi[axes]), axis=1)
        inside = np.all((pmin >= lo[axes]) & (pmax <= hi[axes]), axis=1) & ~outside
        out = list(polys[inside])
        polys = polys[~inside & ~outside]
    for p in polys:
        pmin = p[:, axes].min(0)
        pmax = p[:, axes].max(0)
        if np.any(pmax < lo[axes]) or np.any(pmin > hi[axes]):
            continue
        if np.all(pmin >= lo[axes]) and np.all(pmax <= hi[axes]):
            out.append(p)
            continue
        poly = list(p)
        for a in axes:
            for bound, sign in ((lo[a], 1.0), (hi[a], -1.0)):
                if len(poly) < 3:
                    break
                cut = []
                for i, u in enumerate(poly):
                    v = poly[(i + 1) % len(poly)]
                    du, dv = sign * (u[a] - bound), sign * (v[a] - bound)
                    if du >= 0:
                        cut.append(u)
                    if (du >= 0) != (dv >= 0):
                        cut.append(u + (v - u) * (du / (du - dv)))
                poly = cut
        if len(poly) >= 3:
            out.append(np.array(poly))
    return out


def shade(polys):
    """Grey RGBA per polygon, lighter where it faces the light (the look of a solid), translucent."""
    out = np.empty((len(polys), 4))
    light = np.array([-0.35, -0.55, 0.76])
    light /= np.linalg.norm(light)
    for i, p in enumerate(polys):
        n = np.cross(p[1] - p[0], p[2] - p[0])
        norm = np.linalg.norm(n)
        lit = abs(float(np.dot(n, light))) / norm if norm > 0 else 0.5
        out[i, :3] = 0.38 + 0.3 * lit
    out[:, 3] = OBSTACLE_ALPHA
    return out


# ------------------------------------------------------------------------------------------- drawing


class Trail3DCollection(LineCollection):
    """3-D polylines (NaN-separated segments) projected with one vectorised call per draw.

    Line3DCollection projects and converts every segment on its own, far too slow for thousands of
    trail segments per frame."""

    def set_lines3d(self, lines):
        self._lines3d = lines
        self.stale = True

    def do_3d_projection(self):
        lines = getattr(self, "_lines3d", [])
        if not lines:
            LineCollection.set_segments(self, [])
            return np.nan
        pts = np.concatenate(lines)
        xs, ys, zs = proj3d.proj_transform(pts[:, 0], pts[:, 1], pts[:, 2], self.axes.M)
        xy = np.column_stack([xs, ys])
        ends = np.cumsum([len(line) for line in lines])[:-1]
        LineCollection.set_segments(self, np.split(xy, ends))
        return float(np.nanmin(zs)) if np.any(np.isfinite(zs)) else np.nan


def trail_lines(block, axes):
    """One NaN-separated polyline per trail age (oldest first): the segments from frame s to s+1."""
    lines = []
    for s in range(block.shape[0] - 1):
        seg = np.full((block.shape[1], 3, len(axes)), np.nan)
        seg[:, 0] = block[s][:, axes]
        seg[:, 1] = block[s + 1][:, axes]
        lines.append(seg.reshape(-1, len(axes)))
    return lines


class Plot:
    """One figure: obstacles, domain box, trails, agents, stimuli, labels. update() moves what moves."""

    def __init__(self, args, src, bounds, blocks, stimuli, trail_ref):
        self.args = args
        self.three_d = args.view == "3d"
        self.axes = (0, 1, 2) if self.three_d else AXES[args.view]
        self.trail_ref = trail_ref  # trail length the fading refers to (newest segment: full alpha)
        # a wide video frame leaves room beside the 3-D box: draw it larger
        self.video = args.video is not None
        self.zoom = 1.15 if self.video else 1.1
        lo, hi, self.is_domain, self.zoom_note = bounds
        self.fig = plt.figure(figsize=tuple(args.size), dpi=args.dpi)
        if self.three_d:
            self.ax = self.fig.add_subplot(projection="3d", computed_zorder=False)
        else:
            self.ax = self.fig.add_subplot()
        ax = self.ax
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        self.colours = [matplotlib.colors.to_rgb(colours[i % len(colours)]) for i in range(len(blocks))]
        shown = sum(b.shape[1] for b in blocks)
        self.shown = shown

        self.draw_obstacles(src, lo, hi)

        # markers and trails get lighter as the crowd grows, so dense swarms stay readable
        self.size = float(np.clip(6000.0 / max(shown, 1), 0.3, 12.0))
        self.trail_alpha = float(np.clip(math.sqrt(150.0 / max(shown, 1)), 0.04, 0.5))
        self.trails, self.scatters = [], []
        extra = {"depthshade": False} if self.three_d else {}
        for i, (name, count, block) in enumerate(zip(src.chosen, src.counts, blocks)):
            if args.trail > 0:
                coll = (Trail3DCollection if self.three_d else LineCollection)([], linewidths=0.7,
                                                                                 zorder=Z_TRAILS)
                ax.add_collection(coll)
                self.trails.append(coll)
            now = block[-1]
            label = "%s (%s agents)" % (name, format(count, ","))
            self.scatters.append(ax.scatter(*[now[:, a] for a in self.axes], s=self.size, color=self.colours[i],
                                            alpha=0.9, linewidths=0, label=label, zorder=Z_AGENTS, **extra))

        self.stimuli = []
        for kind, centre, radius in stimuli:  # red: predator, green: attractor
            colour = "tab:red" if kind == "predator" else "tab:green"
            # a disc roughly the sphere's size (points^2 from the radius relative to the domain)
            dom = src.domain
            extent = max(float(np.max(dom[1] - dom[0])), 1e-9) if dom is not None else 1.0
            area = max(40.0, (radius / extent * 0.8 * 72.0 * max(args.size)) ** 2 * math.pi)
            self.stimuli.append(ax.scatter(*[[centre[a]] for a in self.axes], s=area, color=colour, alpha=0.35,
                                           linewidths=1, edgecolors=colour, label="%s stimulus" % kind,
                                           zorder=Z_STIMULI, **extra))

        self.set_limits(lo, hi)
        for a, axis in enumerate(self.axes):
            getattr(ax, "set_%slabel" % "xyz"[a])("%s (m)" % AXIS_NAMES[axis])
        legend = ax.legend(loc="upper right", fontsize=9, markerscale=max(1.0, 4.0 / math.sqrt(self.size)))
        for h in legend.legend_handles if hasattr(legend, "legend_handles") else legend.legendHandles:
            h.set_alpha(1.0)
            if hasattr(h, "set_sizes"):
                h.set_sizes([30.0])
        self.update(blocks, stimuli)

    def draw_obstacles(self, src, lo, hi):
        tris = [t for _, t in src.obstacles]
        if not tris:
            return
        tris = np.concatenate(tris)
        if self.three_d:
            polys = clip_polygons(tris, lo, hi, (0, 1, 2))
        else:
            a, b = self.axes
            depth = 3 - a - b
            polys = clip_polygons(tris, lo, hi, (a, b))
            if src.domain is not None:  # nothing outside the domain along the axis we look along
                polys = clip_polygons(polys, src.domain[0], src.domain[1], (depth,))
        if not polys:
            return
        colours = shade(polys)
        edges = colours.copy()
        edges[:, :3] *= 0.7
        edges[:, 3] = 0.3
        if self.three_d:
            coll = Poly3DCollection(polys, facecolors=colours, edgecolors=edges, linewidths=0.3,
                                    zorder=Z_OBSTACLES)
            self.ax.add_collection(coll)
        else:
            coll = PolyCollection([p[:, self.axes] for p in polys], facecolors=colours, edgecolors=edges,
                                  linewidths=0.3, zorder=Z_OBSTACLES)
            self.ax.add_collection(coll)
        self.obstacle_collection = coll

    def set_limits(self, lo, hi):
        """Equal-aspect axis limits; the domain is drawn as a grey box when they are the domain."""
        ax = self.ax
        if self.three_d:
            if self.is_domain:
                ax.add_collection(Line3DCollection(domain_edges(lo, hi), colors="0.6", linewidths=0.6,
                                                   zorder=Z_DOMAIN))
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_zlim(lo[2], hi[2])
            ax.set_box_aspect(tuple(hi - lo), zoom=self.zoom)  # equal aspect: a metre is as long on every axis
            ax.view_init(elev=18, azim=-60)
        else:
            a, b = self.axes
            if self.is_domain:
                ax.add_patch(matplotlib.patches.Rectangle((lo[a], lo[b]), hi[a] - lo[a], hi[b] - lo[b],
                                                          fill=False, edgecolor="0.6", linewidth=0.8,
                                                          zorder=Z_DOMAIN))
                margin = 0.02 * max(hi[a] - lo[a], hi[b] - lo[b])
                lo, hi = lo - margin, hi + margin
            ax.set_xlim(lo[a], hi[a])
            ax.set_ylim(lo[b], hi[b])
            ax.set_aspect("equal")

    def update(self, blocks, stimuli):
        """New positions: blocks[i] is (trail frames + 1, agents, 3) for swarm i, the last row is now."""
        for i, block in enumerate(blocks):
            now = block[-1]
            sc = self.scatters[i]
            if self.three_d:
                sc._offsets3d = (now[:, 0], now[:, 1], now[:, 2])
            else:
                sc.set_offsets(now[:, self.axes])
            sc.stale = True
            if self.trails:
                lines = trail_lines(block, self.axes)
                k = len(lines)
                ref = max(self.trail_ref, k, 1)
                # line s joins frames s and s+1 of the block; older lines fade out
                rgba = np.empty((k, 4))
                rgba[:, :3] = self.colours[i]
                rgba[:, 3] = self.trail_alpha * (np.arange(k) + 1 + (ref - k)) / ref
                coll = self.trails[i]
                if self.three_d:
                    coll.set_lines3d(lines)
                else:
                    coll.set_segments(lines)
                coll.set_color(rgba)
        for sc, (_, centre, _) in zip(self.stimuli, stimuli):
            if self.three_d:
                sc._offsets3d = ([centre[0]], [centre[1]], [centre[2]])
            else:
                sc.set_offsets([[centre[a] for a in self.axes]])
            sc.stale = True

    def moving(self):
        return self.trails + self.scatters + self.stimuli

    def layout(self):
        if self.three_d and self.video:
            self.fig.subplots_adjust(left=0.0, right=1.0, bottom=0.04, top=0.92)
        elif self.three_d:
            self.fig.subplots_adjust(left=0.0, right=0.95, bottom=0.04, top=0.9)
        else:
            self.fig.tight_layout()


def notes_of(plot, trail_frames, trail_span, stride, shown, total):
    notes = []
    if not plot.is_domain and plot.zoom_note:
        notes.append(plot.zoom_note)
    if trail_frames > 0:
        span = "" if math.isnan(trail_span) else " = %.2f s" % trail_span
        notes.append("trails: %d frame%s%s" % (trail_frames, "" if trail_frames == 1 else "s", span))
    if stride > 1:
        notes.append("every %d%s agent shown (%s of %s)" % (stride, ordinal_suffix(stride), format(shown, ","),
                                                            format(total, ",")))
    return notes


def ordinal_suffix(n):
    if 10 <= n % 100 <= 20:
        return "th"
    return {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")


# --------------------------------------------------------------------------------------------- image


def render(args):
    src = Source(args)
    try:
        frame = pick_frame(args.frame, src.frames, args.file)
        first = max(0, frame - args.trail)
        time = src.time_at(frame)
        trail_time = time - src.time_at(first)
        blocks = src.block(first, frame)  # frames first..frame, every stride-th agent (an HDF5 hyperslab)
        bounds = choose_bounds(args.bounds, raw_box_of(blocks), src.obstacles, src.domain)
        stimuli = stimuli_at(src.scenario, src.chosen, time)
        plot = Plot(args, src, bounds, blocks, stimuli, trail_ref=frame - first)
    finally:
        src.close()
    try:
        title = "%s  frame %d/%d  t = %.2f s" % (src.title_name, frame, src.frames - 1, time)
        if not src.complete:
            title += "  (incomplete run)"
        notes = notes_of(plot, frame - first, trail_time, src.stride, plot.shown, src.total)
        if notes:
            title += "\n" + "; ".join(notes)
        plot.ax.set_title(title, fontsize=11)
        plot.layout()
        out_dir = os.path.dirname(os.path.abspath(args.output))
        os.makedirs(out_dir, exist_ok=True)
        plot.fig.savefig(args.output, dpi=args.dpi)
    except ValueError as e:  # e.g. an unknown image format
        raise PreviewError("%s: %s" % (args.output, e))
    except OSError as e:
        raise PreviewError("%s: cannot write the image (%s)" % (args.output, e), EXIT_OUTPUT)
    finally:
        plt.close(plot.fig)
    return args.output


# --------------------------------------------------------------------------------------------- video


def check_target(target, force, inputs):
    """The path to write the video to (a symlink's target), or PreviewError when it must not be replaced."""
    if not os.path.lexists(target):
        return target
    real = os.path.realpath(target)
    try:
        st = os.stat(real)
    except OSError:
        raise PreviewError("%s: a symlink to nothing (%s); not replaced" % (target, real), EXIT_OUTPUT)
    if not stat.S_ISREG(st.st_mode):
        kind = ("a directory" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode) else
                "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        link = " (through a symlink)" if os.path.islink(target) else ""
        raise PreviewError("%s is %s%s; not replaced, even with --force" % (target, kind, link), EXIT_OUTPUT)
    for path in inputs:
        if os.path.exists(path) and os.path.samefile(path, real):
            raise PreviewError("%s is the input file; not replaced, even with --force" % target, EXIT_OUTPUT)
    if not force:
        raise PreviewError("%s exists; not replaced without --force" % target, EXIT_OUTPUT)
    return real


def even_pixels(fig, args):
    """Size the figure to even pixel sizes (yuv420p needs them): (width, height)."""
    w = max(2, int(round(args.size[0] * args.dpi / 2.0)) * 2)
    h = max(2, int(round(args.size[1] * args.dpi / 2.0)) * 2)
    # +0.25 px: Agg truncates width*dpi, and 9.6 * 100 is 959.999...
    fig.set_size_inches((w + 0.25) / args.dpi, (h + 0.25) / args.dpi)
    return w, h


def ffmpeg_command(ffmpeg, w, h, fps, out):
    return [ffmpeg, "-hide_banner", "-loglevel", "error", "-y",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", "%dx%d" % (w, h), "-r", "%g" % fps, "-i", "-",
            "-an", "-c:v", "libx264", "-preset", "veryfast", "-crf", "20", "-pix_fmt", "yuv420p",
            "-movflags", "+faststart", "-f", "mp4", out]


def publish(tmp, real, force):
    """Move the finished temporary file to its place (atomic: a rename, or a hard link without --force)."""
    if not force:
        try:
            os.link(tmp, real)  # fails if something appeared there meanwhile: never clobbers
            os.unlink(tmp)
            return
        except FileExistsError:
            raise PreviewError("%s appeared while rendering; not replaced without --force" % real, EXIT_OUTPUT)
        except OSError:
            pass  # no hard links on this file system: check and rename
        if os.path.lexists(real):
            raise PreviewError("%s appeared while rendering; not replaced without --force" % real, EXIT_OUTPUT)
    elif os.path.lexists(real) and not stat.S_ISREG(os.lstat(real).st_mode):
        raise PreviewError("%s became something other than a regular file while rendering; not replaced" % real,
                           EXIT_OUTPUT)
    os.replace(tmp, real)


def render_video(args):
    target = args.video
    real = check_target(target, args.force, [args.file])
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise PreviewError("ffmpeg not found (Debian package ffmpeg; scripts/setup.sh --tools installs it)",
                           EXIT_OUTPUT)
    src = Source(args)
    try:
        return encode(args, src, target, real, ffmpeg)
    finally:
        src.close()


def encode(args, src, target, real, ffmpeg):
    start, stop, _ = slice(*(args.frames or (None, None))).indices(src.frames)
    if stop <= start:
        raise PreviewError("%s: --frames %s selects no frames (the file has %d: 0..%d)"
                           % (args.file, ":".join("" if v is None else str(v) for v in args.frames),
                              src.frames, src.frames - 1))
    count = stop - start
    if args.fps is not None:
        fps = args.fps
    elif math.isfinite(src.frame_dt) and src.frame_dt > 0:
        fps = float(max(1, round(1.0 / src.frame_dt)))
    else:
        fps = 25.0
    t0 = wallclock.monotonic()
    read_from = max(0, start - args.trail)
    times = np.asarray(src.time[start:stop], dtype=np.float64) if src.time is not None else None
    # fixed limits for the whole video: every drawn frame (and the trails before the first)
    raw = src.agent_box(read_from, stop - 1) if args.bounds != "domain" or src.domain is None else None
    bounds = choose_bounds(args.bounds, raw, src.obstacles, src.domain)

    window = [b for b in src.block(read_from, start)]  # frames read_from..start: trail + the first frame
    t_first = float(times[0]) if times is not None else float("nan")
    plot = Plot(args, src, bounds, window, stimuli_at(src.scenario, src.chosen, t_first), trail_ref=args.trail)
    fig = plot.fig
    proc = tmp = None
    try:
        w, h = even_pixels(fig, args)
        title = src.title_name + ("  (incomplete run)" if not src.complete else "")
        notes = notes_of(plot, args.trail, args.trail * src.frame_dt, src.stride, plot.shown, src.total)
        if notes:
            title += "\n" + "; ".join(notes)
        plot.ax.set_title(title, fontsize=11)
        plot.layout()
        label = fig.text(0.012, 0.018, "", fontsize=10, family="monospace", ha="left", va="bottom")
        moving = plot.moving() + [label]
        for a in moving:
            a.set_animated(True)
        canvas = fig.canvas
        canvas.draw()  # everything that stays: axes, obstacles, domain, legend, title
        background = canvas.copy_from_bbox(fig.bbox)
        renderer = canvas.get_renderer()
        if (int(renderer.height), int(renderer.width)) != (h, w):
            raise PreviewError("internal: the canvas is %dx%d, expected %dx%d"
                               % (renderer.width, renderer.height, w, h), EXIT_OUTPUT)

        out_dir = os.path.dirname(real) or "."
        try:
            os.makedirs(out_dir, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(real) + ".", suffix=".part.mp4", dir=out_dir)
            os.close(fd)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        except OSError as e:
            raise PreviewError("%s: cannot write in %s (%s)" % (target, out_dir, e), EXIT_OUTPUT)
        errlog = tempfile.TemporaryFile()
        proc = subprocess.Popen(ffmpeg_command(ffmpeg, w, h, fps, tmp), stdin=subprocess.PIPE,
                                stdout=subprocess.DEVNULL, stderr=errlog)
        rgb = np.empty((h, w, 3), dtype=np.uint8)
        progress = sys.stderr.isatty()
        for n, frame in enumerate(range(start, stop)):
            if n > 0:  # slide the window: drop the oldest frame beyond the trail, read the new one
                new = src.block(frame, frame)
                window = [np.concatenate([b[-args.trail:] if args.trail else b[:0], nb]) for b, nb in
                          zip(window, new)]
            tnow = float(times[n]) if times is not None else float("nan")
            plot.update(window, stimuli_at(src.scenario, src.chosen, tnow) if plot.stimuli else [])
            label.set_text("frame %d/%d  t = %.2f s" % (frame, src.frames - 1, tnow) if not math.isnan(tnow)
                           else "frame %d/%d" % (frame, src.frames - 1))
            canvas.restore_region(background)
            for a in plot.moving():
                if plot.three_d:
                    a.do_3d_projection()
                plot.ax.draw_artist(a)
            label.draw(renderer)
            np.copyto(rgb, np.asarray(canvas.buffer_rgba())[:, :, :3])
            try:
                proc.stdin.write(rgb.data)
            except (BrokenPipeError, OSError):
                break  # ffmpeg stopped: its exit code and message tell why
            if progress and (n % 10 == 0 or n == count - 1):
                print("\rpreview.py: frame %d/%d" % (n + 1, count), end="", file=sys.stderr, flush=True)
        if progress:
            print("\r\033[K", end="", file=sys.stderr, flush=True)
        try:
            proc.stdin.close()
        except (BrokenPipeError, OSError):
            pass
        rc = proc.wait()
        if rc != 0:
            errlog.seek(0)
            msg = errlog.read().decode("utf-8", "replace").strip()
            raise PreviewError("ffmpeg failed (exit code %d)%s" % (rc, (":\n" + msg) if msg else ""), EXIT_OUTPUT)
        proc = None
        try:
            publish(tmp, real, args.force)
        except OSError as e:
            raise PreviewError("%s: cannot move the video into place (%s)" % (target, e), EXIT_OUTPUT)
        tmp = None
        elapsed = wallclock.monotonic() - t0
        print("preview.py: %s: %d frames (%d..%d), %.2f s of video at %g fps, %dx%d; rendered in %.1f s = "
              "%.1f frames/s" % (target, count, start, stop - 1, count / fps, fps, w, h, elapsed,
                                 count / max(elapsed, 1e-9)), file=sys.stderr)
        return target
    finally:
        if proc is not None:  # an error or an interrupt: stop ffmpeg
            proc.kill()
            proc.wait()
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        plt.close(fig)


def on_signal(signum, _frame):
    # once: the clean-up (stop ffmpeg, remove the temporary file) must not be interrupted in turn
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    raise Interrupted(signum)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    if hasattr(signal, "SIGHUP"):
        signal.signal(signal.SIGHUP, on_signal)
    try:
        out = render_video(args) if args.video is not None else render(args)
    except PreviewError as e:
        print("preview.py: error: %s" % e, file=sys.stderr)
        return e.code
    except Interrupted as e:
        print("\npreview.py: interrupted (%s); nothing written" % e, file=sys.stderr)
        return e.code
    print("wrote %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
