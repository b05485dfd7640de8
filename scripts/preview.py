#!/usr/bin/python3
"""Render one frame of a swarmsim trajectory file (HDF5) to an image.

Usage:
  scripts/preview.py OUT.h5 -o image.png [--frame N] [--trail K] [--swarm NAME]
                     [--view 3d|xy|xz|yz] [--bounds auto|domain|agents]
                     [--size W H] [--dpi DPI]

Needs Debian's python3-h5py and python3-matplotlib, hence /usr/bin/python3
(scripts/setup.sh installs them). Positions are read one frame slice at a time
(plus the trail frames), never the whole dataset, so multi-GB files are fine.
Above 50,000 agents in total, every k-th agent is drawn (the same agents in
every frame, so trails stay consistent) and the title says so.

Exit codes: 0 success, 2 invalid input (missing file, swarm or frame, bad
option), 3 the image cannot be written.
"""

import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed

import h5py  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

MAX_PLOT_AGENTS = 50_000
EXIT_INPUT = 2
EXIT_OUTPUT = 3
AXES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
AXIS_NAMES = "xyz"


class PreviewError(Exception):
    def __init__(self, message, code=EXIT_INPUT):
        super().__init__(message)
        self.code = code


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="preview.py",
        description="Render one frame of a swarmsim HDF5 trajectory to an image (PNG, SVG, PDF, ...).",
    )
    p.add_argument("file", metavar="OUT.h5", help="swarmsim output file")
    p.add_argument("-o", "--output", required=True, metavar="IMAGE",
                   help="image to write; the format follows the extension")
    p.add_argument("--frame", type=int, default=-1, metavar="N",
                   help="frame to draw; negative counts from the end (default: -1, the last)")
    p.add_argument("--trail", type=int, default=0, metavar="K",
                   help="also draw the K previous frames as fading trails (default: 0)")
    p.add_argument("--swarm", action="append", metavar="NAME",
                   help="draw only this swarm (repeatable; default: all swarms)")
    p.add_argument("--view", choices=["3d", "xy", "xz", "yz"], default="3d",
                   help="3-D perspective or an orthographic projection onto two axes (default: 3d)")
    p.add_argument("--bounds", choices=["auto", "domain", "agents"], default="auto",
                   help="axis limits: the scenario's domain, the drawn agents' bounding box, or auto: the "
                        "domain unless the agents fill less than half of it on every axis (default: auto)")
    p.add_argument("--size", type=float, nargs=2, default=[8.0, 6.0], metavar=("W", "H"),
                   help="figure size in inches (default: 8 6)")
    p.add_argument("--dpi", type=int, default=100, help="resolution in dots per inch (default: 100)")
    args = p.parse_args(argv)
    if args.trail < 0:
        p.error("--trail: expected K >= 0, got %d" % args.trail)
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


def render(args):
    f = open_trajectory(args.file)
    with f:
        scenario = scenario_of(f)
        available = swarm_names(f, scenario)
        if not available:
            raise PreviewError("%s: no swarms in the file" % args.file)
        chosen = list(dict.fromkeys(args.swarm)) if args.swarm else available
        for name in chosen:
            if name not in available:
                raise PreviewError("%s: no swarm '%s' (the file has: %s)" % (args.file, name, ", ".join(available)))
        datasets = []
        for name in chosen:
            group = f["swarms"][name]
            if "position" not in group:
                raise PreviewError("%s: swarm '%s' has no position dataset (the run's output.quantities left it out)"
                                   % (args.file, name))
            datasets.append((name, group["position"]))

        frames = min(ds.shape[0] for _, ds in datasets)
        if "time" in f:
            frames = min(frames, f["time"].shape[0])
        if frames == 0:
            raise PreviewError("%s: the file holds no frames" % args.file)
        frame = pick_frame(args.frame, frames, args.file)
        first = max(0, frame - args.trail)
        time = float(f["time"][frame]) if "time" in f else float("nan")
        trail_time = time - float(f["time"][first]) if "time" in f else float("nan")

        total = sum(ds.shape[1] for _, ds in datasets)
        stride = max(1, math.ceil(total / MAX_PLOT_AGENTS))

        # read only frames first..frame, every stride-th row (an HDF5 hyperslab)
        data = []
        for name, ds in datasets:
            block = np.asarray(ds[first:frame + 1, ::stride, :], dtype=np.float64)
            data.append((name, ds.shape[1], block))

        title_name = text_attr(f, "scenario_name", scenario.get("name", os.path.basename(args.file)))
        complete = text_attr(f, "complete", "1") != "0"

    shown = sum(block.shape[1] for _, _, block in data)
    domain = domain_of(scenario)
    stimuli = stimuli_at(scenario, chosen, time)
    return draw(args, data, domain, title_name, frame, frames, time, total, shown, stride, complete, trail_time,
                stimuli)


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


