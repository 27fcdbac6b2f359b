#!/usr/bin/python3
"""Plots of an `fsp bench` run: bench_plots.py DIR/metrics.json OUT_DIR.

Reads metrics.json (written by `fsp bench`) and, for each scene, the series file
(runs/.../bench_series.json) of the first successful seed of each configuration; writes into OUT_DIR:

  SCENE_top_view.png  trajectory and map from above, ground truth against the SE3-aligned estimate
  SCENE_rpe.png       relative translation and rotation error per step (the paper's Fig. 3)
  SCENE_corners.png   3D error of each corner of each matched object (Fig. 4)
  SCENE_sizes.png     width and height error per object (Fig. 5)
  SCENE_timing.png    time per stage and frame (median; back end also p90), real-time factor

Figs. 3-5 compare FSP with FHP: they show the configurations that have both (same front end and
mode), or every configuration when none has. Needs Debian's python3-matplotlib: without it the
script prints one line and exits 3 (`fsp bench` then writes report.md and metrics.json without
plots). Deterministic: the same inputs give the same pictures.
"""
import json
import os
import sys


def fail(message, code=2):
    print("bench_plots.py: " + message)
    sys.exit(code)


try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import ticker
except ImportError:
    fail("python3-matplotlib is missing (Debian: apt-get install python3-matplotlib); no plots", 3)

# Same colour for a front end + mode, FSP solid, FHP dashed.
PALETTE = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"]


def style(config, order):
    """Colour by front end + mode, line style by landmarks."""
    frontend, rest = config.split("/", 1)
    landmarks, mode = rest.split("-", 1)
    key = frontend + "/" + mode
    colour = PALETTE[order.index(key) % len(PALETTE)] if key in order else "k"
    return colour, "-" if landmarks == "fsp" else "--"


def style_order(configs):
    order = []
    for c in configs:
        frontend, rest = c.split("/", 1)
        key = frontend + "/" + rest.split("-", 1)[1]
        if key not in order:
            order.append(key)
    return order


def load_series(base, scene):
    """{config: (seed, series, aggregate mean, the run's metrics)} for the first successful seed
    of each config."""
    out = {}
    for config, c in scene["configs"].items():
        for seed, run in c["runs"].items():
            if "error" in run or "series" not in run:
                continue
            path = os.path.join(base, run["series"])
            if not os.path.exists(path):
                continue
            with open(path) as f:
                out[config] = (seed, json.load(f), c["aggregate"]["mean"], run)
            break
    return out


def paired(configs):
    """Configurations with an FSP and an FHP run of the same front end and mode."""
    names = set(configs)
    keep = [c for c in configs
            if c.replace("/fsp-", "/fhp-") in names and c.replace("/fhp-", "/fsp-") in names]
    return keep or list(configs)


def log_axis(axis):
    """A log axis labelled in plain numbers at 1, 2, 5 x 10^k (at 10^k over more than 3 decades);
    call after plotting (it reads the data limits)."""
    lo, hi = axis.get_view_interval()
    wide = lo > 0 and hi / lo > 1e3
    axis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0,) if wide else (1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: "%g" % v))
    axis.set_minor_formatter(ticker.NullFormatter())


def top_view(name, runs, path):
    configs = list(runs)
    n = len(configs)
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows), squeeze=False,
                             layout="constrained")
    for k, config in enumerate(configs):
        ax = axes[k // cols][k % cols]
        seed, s, _, run = runs[config]
        for o in s.get("objects_gt", []):
            xs = [p[0] for p in o["corners_W"]] + [o["corners_W"][0][0]]
            ys = [p[1] for p in o["corners_W"]] + [o["corners_W"][0][1]]
            ax.plot(xs, ys, color="k", lw=2.5, solid_capstyle="butt")
        if "xy_ref" in s:
            ax.plot([p[0] for p in s["xy_ref"]], [p[1] for p in s["xy_ref"]], color="0.6", lw=1.5,
                    label="ground truth")
            ax.plot([p[0] for p in s["xy_est"]], [p[1] for p in s["xy_est"]], color="#d62728",
                    lw=0.8, label="estimate (SE3-aligned)")
        for o in s.get("objects_est", []):
            xs = [p[0] for p in o["corners_W"]] + [o["corners_W"][0][0]]
            ys = [p[1] for p in o["corners_W"]] + [o["corners_W"][0][1]]
            ax.plot(xs, ys, color="#d62728", lw=1.0)
        # Frame the ground truth: a diverged estimate is clipped instead of shrinking the truth.
        xs = [p[0] for p in s.get("xy_ref", [])]
        ys = [p[1] for p in s.get("xy_ref", [])]
        for o in s.get("objects_gt", []):
            xs += [p[0] for p in o["corners_W"]]
            ys += [p[1] for p in o["corners_W"]]
        if xs:
            pad = 0.05 * max(max(xs) - min(xs), max(ys) - min(ys)) + 0.2
            ax.set_xlim(min(xs) - pad, max(xs) + pad)
            ax.set_ylim(min(ys) - pad, max(ys) + pad)
        ax.set_aspect("equal")
        ate = run.get("ate_se3_m")
        ax.set_title("%s, seed %s%s" % (config, seed, ", ATE %.2f cm" % (100 * ate) if ate else ""),
                     fontsize=10)
        if k + cols >= n:  # the lowest panel of its column
            ax.set_xlabel("x [m]")
        if k % cols == 0:
            ax.set_ylabel("y [m]")
        ax.grid(True, lw=0.3)
        if k == 0:
            ax.legend(loc="best", fontsize=8)
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle("%s: top view, ground truth (grey, black) and estimate (red)" % name)
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)


