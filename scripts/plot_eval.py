#!/usr/bin/python3
"""Draws the budget-ablation plots of a gauss-eval report.

    /usr/bin/python3 scripts/plot_eval.py docs/results/<name>/report.json docs/results/<name>

Reads report.json's "ablation" list, one item per (scene, budget M, resolution):
    {"scene": str, "budget": int, "width": int, "height": int,
     "psnr_pc_hs": float, "ssim_pc_hs": float, "flip_pc_hs": float,
     "frame_ms_p50": float, "frame_ms_p95": float}
and writes into the output folder (made if missing):
    ablation_<scene>.png  PC-HS PSNR against M (log axis), client frame time p50 on a second
                          axis, one line per resolution;
    pareto.png            PSNR against frame time p50 over every budget and resolution, one
                          panel per scene, the Pareto front (the best PSNR reachable within
                          each frame time) marked and connected, points labelled by M and
                          resolution.
It prints each file it wrote. A point whose PSNR is null (not available) or infinite
(identical images) cannot be placed: it is left out with a note on stderr.

Exit status: 0 written; 1 bad input (missing file, bad JSON, missing or mistyped field:
one line on stderr naming the item and field); 77 python3-matplotlib is not installed
(the input is still checked first; CTest reads 77 as "skipped").
Debian packages: python3-matplotlib (scripts/packages.txt).
"""
import argparse
import json
import math
import os
import re
import sys

FIELDS = {
    "scene": str,
    "budget": int,
    "width": int,
    "height": int,
    "psnr_pc_hs": float,
    "ssim_pc_hs": float,
    "flip_pc_hs": float,
    "frame_ms_p50": float,
    "frame_ms_p95": float,
}
# Metrics that may be null in a report ("n/a"); the rest must be numbers.
NULLABLE = {"psnr_pc_hs", "ssim_pc_hs", "flip_pc_hs"}


class InputError(Exception):
    pass


def load_ablation(path):
    """Returns the checked "ablation" items of the report at path, or raises InputError."""
    try:
        with open(path, encoding="utf-8") as f:
            report = json.load(f)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file")
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror}")
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: not valid JSON: {e}")
    if not isinstance(report, dict):
        raise InputError(f"{path}: the top level is not an object")
    items = report.get("ablation")
    if items is None:
        raise InputError(f'{path}: no "ablation" list')
    if not isinstance(items, list):
        raise InputError(f'{path}: "ablation" is not a list')
    if not items:
        raise InputError(f'{path}: "ablation" is empty: nothing to plot')
    for i, item in enumerate(items):
        where = f"{path}: ablation[{i}]"
        if not isinstance(item, dict):
            raise InputError(f"{where} is not an object")
        for name, kind in FIELDS.items():
            if name not in item:
                raise InputError(f'{where}: missing field "{name}"')
            v = item[name]
            if v is None and name in NULLABLE:
                continue
            if kind is str:
                ok = isinstance(v, str) and v != ""
            elif kind is int:
                ok = isinstance(v, int) and not isinstance(v, bool) and v > 0
            else:
                ok = isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)
            if not ok:
                want = {str: "a non-empty string", int: "a positive integer",
                        float: "a number"}[kind]
                raise InputError(f'{where}: field "{name}" is {json.dumps(v)}, not {want}')
        if not math.isfinite(item["frame_ms_p50"]) or item["frame_ms_p50"] < 0:
            raise InputError(f'{where}: field "frame_ms_p50" must be a finite time >= 0')
    return items


