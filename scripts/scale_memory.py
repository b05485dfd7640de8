#!/usr/bin/env python3
"""Peak memory and speed of boids at growing agent counts, at one density.

For each count N it scales scenarios/boids_100k.json (spawn radius and domain by
(N / 100,000)^(1/3), so the density and the neighbour count stay those of the
bench case), then
  - runs `swarmsim run` of it for a few frames under /usr/bin/time -v and reads
    the peak resident set size (everything: state, grid, scratch, writer
    buffers, libraries), and
  - times it with `swarmsim bench --agents N` (no output written) for the
    nanoseconds per agent-step.
It prints a Markdown table (docs/performance.md#memory quotes one).

usage: scripts/scale_memory.py [--swarmsim build/swarmsim] [--counts 100000,1000000,10000000]
                               [--frames 4] [--threads 2] [--repeat 3]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BASE = os.path.join(ROOT, "scenarios", "boids_100k.json")


def peak_rss_kib(cmd):
    """run cmd under /usr/bin/time -v; its peak RSS in KiB (the exit status must be 0)"""
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr[-2000:]))
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    if not m:
        sys.exit("no peak RSS in /usr/bin/time's report (is the time package installed?)")
    return int(m.group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--swarmsim", default=os.path.join(ROOT, "build", "swarmsim"))
    ap.add_argument("--counts", default="100000,1000000,10000000")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    with open(BASE) as f:
        base = json.load(f)
    n0 = base["swarms"][0]["count"]
    r0 = base["swarms"][0]["spawn"]["radius"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in [int(c) for c in a.counts.split(",")]:
            s = (n / n0) ** (1.0 / 3.0)
            lo = [v * s for v in base["domain"]["min"]]
            hi = [v * s for v in base["domain"]["max"]]
            sets = ["--set", "swarms[0].count=%d" % n, "--set", "swarms[0].spawn.radius=%r" % (r0 * s),
                    "--set", "domain.min=%s" % json.dumps(lo), "--set", "domain.max=%s" % json.dumps(hi)]
            out = os.path.join(tmp, "out_%d.h5" % n)
            rss = peak_rss_kib([a.swarmsim, "run", BASE, "--frames", str(a.frames), "--threads", str(a.threads),
                                "--quiet", "-o", out] + sets)
            os.remove(out)
            b = subprocess.run([a.swarmsim, "bench", "--json", "--fixed-threads", "--threads", str(a.threads),
                                "--frames", str(a.frames), "--repeat", str(a.repeat), BASE] + sets,
                               stdout=subprocess.PIPE, text=True, check=True)
            ns = [json.loads(l)["ns_per_agent_step"] for l in b.stdout.splitlines() if l.startswith("{")][0]
            rows.append((n, rss, ns))
            print("%d agents: peak RSS %.1f MiB (%.1f bytes per agent), %.1f ns per agent-step" %
                  (n, rss / 1024.0, rss * 1024.0 / n, ns), file=sys.stderr)
    print("| agents | peak RSS (MiB) | bytes per agent | ns per agent-step (%d threads) |" % a.threads)
    print("|---:|---:|---:|---:|")
    for n, rss, ns in rows:
        print("| %s | %.1f | %.1f | %.1f |" % (format(n, ","), rss / 1024.0, rss * 1024.0 / n, ns))


if __name__ == "__main__":
    main()
