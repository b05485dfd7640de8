#!/usr/bin/python3
"""Plot the result of `swarmsim evaluate --json`: the seven metric PDFs,
simulation against reference, and the energy terms.

Usage:
  scripts/plot_eval.py EVAL.json -o OUT.png [--title TEXT] [--size W H] [--dpi DPI]
  swarmsim evaluate SIM --reference REF --json | scripts/plot_eval.py - -o OUT.png

Needs Debian's python3-matplotlib and python3-numpy, hence /usr/bin/python3
(scripts/setup.sh installs them). The figure is a 2 x 4 grid: one panel per
metric (v, a, omega, alpha, mu, d, eta) with the discrete PDFs of the reference
(grey, filled) and of the simulation (line) over the common z-score bins, E_phi
and the entropy weight in the panel title and the medians (raw units) in a text
box; the eighth panel is a bar chart of E_phi per metric with the total E in
its title. See docs/evaluation.md.

Exit codes: 0 success, 2 invalid input (missing file, not JSON, JSON not in
the `swarmsim evaluate --json` layout, bad option), 3 the image cannot be
written.
"""

import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

EXIT_INPUT = 2
EXIT_OUTPUT = 3
# canonical order of the metrics (BSwarm section 5) and their labels
METRICS = ["v", "a", "omega", "alpha", "mu", "d", "eta"]
LABELS = {
    "v": r"$v$ speed",
    "a": r"$a$ acceleration",
    "omega": r"$\omega$ angular velocity",
    "alpha": r"$\alpha$ angular acceleration",
    "mu": r"$\mu$ jerk",
    "d": r"$d$ nearest distance",
    "eta": r"$\eta$ velocity difference",
}
# other spellings accepted in "name"
ALIASES = {"jerk": "mu"}
SHORT = {"v": r"$v$", "a": r"$a$", "omega": r"$\omega$", "alpha": r"$\alpha$", "mu": r"$\mu$", "d": r"$d$",
         "eta": r"$\eta$"}
PDF_SUM_TOLERANCE = 1e-3
COLOUR_REF = "0.55"
COLOUR_SIM = "tab:blue"


class PlotError(Exception):
    def __init__(self, message, code=EXIT_INPUT):
        super().__init__(message)
        self.code = code


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="plot_eval.py",
        description="Plot the metric PDFs of `swarmsim evaluate --json` (simulation against reference) "
                    "to an image (PNG, SVG, PDF, ...).",
    )
    p.add_argument("file", metavar="EVAL.json", help="output of `swarmsim evaluate ... --json`; - reads standard input")
    p.add_argument("-o", "--output", required=True, metavar="IMAGE",
                   help="image to write; the format follows the extension (PNG without one)")
    p.add_argument("--title", metavar="TEXT",
                   help="figure title (default: the simulation and reference files)")
    p.add_argument("--size", type=float, nargs=2, default=[16.0, 8.0], metavar=("W", "H"),
                   help="figure size in inches (default: 16 8)")
    p.add_argument("--dpi", type=int, default=100, help="resolution in dots per inch (default: 100)")
    args = p.parse_args(argv)
    if not (args.size[0] > 0 and args.size[1] > 0):
        p.error("--size: expected two positive numbers")
    if args.dpi <= 0:
        p.error("--dpi: expected a positive integer")
    return args


# ---------------------------------------------------------------- reading

def load(path):
    name = "standard input" if path == "-" else path
    try:
        if path == "-":
            text = sys.stdin.read()
        else:
            if not os.path.exists(path):
                raise PlotError("%s: no such file" % path)
            if os.path.isdir(path):
                raise PlotError("%s: is a folder, expected a JSON file" % path)
            with open(path, "r", encoding="utf-8") as f:
                text = f.read()
    except (OSError, UnicodeDecodeError) as e:
        raise PlotError("%s: cannot read (%s)" % (name, e))
    if not text.strip():
        raise PlotError("%s: empty, expected the JSON of `swarmsim evaluate --json`" % name)
    try:
        doc = json.loads(text)
    except ValueError as e:
        raise PlotError("%s: not valid JSON (%s)" % (name, e))
    return validate(doc, name)


