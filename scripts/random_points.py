#!/usr/bin/python3
"""Tracks of uniform random points: a CSV that `swarmsim evaluate` reads as a swarm.

Every individual is present at every sample, and at every sample its position is
drawn anew, uniformly at random inside a box, independently of everything else.
There is no motion from one sample to the next, only jumps: with the mosquito
data's box (2.06 x 0.80 x 1.71 m) and dt 0.02 s the speeds that `evaluate`
derives from the positions have a median of 25 m/s, 55 times the mosquitoes'
0.46 m/s. It is the "uniform random points" case of docs/evaluation.md: a
swarm that is plainly not an insect swarm, to see what a score makes of it.

Usage:
    scripts/random_points.py --box XMIN XMAX YMIN YMAX ZMIN ZMAX [--count N]
                             [--samples K] [--dt DT] [--seed S] -o OUT.csv
    scripts/random_points.py --like REF.csv [--count N] [--samples K] [--dt DT]
                             [--box ...] [--seed S] -o OUT.csv

    -o OUT         the CSV to write; "-" writes to standard output
    --box ...      the box in metres: XMIN XMAX YMIN YMAX ZMIN ZMAX (each MIN < MAX)
    --count N      individuals (default 10; with --like: the median number of
                   individuals per sample of REF)
    --samples K    samples (default 1000; with --like: REF's samples, from its
                   first to its last time)
    --dt DT        sampling interval in seconds (default 0.02; with --like: REF's)
    --like REF     take the box (the bounding box of REF's positions), the count,
                   the samples and dt from a tracks CSV; options given explicitly
                   override what REF gives
    --seed S       seed of the random numbers, an integer >= 0 (default 1); the
                   same arguments and seed give the same file, byte for byte

Output: one header line `id,time,x,y,z`, then one row per individual per
sample, sample by sample: id 0..N-1, time k * dt (s, k = 0..K-1), positions in
metres with 6 decimals (micrometres). No velocity columns: `swarmsim evaluate`
derives velocities from the positions.

REF is read the way `swarmsim evaluate` reads a CSV of tracks (docs/evaluation.md,
"CSV of tracks"): one header line; the delimiter is whichever of `;`, `,` and tab
occurs most often in it; the columns are found case-insensitively: the id is the
first present of id, object, track, track_id, individual; the time is `time`,
else `t`; x (y, z) is exactly `x`, else the first column whose name starts with
`x` (e.g. XSplined). The mosquito file
(object;oldobject;time;XSplined;YSplined;ZSplined;VXSplined;...) needs no option.
Its sampling interval is found as `evaluate` finds it: the median positive step
between consecutive times of one id (the lower middle one), refined to the mean of
the steps within 25 % of it; a row's sample is round((t - t0) / dt). The count is
the median over REF's samples (those with no row count as 0; the upper middle
one for an even number of samples), as for `evaluate --baseline`.

Example (from the top of the repository):
    REF=../shared/data/real/anopheles_swarm_moustic/tracks.csv
    scripts/random_points.py --like $REF --seed 1 -o /tmp/uniform.csv
    build/swarmsim evaluate /tmp/uniform.csv --reference $REF

Exit codes: 0 success, 2 invalid input (bad option or value, REF missing,
unreadable or without the needed columns, a cell that is not a number, no
sampling interval found), 3 the output cannot be written.
Needs Debian's /usr/bin/python3 and python3-numpy.
"""

import argparse
import math
import sys

import numpy as np

# ids, times, positions: the column keys evaluate detects (lib/eval/tracks.hpp)
ID_NAMES = ("id", "object", "track", "track_id", "individual")
CHUNK = 4096  # samples drawn and written at a time (fixed: the output does not depend on it)


class InputError(Exception):
    pass


def fail(message, code=2):
    print("random_points.py: error: %s" % message, file=sys.stderr)
    sys.exit(code)


def clean(cell):
    return cell.strip().strip('"').strip()