def draw(args, data, domain, title_name, frame, frames, time, total, shown, stride, complete, trail_time,
         stimuli=()):
    three_d = args.view == "3d"
    trail_frames = data[0][2].shape[0] - 1
    fig = plt.figure(figsize=tuple(args.size), dpi=args.dpi)
    ax = fig.add_subplot(projection="3d") if three_d else fig.add_subplot()
    axes = (0, 1, 2) if three_d else AXES[args.view]
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]

    # markers and trails get lighter as the crowd grows, so dense swarms stay readable
    size = float(np.clip(6000.0 / max(shown, 1), 0.3, 12.0))
    trail_alpha = float(np.clip(math.sqrt(150.0 / max(shown, 1)), 0.04, 0.5))
    for i, (name, count, block) in enumerate(data):
        colour = matplotlib.colors.to_rgb(colours[i % len(colours)])
        now = block[-1]
        k = block.shape[0] - 1  # trail segments per agent
        if k > 0:
            # segment s joins frame first+s to first+s+1; older segments fade out
            starts = block[:-1][:, :, axes].reshape(-1, len(axes))
            ends = block[1:][:, :, axes].reshape(-1, len(axes))
            segs = np.stack([starts, ends], axis=1)
            age = np.repeat(np.arange(k), block.shape[1])  # 0 = oldest
            alpha = trail_alpha * (age + 1) / k
            rgba = np.empty((segs.shape[0], 4))
            rgba[:, :3] = colour
            rgba[:, 3] = alpha
            coll = (Line3DCollection if three_d else LineCollection)(segs, colors=rgba, linewidths=0.7)
            ax.add_collection(coll)
        label = "%s (%s agents)" % (name, format(count, ","))
        pts = [now[:, a] for a in axes]
        ax.scatter(*pts, s=size, color=colour, alpha=0.9, linewidths=0, label=label,
                   **({"depthshade": False} if three_d else {}))

    for kind, centre, radius in stimuli:  # red: predator, green: attractor
        colour = "tab:red" if kind == "predator" else "tab:green"
        pts = [[centre[a]] for a in axes]
        # a disc roughly the sphere's size (points^2 from the radius relative to the domain)
        extent = max(float(np.max(domain[1] - domain[0])), 1e-9) if domain is not None else 1.0
        area = max(40.0, (radius / extent * 0.8 * 72.0 * max(args.size)) ** 2 * math.pi)
        ax.scatter(*pts, s=area, color=colour, alpha=0.35, linewidths=1, edgecolors=colour,
                   label="%s stimulus" % kind, **({"depthshade": False} if three_d else {}))

    whole_domain = set_bounds(ax, args.view, args.bounds, data, domain)
    for a, axis in enumerate(axes):
        getattr(ax, "set_%slabel" % "xyz"[a])("%s (m)" % AXIS_NAMES[axis])

    title = "%s  frame %d/%d  t = %.2f s" % (title_name, frame, frames - 1, time)
    if not complete:
        title += "  (incomplete run)"
    notes = []
    if not whole_domain:
        notes.append("zoomed to the agents")
    if trail_frames > 0:
        span = "" if math.isnan(trail_time) else " = %.2f s" % trail_time
        notes.append("trails: %d frame%s%s" % (trail_frames, "" if trail_frames == 1 else "s", span))
    if stride > 1:
        notes.append("every %d%s agent shown (%s of %s)" % (stride, ordinal_suffix(stride), format(shown, ","),
                                                            format(total, ",")))
    if notes:
        title += "\n" + "; ".join(notes)
    ax.set_title(title, fontsize=11)
    legend = ax.legend(loc="upper right", fontsize=9, markerscale=max(1.0, 4.0 / math.sqrt(size)))
    for h in legend.legend_handles if hasattr(legend, "legend_handles") else legend.legendHandles:
        h.set_alpha(1.0)
        if hasattr(h, "set_sizes"):
            h.set_sizes([30.0])
    if three_d:
        fig.subplots_adjust(left=0.0, right=0.95, bottom=0.04, top=0.9)
    else:
        fig.tight_layout()
    try:
        out_dir = os.path.dirname(os.path.abspath(args.output))
        os.makedirs(out_dir, exist_ok=True)
        fig.savefig(args.output, dpi=args.dpi)
    except ValueError as e:  # e.g. an unknown image format
        raise PreviewError("%s: %s" % (args.output, e))
    except OSError as e:
        raise PreviewError("%s: cannot write the image (%s)" % (args.output, e), EXIT_OUTPUT)
    finally:
        plt.close(fig)
    return args.output