def _where(name, key):
    return "%s: %s" % (name, key)


def number(obj, key, where, allow_null=False):
    """A finite float (None for a JSON null when allowed)."""
    if key not in obj:
        raise PlotError("%s: missing key '%s'" % (where, key))
    v = obj[key]
    if v is None and allow_null:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise PlotError("%s: '%s' must be a number, got %s" % (where, key, json.dumps(v)[:40]))
    v = float(v)
    if not math.isfinite(v):
        if allow_null:
            return None
        raise PlotError("%s: '%s' must be finite, got %s" % (where, key, v))
    return v


def integer(obj, key, where):
    if key not in obj:
        raise PlotError("%s: missing key '%s'" % (where, key))
    v = obj[key]
    if (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or float(v) != int(v)
            or v < 0):
        raise PlotError("%s: '%s' must be a non-negative integer, got %s" % (where, key, json.dumps(v)[:40]))
    return int(v)


def array(obj, key, length, where):
    if key not in obj:
        raise PlotError("%s: missing key '%s'" % (where, key))
    v = obj[key]
    if not isinstance(v, list):
        raise PlotError("%s: '%s' must be a list of numbers" % (where, key))
    if len(v) != length:
        raise PlotError("%s: '%s' has %d values, expected %d" % (where, key, len(v), length))
    if any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v):
        raise PlotError("%s: '%s' must hold numbers only" % (where, key))
    a = np.asarray(v, dtype=float)
    if not np.all(np.isfinite(a)):
        raise PlotError("%s: '%s' holds a value that is not finite" % (where, key))
    return a


def side(doc, key, name):
    where = _where(name, key)
    if key not in doc:
        raise PlotError("%s: missing key '%s'" % (name, key))
    s = doc[key]
    if not isinstance(s, dict):
        raise PlotError("%s: must be an object" % where)
    f = s.get("file")
    if not isinstance(f, str):
        raise PlotError("%s: 'file' must be a string" % where)
    swarm = s.get("swarm")
    if swarm is not None and not isinstance(swarm, str):
        raise PlotError("%s: 'swarm' must be a string or null" % where)
    return {"file": f, "swarm": swarm, "dt": number(s, "dt", where, allow_null=True),
            "individuals": integer(s, "individuals", where)}


def validate(doc, name):
    if not isinstance(doc, dict):
        raise PlotError("%s: expected a JSON object (the output of `swarmsim evaluate --json`)" % name)
    sim = side(doc, "sim", name)
    ref = side(doc, "reference", name)
    bins = integer(doc, "bins", name)
    if bins < 1:
        raise PlotError("%s: 'bins' must be at least 1, got %d" % (name, bins))
    if "metrics" not in doc or not isinstance(doc["metrics"], list) or not doc["metrics"]:
        raise PlotError("%s: 'metrics' must be a non-empty list" % name)
    metrics = {}
    for i, m in enumerate(doc["metrics"]):
        where = "%s: metrics[%d]" % (name, i)
        if not isinstance(m, dict):
            raise PlotError("%s: must be an object" % where)
        if m.get("paper") is False:
            continue  # a collective metric of the physical score: no z-score PDF to draw
        key = m.get("name")
        key = ALIASES.get(key, key) if isinstance(key, str) else key
        if key not in METRICS:
            raise PlotError("%s: unknown metric name %s (expected one of %s)"
                            % (where, json.dumps(m.get("name"))[:40], ", ".join(METRICS + sorted(ALIASES))))
        if key in metrics:
            raise PlotError("%s: metric '%s' appears twice" % (where, key))
        where = "%s (%s)" % (where, key)
        unit = m.get("unit", "")
        if not isinstance(unit, str):
            raise PlotError("%s: 'unit' must be a string" % where)
        e = {
            "name": key,
            "unit": unit,
            "samples_sim": integer(m, "samples_sim", where),
            "samples_ref": integer(m, "samples_ref", where),
            "median_sim": number(m, "median_sim", where, allow_null=True),
            "median_ref": number(m, "median_ref", where, allow_null=True),
            "w1": number(m, "w1", where, allow_null=True),
            "energy": number(m, "energy", where, allow_null=True),
            "weight": number(m, "weight", where, allow_null=True),
            "edges": array(m, "edges", bins + 1, where),
            "pdf_sim": array(m, "pdf_sim", bins, where),
            "pdf_ref": array(m, "pdf_ref", bins, where),
        }
        if np.any(np.diff(e["edges"]) <= 0):
            raise PlotError("%s: 'edges' must be strictly increasing" % where)
        for k, n in (("pdf_sim", "samples_sim"), ("pdf_ref", "samples_ref")):
            if np.any(e[k] < 0):
                raise PlotError("%s: '%s' holds a negative probability" % (where, k))
            total = float(e[k].sum())
            if e[n] > 0 and abs(total - 1.0) > PDF_SUM_TOLERANCE:
                raise PlotError("%s: '%s' sums to %.6g, expected 1" % (where, k, total))
        metrics[key] = e
    total = number(doc, "total", name, allow_null=True)
    return {"sim": sim, "reference": ref, "bins": bins, "metrics": metrics, "total": total}


