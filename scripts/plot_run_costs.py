#!/usr/bin/python3
"""Plots what a long run costs over time, from its run.json (`fsp run ... --out RUN`): the global
step's time per solve against the keyframes it held, the back end's median time per frame in each
tenth of the run and, given a memory log (lines "seconds_since_start rss_kb", e.g. VmRSS from
/proc/PID/status sampled every few seconds), the resident memory over the run.

    scripts/plot_run_costs.py RUN/run.json OUT.png [--rss rss.txt]
"""
import argparse
import json
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("plot_run_costs: matplotlib is missing (Debian: apt install python3-matplotlib)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_json")
    ap.add_argument("out_png")
    ap.add_argument("--rss", help="memory log: seconds since start, resident set size [kB]")
    a = ap.parse_args()
    with open(a.run_json) as f:
        run = json.load(f)
    g = run.get("global", {})
    tenths = run.get("estimator", {}).get("backend_ms_by_tenth", [])
    panels = 2 + (1 if a.rss else 0)
    fig, axes = plt.subplots(1, panels, figsize=(5 * panels, 3.8))
    ms, kfs = g.get("solve_ms", []), g.get("solve_keyframes", [])
    if ms:
        axes[0].plot(kfs[:-1], ms[:-1], ".", ms=3, label="during the run")
        axes[0].plot(kfs[-1:], ms[-1:], "r*", ms=10, label="final solve (all keyframes free)")
        axes[0].set_yscale("log")
        axes[0].legend(fontsize=8)
    axes[0].set_xlabel("keyframes in the solve")
    axes[0].set_ylabel("global solve [ms]")
    axes[0].set_title("global step: time per solve", fontsize=10)
    if tenths:
        axes[1].bar([f"{k + 1}" for k in range(len(tenths))], tenths, color="tab:blue")
    axes[1].set_xlabel("tenth of the run")
    axes[1].set_ylabel("back end per frame, median [ms]")
    axes[1].set_title("back end per frame", fontsize=10)
    if a.rss:
        t, kb = [], []
        with open(a.rss) as f:
            for line in f:
                p = line.split()
                if len(p) == 2 and p[0][0].isdigit():
                    t.append(float(p[0]))
                    kb.append(float(p[1]) / 1024.0)
        axes[2].plot(t, kb)
        axes[2].set_xlabel("wall time [s]")
        axes[2].set_ylabel("resident memory [MB]")
        axes[2].set_ylim(bottom=0)
        axes[2].set_title("memory", fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(f"{run.get('input', '')}: {run.get('frames', 0)} frames, "
                 f"{run.get('keyframes', 0)} keyframes", fontsize=11)
    fig.tight_layout()
    fig.savefig(a.out_png, dpi=90)


if __name__ == "__main__":
    main()