def rpe(name, runs, path):
    configs = paired(list(runs))
    order = style_order(configs)
    fig, axes = plt.subplots(2, 1, figsize=(11, 6.5), sharex=True)
    for config in configs:
        seed, s, _, _ = runs[config]
        if "rpe_trans_m" not in s or not s["rpe_trans_m"]:
            continue
        t = s["t_s"][1:]
        colour, ls = style(config, order)
        axes[0].plot(t, [100 * e for e in s["rpe_trans_m"]], color=colour, ls=ls, lw=0.8,
                     label="%s (seed %s)" % (config, seed))
        axes[1].plot(t, s["rpe_rot_deg"], color=colour, ls=ls, lw=0.8)
    for ax in axes:
        ax.set_yscale("log")
        log_axis(ax.yaxis)
        ax.grid(True, which="major", lw=0.3)
    axes[0].set_ylabel("translation error [cm]")
    axes[1].set_ylabel("rotation error [deg]")
    axes[1].set_xlabel("time [s]")
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title("%s: relative pose error per step (consecutive frames), FSP solid, FHP dashed"
                      % name)
    fig.tight_layout()
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)


def objects_axis(runs):
    """The configurations in plotting order, their styles, and the object ids on the x axis with
    their positions, for the per-object plots."""
    configs = paired(list(runs))
    ids = sorted({o["id"] for c in configs for o in runs[c][1].get("per_object", [])})
    return configs, style_order(configs), ids, {i: k for k, i in enumerate(ids)}


def corners(name, runs, path):
    configs, order, ids, index = objects_axis(runs)
    if not ids:
        return False
    fig, ax = plt.subplots(figsize=(max(8, 0.5 * len(ids) + 3), 4.5))
    width = 0.8 / max(1, len(configs))
    for n, config in enumerate(configs):
        seed, s, _, _ = runs[config]
        colour, ls = style(config, order)
        xs, ys = [], []
        for o in s.get("per_object", []):
            for j, e in enumerate(o["corner_err_m"]):
                xs.append(index[o["id"]] - 0.4 + width * (n + 0.5) + (j - 1.5) * width / 5)
                ys.append(100 * e)
        ax.plot(xs, ys, ls="none", marker="o" if ls == "-" else "^", ms=3.5, color=colour,
                label="%s (seed %s)" % (config, seed))
    ax.set_xticks(range(len(ids)))
    ax.set_xticklabels([str(i) for i in ids])
    ax.set_xlabel("object id (its four corners s1..s4 side by side)")
    ax.set_ylabel("corner 3D error [cm]")
    ax.set_yscale("log")
    log_axis(ax.yaxis)
    ax.grid(True, which="major", axis="y", lw=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.set_title("%s: corner error per corner after SE3 alignment, FSP (o) and FHP (^)" % name)
    fig.tight_layout()
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)
    return True