# ---------------------------------------------------------------- drawing

def fmt(value, unit=""):
    if value is None:
        return "n/a"
    text = "%.4g" % value
    return "%s %s" % (text, unit) if unit else text


def describe(s):
    base = os.path.basename(s["file"]) or s["file"]
    if s["swarm"]:
        base += " [%s]" % s["swarm"]
    extra = []
    if s["individuals"]:
        extra.append("%s individuals" % format(s["individuals"], ","))
    if s["dt"] is not None:
        extra.append("dt %.4g s" % s["dt"])
    return base + (" (%s)" % ", ".join(extra) if extra else "")


def draw_metric(ax, e):
    edges = e["edges"]
    empty_ref, empty_sim = e["samples_ref"] == 0, e["samples_sim"] == 0
    if not empty_ref:
        ax.stairs(e["pdf_ref"], edges, fill=True, color=COLOUR_REF, alpha=0.45, label="reference")
        ax.stairs(e["pdf_ref"], edges, color=COLOUR_REF, linewidth=1.0)
    if not empty_sim:
        ax.stairs(e["pdf_sim"], edges, color=COLOUR_SIM, linewidth=1.6, label="simulation")
    ax.set_xlim(edges[0], edges[-1])
    top = max(float(e["pdf_ref"].max()), float(e["pdf_sim"].max()), 1e-3)
    ax.set_ylim(0, top * 1.12)
    title = LABELS[e["name"]] + (" (%s)" % e["unit"] if e["unit"] else "")
    title += "\n$E_\\phi$ = %s   w = %s" % (fmt(e["energy"]), fmt(e["weight"]))
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("z-score", fontsize=9)
    ax.tick_params(labelsize=8)
    ax.grid(True, alpha=0.25, linewidth=0.5)
    lines = [
        "median sim %s" % fmt(e["median_sim"], e["unit"]),
        "median ref %s" % fmt(e["median_ref"], e["unit"]),
        "W1 %s" % fmt(e["w1"], e["unit"]),
        "n %s / %s" % (format(e["samples_sim"], ","), format(e["samples_ref"], ",")),
    ]
    ax.text(0.97, 0.96, "\n".join(lines), transform=ax.transAxes, ha="right", va="top", fontsize=7,
            family="monospace", bbox=dict(boxstyle="round,pad=0.3", facecolor="white", edgecolor="0.7", alpha=0.85))
    if empty_ref or empty_sim:
        which = "no samples: " + " and ".join(n for n, empty in (("reference", empty_ref), ("simulation", empty_sim))
                                               if empty)
        ax.text(0.5, 0.5, which, transform=ax.transAxes, ha="center", va="center", fontsize=9, color="tab:red",
                bbox=dict(boxstyle="round,pad=0.3", facecolor="white", edgecolor="tab:red", alpha=0.9))


