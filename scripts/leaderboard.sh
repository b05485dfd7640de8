#!/usr/bin/env bash
# Reproduces the leaderboard of docs/evaluation.md: how closely each of our models, and three yardsticks,
# move like the Anopheles swarm (moustic), by `swarmsim evaluate --json`.
#
# Usage: scripts/leaderboard.sh [--keep DIR] [REF]
#   REF         the mosquito tracks (default: /work/shared/data/real/anopheles_swarm_moustic/tracks.csv, else
#               ../shared/data/real/anopheles_swarm_moustic/tracks.csv beside the repository)
#   --keep DIR  also keep every evaluate JSON in DIR (created if needed)
# Environment: SWARMSIM (default build/swarmsim of this repository), PYTHON (default /usr/bin/python3,
# which needs python3-numpy).
#
# Rows, each scored by `swarmsim evaluate SIM --reference REF --json` (default bootstrap: 200 replicates of
# 20 time blocks, seed 1):
#   (a) real vs real: REF's samples 0..999 (the first 20 s) against its samples 1000.. (--sim-frames :1000
#       --ref-frames 1000: --baseline);
#   (b) the Ornstein-Uhlenbeck baseline: S and E from the --baseline run of (a), i.e. the walkers matched to
#       and scored against REF's samples 1000..;
#   (c) uniform random points: scripts/random_points.py --like REF --seed 1, against the whole REF;
#   (d) our models: the scenarios below, 1,000 frames of 0.02 s each, against the whole REF, unscaled
#       (no --sim-scale: the physical score compares physical units).
# A second table compares, term by term, real vs real with the baseline (the JSON's baseline.scores).
# Prints Markdown on standard output, progress on standard error. Takes about a minute on 2 cores.
# Exit codes: 0 success, 2 REF or the binary missing or a bad option, 1 any step failing.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
B=${SWARMSIM:-$ROOT/build/swarmsim}
PY=${PYTHON:-/usr/bin/python3}
REF=/work/shared/data/real/anopheles_swarm_moustic/tracks.csv
if [ ! -r "$REF" ] && [ -r "$ROOT/../shared/data/real/anopheles_swarm_moustic/tracks.csv" ]; then
  REF=$ROOT/../shared/data/real/anopheles_swarm_moustic/tracks.csv  # shared/ beside the repository
fi
KEEP=

usage() { sed -n '5,11p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --keep) [ $# -ge 2 ] || { echo "leaderboard.sh: error: --keep needs a folder" >&2; exit 2; }
            KEEP=$2; shift 2 ;;
    -*) echo "leaderboard.sh: error: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) REF=$1; shift ;;
  esac
done
if [ ! -r "$REF" ] || [ -d "$REF" ]; then
  echo "leaderboard.sh: error: reference data not found or not readable: $REF" >&2
  echo "  (the Anopheles tracks, ../shared/data/real/anopheles_swarm_moustic/tracks.csv from the repository;" >&2
  echo "  give its path as the argument)" >&2
  exit 2
fi
REF=$(cd "$(dirname "$REF")" && pwd)/$(basename "$REF")
if [ ! -x "$B" ]; then
  echo "leaderboard.sh: error: swarmsim binary not found: $B (build it, or set SWARMSIM)" >&2
  exit 2
fi
if ! "$PY" -c 'import numpy' 2>/dev/null; then
  echo "leaderboard.sh: error: $PY cannot import numpy (apt-get install python3-numpy, or set PYTHON)" >&2
  exit 2
fi
if [ -n "$KEEP" ]; then mkdir -p "$KEEP"; fi