def sizes(name, runs, path):
    configs, order, ids, index = objects_axis(runs)
    if not ids:
        return False
    fig, axes = plt.subplots(2, 1, figsize=(max(8, 0.5 * len(ids) + 3), 6.5), sharex=True)
    width = 0.8 / max(1, len(configs))
    for n, config in enumerate(configs):
        seed, s, _, _ = runs[config]
        colour, ls = style(config, order)
        per = s.get("per_object", [])
        xs = [index[o["id"]] - 0.4 + width * (n + 0.5) for o in per]
        hatch = None if ls == "-" else "//"
        axes[0].bar(xs, [100 * o["width_err_m"] for o in per], width, color=colour, hatch=hatch,
                    edgecolor="white" if hatch else colour, lw=0,
                    label="%s (seed %s)" % (config, seed))
        axes[1].bar(xs, [100 * o["height_err_m"] for o in per], width, color=colour, hatch=hatch,
                    edgecolor="white" if hatch else colour, lw=0)
    classes = {}
    for c in configs:
        for o in runs[c][1].get("per_object", []):
            classes[o["id"]] = o.get("class", "")
    axes[1].set_xticks(range(len(ids)))
    axes[1].set_xticklabels(["%d\n%s" % (i, classes.get(i, "")) for i in ids], fontsize=7)
    axes[0].set_ylabel("width error [cm]")
    axes[1].set_ylabel("height error [cm]")
    for ax in axes:
        ax.grid(True, axis="y", lw=0.3)
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title("%s: width and height error per object, FSP (plain) and FHP (hatched)" % name)
    fig.tight_layout()
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)
    return True


STAGES = [("track", "track"), ("detect", "detect"), ("associate", "associate"),
          ("points", "points"), ("frontend", "front end"), ("backend", "back end")]


def stage_entries(st):
    """(label, ms) of the stages a run measured: medians, and the back end's p90."""
    entries = [(label, st[key]["median"]) for key, label in STAGES
               if isinstance(st.get(key), dict) and st[key].get("count", 0) > 0]
    if isinstance(st.get("backend"), dict) and st["backend"].get("count", 0) > 0:
        entries.append(("back end p90", st["backend"]["p90"]))
    return entries


def timing(name, runs, path):
    configs = list(runs)
    entries = {c: stage_entries(runs[c][1].get("stage_ms", {})) for c in configs}
    labels = []
    for c in configs:
        for label, _ in entries[c]:
            if label not in labels:
                labels.append(label)
    colours = dict(zip(labels, ["#bcbd22", "#17becf", "#e377c2", "#ff7f0e", "#1f77b4",
                                "#aec7e8", "#9467bd"]))
    # Each configuration takes as many bar slots as it has stages, plus a gap.
    height = 0.8
    centres, y = [], 0.0
    total = sum(len(entries[c]) for c in configs) + len(configs)
    fig, ax = plt.subplots(figsize=(10, 0.22 * total + 1.6))
    for config in configs:
        first = y
        for label, value in entries[config]:
            ax.barh(y, max(value, 1e-3), height, color=colours[label], label=label)
            ax.text(max(value, 1e-3) * 1.05, y, "%.3g" % value, va="center", fontsize=7)
            y += 1.0
        centres.append(0.5 * (first + y - 1.0))
        y += 1.0
    ticks = []
    for config in configs:
        rt = runs[config][2].get("realtime_factor")
        ticks.append(config + ("\n%.1fx real time" % rt if rt is not None else ""))
    ax.set_yticks(centres)
    ax.set_yticklabels(ticks, fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("log")
    log_axis(ax.xaxis)
    ax.set_xlabel("milliseconds per frame (median unless p90; the seed of the other plots)")
    ax.grid(True, which="major", axis="x", lw=0.3)
    handles, names = ax.get_legend_handles_labels()
    unique = dict(zip(names, handles))
    ax.legend(unique.values(), unique.keys(), fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    ax.set_title("%s: time per stage and frame (real-time factor: seed mean)" % name)
    fig.tight_layout()
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)


def main(argv):
    if len(argv) != 3:
        fail("usage: bench_plots.py METRICS_JSON OUT_DIR")
    metrics_path, out_dir = argv[1], argv[2]
    try:
        with open(metrics_path) as f:
            metrics = json.load(f)
    except (OSError, ValueError) as e:
        fail("%s: %s" % (metrics_path, e))
    base = os.path.dirname(os.path.abspath(metrics_path))
    os.makedirs(out_dir, exist_ok=True)
    written = []
    for name, scene in metrics.get("scenes", {}).items():
        runs = load_series(base, scene)
        if not runs:
            print("%s: no successful run, no plots" % name)
            continue
        stem = os.path.join(out_dir, name.replace("/", "_"))
        top_view(name, runs, stem + "_top_view.png")
        written.append(stem + "_top_view.png")
        rpe(name, runs, stem + "_rpe.png")
        written.append(stem + "_rpe.png")
        if corners(name, runs, stem + "_corners.png"):
            written.append(stem + "_corners.png")
        if sizes(name, runs, stem + "_sizes.png"):
            written.append(stem + "_sizes.png")
        timing(name, runs, stem + "_timing.png")
        written.append(stem + "_timing.png")
    for w in written:
        print("wrote " + w)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