def draw_missing(ax, key):
    ax.set_title(LABELS[key], fontsize=10)
    ax.text(0.5, 0.5, "not in the JSON", transform=ax.transAxes, ha="center", va="center", fontsize=9, color="0.4")
    ax.set_xticks([])
    ax.set_yticks([])


def draw_energies(ax, ev):
    keys = [k for k in METRICS if k in ev["metrics"]]
    values = [ev["metrics"][k]["energy"] for k in keys]
    weights = [ev["metrics"][k]["weight"] for k in keys]
    x = np.arange(len(keys))
    heights = [0.0 if v is None else v for v in values]
    wmax = max([w for w in weights if w is not None] or [0.0])
    # darker bars carry more weight in the total
    colours = [matplotlib.colors.to_rgba(COLOUR_SIM, 0.35 + 0.65 * ((w or 0.0) / wmax if wmax > 0 else 1.0))
               for w in weights]
    ax.bar(x, heights, color=colours, edgecolor=COLOUR_SIM, linewidth=0.8)
    for xi, v, w in zip(x, values, weights):
        label = "n/a" if v is None else "%.3f" % v
        ax.text(xi, (v or 0.0) + 0.02, label, ha="center", va="bottom", fontsize=7)
        if v is None:
            continue
        ax.text(xi, 0.03, "w %s" % ("n/a" if w is None else "%.2f" % w), ha="center", va="bottom", fontsize=6.5,
                rotation=90, color="black")
    ax.set_xticks(x)
    ax.set_xticklabels([SHORT[k] for k in keys], fontsize=10)
    ax.set_ylim(0, 1.12)
    ax.axhline(1.0, color="0.6", linewidth=0.6, linestyle="--")
    ax.set_ylabel("$E_\\phi$ (1 = same PDF)", fontsize=9)
    ax.tick_params(axis="y", labelsize=8)
    total = ev["total"]
    ax.set_title("energy per metric\ntotal E = %s" % ("n/a" if total is None else "%.4f" % total), fontsize=10,
                 fontweight="bold")
    ax.grid(True, axis="y", alpha=0.25, linewidth=0.5)


def render(args, ev):
    fig, axes = plt.subplots(2, 4, figsize=tuple(args.size), dpi=args.dpi)
    flat = axes.ravel()
    for i, key in enumerate(METRICS):
        if key in ev["metrics"]:
            draw_metric(flat[i], ev["metrics"][key])
        else:
            draw_missing(flat[i], key)
        if i % 4 == 0:
            flat[i].set_ylabel("probability", fontsize=9)
    draw_energies(flat[7], ev)
    handles, labels = [], []
    for ax in flat[:7]:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    if handles:
        fig.legend(handles, labels, loc="upper right", fontsize=9, ncol=len(handles), frameon=False)
    if args.title is not None:
        title = args.title
    else:
        title = "simulation %s  vs  reference %s" % (describe(ev["sim"]), describe(ev["reference"]))
    fig.suptitle(title + "\n%d bins over the z-scored values; E = sum of w $E_\\phi$" % ev["bins"], fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    # the format follows the extension; without one, PNG to exactly that path (matplotlib would append .png)
    ext = os.path.splitext(args.output)[1].lstrip(".").lower() or "png"
    try:
        if os.path.isdir(args.output):
            raise PlotError("%s: is a folder, expected an image file name" % args.output, EXIT_OUTPUT)
        out_dir = os.path.dirname(os.path.abspath(args.output))
        os.makedirs(out_dir, exist_ok=True)
        fig.savefig(args.output, dpi=args.dpi, format=ext)
    except ValueError as e:  # e.g. an unknown image format
        raise PlotError("%s: %s" % (args.output, e))
    except OSError as e:
        raise PlotError("%s: cannot write the image (%s)" % (args.output, e), EXIT_OUTPUT)
    finally:
        plt.close(fig)
    return args.output


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        ev = load(args.file)
        out = render(args, ev)
    except PlotError as e:
        print("plot_eval.py: error: %s" % e, file=sys.stderr)
        return e.code
    print("wrote %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