TMP=$(mktemp -d "${TMPDIR:-/tmp}/leaderboard.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
cd "$ROOT"
START=$(date +%s)
step() { echo "leaderboard.sh: $* ($(( $(date +%s) - START )) s)" >&2; }

# (a), (b)
step "real vs real, with the baseline"
"$B" evaluate "$REF" --reference "$REF" --sim-frames :1000 --ref-frames 1000: --baseline --json > "$TMP/real.json"

# (c)
step "uniform random points"
"$PY" scripts/random_points.py --like "$REF" --seed 1 -o "$TMP/uniform.csv"
"$B" evaluate "$TMP/uniform.csv" --reference "$REF" --json > "$TMP/uniform.json"

# (d): the commands of docs/evaluation.md, without --sim-scale
run_model() {  # name, scenario, extra run options...
  local name=$1 scenario=$2
  shift 2
  step "model $name: run"
  "$B" run "scenarios/$scenario" -o "$TMP/$name.h5" "$@" > /dev/null
  step "model $name: evaluate"
  "$B" evaluate "$TMP/$name.h5" --reference "$REF" --json > "$TMP/$name.json"
  rm -f "$TMP/$name.h5"
}
run_model boids       default.json     --frames 1000 --set dt=0.01 --set steps_per_frame=2
run_model aggregation aggregation.json --frames 1000 --set dt=0.02 --set steps_per_frame=1
run_model midges_100  midges_100.json  --frames 1000 --set steps_per_frame=2
run_model midges_500  midges_500.json  --frames 1000 --set steps_per_frame=2
run_model fs_aggregation_37 fastswarm_aggregation_37.json
run_model fs_realistic_37   fastswarm_realistic_37.json

# the Python half: the tables
cat > "$TMP/lb.py" <<'PY'
import json, sys

def load(path):
    with open(path) as f:
        return json.load(f)

# ---- the tables ----
def fmt(x, nd=3):
    return "-" if x is None else ("%.*f" % (nd, x))

def with_ci(x, ci):
    if x is None:
        return "-"
    return fmt(x) + (" [%s, %s]" % (fmt(ci[0]), fmt(ci[1])) if ci else "")

def term(r, name):
    if "metrics" not in r:  # the baseline: the JSON's baseline.scores
        return dict(r["scores"][name], unit="")
    for m in r["metrics"]:
        if m["name"] == name:
            return m
    for c in r["curves"]:
        if c["name"] == name:
            return c
    raise KeyError(name)

COLUMNS = [("v", "v"), ("a", "a"), ("d", "d"), ("pol", "pol"), ("r_c", "r_c"), ("autocorr.", "autocorrelation")]

def tables(tmp, ref_text):
    real = load(tmp + "/real.json")
    b_builtin = real["baseline"]
    models = [
        ("boids", "boids, default.json (2,000)"),
        ("aggregation", "field, aggregation.json (1,000)"),
        ("midges_100", "bswarm, midges_100.json (100)"),
        ("midges_500", "bswarm, midges_500.json (500)"),
        ("fs_aggregation_37", "fastswarm, fastswarm_aggregation_37.json (37)"),
        ("fs_realistic_37", "fastswarm, fastswarm_realistic_37.json (37)"),
    ]
    rows = [("mosquitoes: first 20 s vs the rest (real vs real)", real, real["scores"]),
            ("OU baseline (`--baseline` of the row above)", b_builtin, b_builtin),
            ("uniform random points (`random_points.py --like`)", load(tmp + "/uniform.json"), None)]
    scored = [(label, load(tmp + "/" + name + ".json")) for name, label in models]
    scored.sort(key=lambda lr: -lr[1]["scores"]["physical"])
    rows += [(label, r, None) for label, r in scored]
    print("| Row | S [95 %] | E [95 %] | " + " | ".join("s_" + c for c, _ in COLUMNS) + " |")
    print("|---|---|---|" + "---|" * len(COLUMNS))
    for label, r, summary in rows:
        sc = summary if summary is not None else r["scores"]
        cells = [with_ci(sc["physical"], sc["physical_ci"]), with_ci(sc["wang2015"], sc["wang2015_ci"])]
        for _, name in COLUMNS:
            cells.append(fmt(term(r, name)["score"]) if r is not None else "-")
        print("| %s | %s |" % (label, " | ".join(cells)))
    print()
    # per term: real vs real against the baseline
    print("| Term | unit | real vs real s [95 %] | OU baseline s [95 %] | separated |")
    print("|---|---|---|---|---|")
    names = [m["name"] for m in real["metrics"]] + [c["name"] for c in real["curves"]]
    for name in names:
        a, b = term(real, name), term(b_builtin, name)
        unit = a.get("unit", "")
        if "axis" in a:
            unit = "over " + a["axis"] + (" (%s)" % a["axis_unit"])
        if a["score"] is None or b["score"] is None or not a["score_ci"] or not b["score_ci"]:
            verdict = "not scored"
        elif a["score_ci"][0] > b["score_ci"][1]:
            verdict = "yes"
        elif b["score"] >= a["score"]:
            verdict = "no: baseline as high or higher"
        else:
            verdict = "no: intervals overlap"
        print("| %s | %s | %s | %s | %s |" % (name, unit, with_ci(a["score"], a["score_ci"]),
                                             with_ci(b["score"], b["score_ci"]), verdict))
    sa, sb = real["scores"], b_builtin
    print("| **S** (%d terms) | | %s | %s | %s |" % (
        sa["physical_terms"], with_ci(sa["physical"], sa["physical_ci"]), with_ci(sb["physical"], sb["physical_ci"]),
        "yes" if sa["physical_ci"][0] > sb["physical_ci"][1] else "no"))
    print("| **E** (7 metrics) | | %s | %s | %s |" % (
        with_ci(sa["wang2015"], sa["wang2015_ci"]), with_ci(sb["wang2015"], sb["wang2015_ci"]),
        "yes" if sa["wang2015_ci"][0] > sb["wang2015_ci"][1] else "no"))

if __name__ == "__main__":
    tables(sys.argv[2], sys.argv[3])
PY

if [ -n "$KEEP" ]; then cp "$TMP"/*.json "$KEEP"/; fi
step "done"

CPU=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo 2>/dev/null | head -1)
echo "Measured $(date +%F) with $("$B" --version 2>/dev/null | head -1) (commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)),"
echo "$(uname -sm), ${CPU:-unknown CPU}, $(nproc) cores, in $(( $(date +%s) - START )) s: \`scripts/leaderboard.sh\`"
echo "(REF $REF)."
echo
"$PY" "$TMP/lb.py" tables "$TMP" "$REF"
