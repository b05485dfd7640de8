#!/usr/bin/env python3
"""Thread scaling on an idle and on a busy machine (docs/cli.md#threads).

For each load (idle; one competing busy process pinned to the last CPU; one
busy process on every CPU) and each binary given, runs `swarmsim bench --json`
at 1 and 2 threads, RUNS times, interleaving the binaries and alternating the
order of the thread counts, and prints the median steps/s of every case and
the threads the governor used. With --old, a second binary (for example a build
of an earlier commit) is measured in the same session for comparison.

  scripts/bench_busy.py build/swarmsim [--old OLD/swarmsim] [--runs 4]
                        [--agents 10000] [--scenario scenarios/locusts.json]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys


def bench(binary, extra, order):
    cmd = [binary, "bench", "--json", "--threads", order, "--repeat", "3"] + extra
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    rows = {}
    for line in out.splitlines():
        line = line.strip()
        if not line.startswith("{"):
            continue
        r = json.loads(line)
        rows[(r["scenario"], r["agents"], r["threads"])] = (r["steps_per_s"], r.get("threads_used", r["threads"]))
    return rows


def start_load(kind):
    cpus = sorted(os.sched_getaffinity(0))
    chosen = [] if kind == "idle" else ([cpus[-1]] if kind == "one" else cpus)
    procs = [subprocess.Popen(["taskset", "-c", str(c), "sh", "-c", "while :; do :; done"]) for c in chosen]
    return procs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--old", help="a second binary measured alongside")
    ap.add_argument("--runs", type=int, default=4, help="runs per binary and load (even: both thread orders alike)")
    ap.add_argument("--agents", action="append", default=[], help="extra agent counts for the built-in cases")
    ap.add_argument("--scenario", action="append", default=[], help="scenario files benched as well")
    ap.add_argument("--loads", default="idle,one,all")
    a = ap.parse_args()

    binaries = [("new", a.binary)] + ([("old", a.old)] if a.old else [])
    jobs = [[]] + [["--agents", n] for n in a.agents] + [[s, "--frames", "100"] for s in a.scenario]
    print("uptime:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    results = {}  # (load, label, scenario, agents, threads) -> [steps/s]
    teams = {}  # the same -> [threads the governor used, averaged over the timed steps]
    for load in a.loads.split(","):
        procs = start_load(load)
        try:
            for run in range(a.runs):
                # 1 then 2 threads, then 2 then 1: on this kind of machine a process slows down the longer a
                # load has run (the host's clock boost), so a fixed order would favour the first
                order = "1,2" if run % 2 == 0 else "2,1"
                for label, binary in binaries:
                    for extra in jobs:
                        for key, (v, used) in bench(binary, extra, order).items():
                            results.setdefault((load,) + (label,) + key, []).append(v)
                            teams.setdefault((load,) + (label,) + key, []).append(used)
        finally:
            for p in procs:
                p.kill()
                p.wait()
    print("uptime:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    print(f"median of {a.runs} runs (each the median of 3 repetitions), steps/s")
    print(f"{'load':5} {'binary':6} {'scenario':26} {'agents':>8} {'1 thread':>10} {'2 threads':>10} {'2/1':>6}"
          "  threads used at 2 (each run)")
    cases = sorted({k[1:5] for k in results if k[4] == 1}, key=lambda k: (k[0], k[1], k[2]))
    for load in a.loads.split(","):
        for label, scen, agents in sorted({(k[0], k[1], k[2]) for k in cases}, key=lambda k: (k[1], k[2], k[0])):
            one = results.get((load, label, scen, agents, 1))
            two = results.get((load, label, scen, agents, 2))
            if not one or not two:
                continue
            m1, m2 = statistics.median(one), statistics.median(two)
            used = " ".join(f"{u:.2f}" for u in teams.get((load, label, scen, agents, 2), []))
            print(f"{load:5} {label:6} {os.path.basename(scen):26} {agents:>8} {m1:>10.2f} {m2:>10.2f} {m2 / m1:>6.2f}"
                  f"  {used}")
    if a.old:
        print("\nnew / old, same load and threads:")
        for (load, label, scen, agents, threads), v in sorted(results.items()):
            if label != "new":
                continue
            o = results.get((load, "old", scen, agents, threads))
            if o:
                r = statistics.median(v) / statistics.median(o)
                print(f"{load:5} {os.path.basename(scen):26} {agents:>8} {threads} threads  {r:6.3f}")


if __name__ == "__main__":
    sys.exit(main())