def ordinal_suffix(n):
    if 10 <= n % 100 <= 20:
        return "th"
    return {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")


def agent_box(data):
    pts = np.concatenate([block.reshape(-1, 3) for _, _, block in data])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return None
    lo, hi = pts.min(0), pts.max(0)
    # pad by 8% of the largest extent so a flat or thin swarm still gets a box
    pad = max(0.08 * float(np.max(hi - lo)), 1e-3)
    return lo - pad, hi + pad


def choose_bounds(mode, data, domain):
    """(lo, hi, is_domain): the axis limits."""
    box = agent_box(data)
    if domain is not None and (mode == "domain" or box is None):
        return domain[0], domain[1], True
    if box is None:
        return np.zeros(3), np.ones(3), False
    if mode == "auto" and domain is not None:
        small = np.all((box[1] - box[0]) < 0.5 * (domain[1] - domain[0]))
        if not small:
            return domain[0], domain[1], True
    return box[0], box[1], False


def set_bounds(ax, view, mode, data, domain):
    """Set equal-aspect axis limits; returns True when they are the domain (drawn as a grey box)."""
    lo, hi, is_domain = choose_bounds(mode, data, domain)
    if view == "3d":
        if is_domain:
            ax.add_collection(Line3DCollection(domain_edges(lo, hi), colors="0.6", linewidths=0.6))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(hi - lo), zoom=1.1)  # equal aspect: a metre is as long on every axis
        ax.view_init(elev=18, azim=-60)
    else:
        a, b = AXES[view]
        if is_domain:
            ax.add_patch(matplotlib.patches.Rectangle((lo[a], lo[b]), hi[a] - lo[a], hi[b] - lo[b],
                                                      fill=False, edgecolor="0.6", linewidth=0.8))
            margin = 0.02 * max(hi[a] - lo[a], hi[b] - lo[b])
            lo, hi = lo - margin, hi + margin
        ax.set_xlim(lo[a], hi[a])
        ax.set_ylim(lo[b], hi[b])
        ax.set_aspect("equal")
    return is_domain


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        out = render(args)
    except PreviewError as e:
        print("preview.py: error: %s" % e, file=sys.stderr)
        return e.code
    print("wrote %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