def read_tracks(path, option="--like"):
    """A tracks CSV read as swarmsim evaluate reads it: (id index, time, positions (n x 3), dt, sample index).

    Raises InputError (its message names `option`, the file and the line) on bad input."""
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise InputError("%s %s: cannot read: %s" % (option, path, e.strerror or e))
    lineno = 0
    while lineno < len(lines) and not lines[lineno].strip():
        lineno += 1
    if lineno == len(lines):
        raise InputError("%s %s: empty file (no header line)" % (option, path))
    header = lines[lineno]
    counts = [(header.count(d), d) for d in (";", ",", "\t")]
    best = max(c for c, _ in counts)
    if best == 0:
        raise InputError("%s %s: no delimiter (; , or tab) in the header line" % (option, path))
    delim = next(d for c, d in counts if c == best)
    names = [clean(c).lower() for c in header.split(delim)]

    def exact_or_prefix(key):
        if key in names:
            return names.index(key)
        for i, n in enumerate(names):
            if n.startswith(key):
                return i
        return None

    cols = {}
    cols["id"] = next((names.index(n) for n in ID_NAMES if n in names), None)
    cols["time"] = names.index("time") if "time" in names else (names.index("t") if "t" in names else None)
    for k in ("x", "y", "z"):
        cols[k] = exact_or_prefix(k)
    missing = [k for k, v in cols.items() if v is None]
    if missing:
        raise InputError("%s %s: column(s) not found in the header: %s (header: %s)"
                         % (option, path, ", ".join(missing), header.strip()))
    need = max(cols.values())
    ids, values = [], []
    for i in range(lineno + 1, len(lines)):
        line = lines[i]
        if not line.strip():
            continue
        cells = line.split(delim)
        if len(cells) <= need:
            raise InputError("%s %s:%d: %d cells, need at least %d" % (option, path, i + 1, len(cells), need + 1))
        ident = clean(cells[cols["id"]])
        if not ident:
            raise InputError("%s %s:%d: column %s: empty id" % (option, path, i + 1, names[cols["id"]]))
        row = []
        for k in ("time", "x", "y", "z"):
            text = clean(cells[cols[k]])
            try:
                v = float(text)
            except ValueError:
                v = float("nan")
            if not math.isfinite(v):
                raise InputError("%s %s:%d: column %s: not a finite number: \"%s\""
                                 % (option, path, i + 1, names[cols[k]], text))
            row.append(v)
        ids.append(ident)
        values.append(row)
    if len(values) < 2:
        raise InputError("%s %s: %d row(s); need at least 2" % (option, path, len(values)))
    _, idx = np.unique(np.array(ids), return_inverse=True)
    a = np.array(values)
    t = a[:, 0]
    order_rows = np.lexsort((t, idx))
    ti, tt = idx[order_rows], t[order_rows]
    same = (ti[1:] == ti[:-1]) & (tt[1:] > tt[:-1])
    steps = (tt[1:] - tt[:-1])[same]
    if steps.size == 0:
        raise InputError("%s %s: cannot determine the sampling interval: no track has two samples "
                         "at different times" % (option, path))
    dt0 = np.sort(steps)[(steps.size - 1) // 2]
    near = steps[np.abs(steps / dt0 - 1.0) < 0.25]
    mean = near.mean() if near.size else dt0
    dt = float(mean if abs(mean - dt0) > 1e-6 * dt0 else dt0)
    sample = np.floor((t - t.min()) / dt + 0.5).astype(np.int64)
    key = idx.astype(np.int64) * (int(sample.max()) + 1) + sample
    uniq, first, n = np.unique(key, return_index=True, return_counts=True)
    if (n > 1).any():
        dup = uniq[n > 1][0]
        rows = np.nonzero(key == dup)[0]
        raise InputError("%s %s: duplicate sample: id %s has %d rows on sample %d (dt %.9g s), at times %s"
                         % (option, path, ids[rows[0]], rows.size, sample[rows[0]], dt,
                            ", ".join("%g" % t[r] for r in rows[:3])))
    return idx, t, a[:, 1:4], dt, sample


def read_like(path):
    """(box, count, samples, dt) of a tracks CSV (see the module docstring)."""
    _, _, pos, dt, sample = read_tracks(path)
    samples = int(sample.max()) + 1
    per_sample = np.sort(np.bincount(sample, minlength=samples))
    count = int(per_sample[samples // 2])
    box = []
    for c in range(3):
        box += [float(pos[:, c].min()), float(pos[:, c].max())]
    return box, count, samples, dt


def positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected an integer, got %r" % text)
    if v < 1:
        raise argparse.ArgumentTypeError("expected an integer >= 1, got %d" % v)
    return v


def seed_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected an integer >= 0, got %r" % text)
    if v < 0:
        raise argparse.ArgumentTypeError("expected an integer >= 0, got %d" % v)
    return v


def finite_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected a number, got %r" % text)
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError("expected a finite number, got %r" % text)
    return v


def positive_float(text):
    v = finite_float(text)
    if v <= 0:
        raise argparse.ArgumentTypeError("expected a number > 0, got %r" % text)
    return v


def main(argv):
    p = argparse.ArgumentParser(prog="random_points.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", required=True, help='CSV to write ("-": standard output)')
    p.add_argument("--box", nargs=6, type=finite_float, metavar=("XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"),
                   help="the box in metres")
    p.add_argument("--count", type=positive_int, help="individuals (default 10, or from --like)")
    p.add_argument("--samples", type=positive_int, help="samples (default 1000, or from --like)")
    p.add_argument("--dt", type=positive_float, help="sampling interval, s (default 0.02, or from --like)")
    p.add_argument("--like", metavar="REF.csv", help="take the box, count, samples and dt from a tracks CSV")
    p.add_argument("--seed", type=seed_int, default=1, help="seed, integer >= 0 (default 1)")
    args = p.parse_args(argv)

    box, count, samples, dt = None, 10, 1000, 0.02
    if args.like is not None:
        try:
            box, count, samples, dt = read_like(args.like)
        except InputError as e:
            fail(str(e))
    if args.box is not None:
        box = list(args.box)
    if box is None:
        p.error("give --box XMIN XMAX YMIN YMAX ZMIN ZMAX or --like REF.csv")
    for axis, lo, hi in zip("xyz", box[0::2], box[1::2]):
        if not lo < hi:
            fail("box: %s: expected MIN < MAX, got %g and %g" % (axis, lo, hi))
    if args.count is not None:
        count = args.count
    elif count < 1:
        fail("--like %s: the median number of individuals per sample is 0 (dt %.9g s, %d samples); give --count"
             % (args.like, dt, samples))
    if args.samples is not None:
        samples = args.samples
    if args.dt is not None:
        dt = args.dt
    if count < 1 or samples < 1:
        fail("expected at least 1 individual and 1 sample, got %d and %d" % (count, samples))

    lo = np.array(box[0::2])
    hi = np.array(box[1::2])
    rng = np.random.default_rng(args.seed)
    ids = np.arange(count)
    try:
        out = sys.stdout if args.output == "-" else open(args.output, "w", encoding="ascii", newline="\n")
    except OSError as e:
        fail("cannot write %s: %s" % (args.output, e.strerror or e), 3)
    try:
        out.write("id,time,x,y,z\n")
        for first in range(0, samples, CHUNK):
            n = min(CHUNK, samples - first)
            pos = lo + (hi - lo) * rng.random((n, count, 3))
            rows = []
            for j in range(n):
                k = first + j
                t = "%.12g" % (k * dt)
                block = np.column_stack((ids, pos[j]))
                rows.append("\n".join("%d,%s,%.6f,%.6f,%.6f" % (int(r[0]), t, r[1], r[2], r[3]) for r in block))
            out.write("\n".join(rows) + "\n")
        if out is not sys.stdout:
            out.close()
        else:
            out.flush()
    except OSError as e:
        fail("cannot write %s: %s" % (args.output, e.strerror or e), 3)
    if args.output != "-":
        print("random_points.py: %s: %d individuals x %d samples, dt %.9g s, box x [%g, %g] y [%g, %g] z [%g, %g] m, "
              "seed %d" % (args.output, count, samples, dt, *box, args.seed), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