def file_stem(scene):
    """A scene name as a file-name part: letters, digits, '.', '_' and '-' only."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", scene)


def budget_label(m):
    if m >= 1000000 and m % 1000000 == 0:
        return f"{m // 1000000}M"
    if m >= 1000 and m % 1000 == 0:
        return f"{m // 1000}k"
    return str(m)


def resolution_label(w, h):
    return f"{w}\u00d7{h}"


def plottable(item):
    p = item["psnr_pc_hs"]
    return p is not None and math.isfinite(p)


def note_unplottable(items):
    for it in items:
        if not plottable(it):
            why = "null" if it["psnr_pc_hs"] is None else "infinite (identical images)"
            print(f'plot_eval: note: {it["scene"]} M={it["budget"]} '
                  f'{resolution_label(it["width"], it["height"])}: PSNR is {why}, not drawn',
                  file=sys.stderr)


def pareto_front(points):
    """points: (time, psnr, item). The front: points no other point beats with at most the
    same time and a higher PSNR, ordered by time."""
    front = []
    best = -math.inf
    for t, p, it in sorted(points, key=lambda q: (q[0], -q[1])):
        if p > best:
            front.append((t, p, it))
            best = p
    return front


def plot_ablation(plt, scene, items, out_dir):
    # One curve per view size and LoD setting ("lod": false marks gauss-eval --lod both's
    # leaf-only comparison runs; reports before LoD have no such field).
    by_res = {}
    for it in items:
        by_res.setdefault((it["width"], it["height"], it.get("lod", True)), []).append(it)
    fig, ax = plt.subplots(figsize=(8, 5), dpi=120)
    ax_t = ax.twinx()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    budgets = sorted({it["budget"] for it in items})
    handles = []
    for k, (res, runs) in enumerate(sorted(by_res.items(), key=lambda r: (r[0][0] * r[0][1], not r[0][2]))):
        runs = sorted(runs, key=lambda it: it["budget"])
        c = colours[k % len(colours)]
        drawn = [it for it in runs if plottable(it)]
        label = resolution_label(res[0], res[1]) + ("" if res[2] else ", leaves only")
        (h,) = ax.plot([it["budget"] for it in drawn], [it["psnr_pc_hs"] for it in drawn],
                       "-o", color=c, lw=2, ms=5, label=label)
        ax_t.plot([it["budget"] for it in runs], [it["frame_ms_p50"] for it in runs],
                  "--s", color=c, lw=1.5, ms=4, alpha=0.85)
        handles.append(h)
    ax.set_xscale("log")
    ax.set_xticks(budgets)
    ax.set_xticklabels([budget_label(m) for m in budgets])
    ax.minorticks_off()
    ax.set_xlabel("budget M (resident Gaussians, log scale)")
    ax.set_ylabel("PC\u2013HS PSNR (dB), solid")
    ax_t.set_ylabel("client frame time p50 (ms), dashed")
    ax_t.set_ylim(bottom=0)
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(f"{scene}: fidelity and frame time against budget")
    style = [plt.Line2D([], [], color="0.2", ls="-", marker="o", label="PSNR (left)"),
             plt.Line2D([], [], color="0.2", ls="--", marker="s", label="frame p50 (right)")]
    fig.legend(handles=handles + style, loc="lower center", ncol=len(handles) + 2, fontsize=8,
               frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    path = os.path.join(out_dir, f"ablation_{file_stem(scene)}.png")
    fig.savefig(path)
    plt.close(fig)
    return path


# Label positions tried in turn (offset in points, horizontal alignment): right of the point
# above, right below, left above, left below, straight above, straight below.
LABEL_SPOTS = [((6, 3), "left"), ((6, -10), "left"), ((-6, 3), "right"), ((-6, -10), "right"),
               ((0, 8), "center"), ((0, -16), "center")]


def label_points(fig, ax, points):
    """Labels (x, y, text) points, each at the first spot inside the axes that overlaps
    neither an earlier label nor a marker (else at the first spot)."""
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    markers = []
    for x, y, _ in points:
        px, py = ax.transData.transform((x, y))
        markers.append((px - 5, py - 5, px + 5, py + 5))
    placed = []

    def clear(box):
        if box.x0 < frame.x0 or box.x1 > frame.x1 or box.y0 < frame.y0 or box.y1 > frame.y1:
            return False
        return not any(box.x0 < b[2] and box.x1 > b[0] and box.y0 < b[3] and box.y1 > b[1]
                       for b in placed + markers)

    for x, y, text in sorted(points):
        for k, (offset, ha) in enumerate(LABEL_SPOTS):
            a = ax.annotate(text, (x, y), textcoords="offset points", xytext=offset, ha=ha,
                            fontsize=7, color="0.25")
            box = a.get_window_extent(renderer)
            if clear(box) or k == len(LABEL_SPOTS) - 1:
                if not clear(box):  # nowhere free: keep the first spot
                    a.remove()
                    a = ax.annotate(text, (x, y), textcoords="offset points",
                                    xytext=LABEL_SPOTS[0][0], ha=LABEL_SPOTS[0][1], fontsize=7,
                                    color="0.25")
                    box = a.get_window_extent(renderer)
                placed.append((box.x0, box.y0, box.x1, box.y1))
                break
            a.remove()


def plot_pareto(plt, scenes, out_dir):
    n = len(scenes)
    cols = min(n, 2)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(7.5 * cols, 5.5 * rows), dpi=120,
                             squeeze=False)
    markers = ["o", "s", "^", "D", "v", "P", "X"]
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (scene, items) in zip(axes.flat, scenes):
        items = [it for it in items if it.get("lod", True)]  # the system as run, not the comparison
        resolutions = sorted({(it["width"], it["height"]) for it in items},
                             key=lambda r: r[0] * r[1])
        points = [(it["frame_ms_p50"], it["psnr_pc_hs"], it) for it in items if plottable(it)]
        for k, res in enumerate(resolutions):
            mine = [q for q in points if (q[2]["width"], q[2]["height"]) == res]
            ax.scatter([q[0] for q in mine], [q[1] for q in mine], s=36,
                       marker=markers[k % len(markers)], color=colours[k % len(colours)],
                       label=resolution_label(*res), zorder=3)
        front = pareto_front(points)
        if front:
            ax.step([q[0] for q in front], [q[1] for q in front], where="post", color="crimson",
                    lw=1.5, zorder=2, label="Pareto front")
            ax.scatter([q[0] for q in front], [q[1] for q in front], s=140, facecolors="none",
                       edgecolors="crimson", lw=1.5, zorder=4)
        ax.set_xlabel("client frame time p50 (ms, lower is better)")
        ax.set_ylabel("PC\u2013HS PSNR (dB, higher is better)")
        ax.set_title(f"{scene}: error against run time")
        ax.grid(True, alpha=0.3)
        ax.margins(x=0.15, y=0.1)
        ax.legend(loc="lower right", fontsize=8)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.tight_layout()
    for ax, (scene, items) in zip(axes.flat, scenes):
        label_points(fig, ax, [(it["frame_ms_p50"], it["psnr_pc_hs"],
                                f'{budget_label(it["budget"])} @ '
                                f'{resolution_label(it["width"], it["height"])}')
                               for it in items if plottable(it)])
    path = os.path.join(out_dir, "pareto.png")
    fig.savefig(path)
    plt.close(fig)
    return path


class Parser(argparse.ArgumentParser):
    def error(self, message):
        # One line and status 1, like every other input error (argparse uses 2).
        print(f"plot_eval: error: {message} (see --help)", file=sys.stderr)
        sys.exit(1)


def main(argv):
    parser = Parser(
        prog="plot_eval", description="Draws the budget-ablation plots of a gauss-eval report.")
    parser.add_argument("report", help="report.json written by gauss-eval")
    parser.add_argument("out_dir", help="folder for the PNG files (made if missing)")
    args = parser.parse_args(argv)
    try:
        items = load_ablation(args.report)
    except InputError as e:
        print(f"plot_eval: error: {e}", file=sys.stderr)
        return 1
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_eval: python3-matplotlib is not installed (apt-get install "
              "python3-matplotlib): no plots drawn", file=sys.stderr)
        return 77
    try:
        os.makedirs(args.out_dir, exist_ok=True)
    except OSError as e:
        print(f"plot_eval: error: {args.out_dir}: cannot make the folder: {e.strerror}",
              file=sys.stderr)
        return 1
    note_unplottable(items)
    scenes = {}
    for it in items:
        scenes.setdefault(it["scene"], []).append(it)
    scenes = sorted(scenes.items())
    stems = {}
    for scene, _ in scenes:
        other = stems.setdefault(file_stem(scene), scene)
        if other != scene:
            print(f'plot_eval: error: {args.report}: scenes "{other}" and "{scene}" would both '
                  f"write ablation_{file_stem(scene)}.png", file=sys.stderr)
            return 1
    written = []
    try:
        for scene, runs in scenes:
            written.append(plot_ablation(plt, scene, runs, args.out_dir))
        written.append(plot_pareto(plt, scenes, args.out_dir))
    except OSError as e:
        print(f"plot_eval: error: cannot write into {args.out_dir}: {e.strerror}", file=sys.stderr)
        return 1
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
