"""The report's wheel layout: where each wheel sits and which way it drives, drawn from
layout.csv of `omni4-ident identify --csv` (written for a layout other than the paper's: wheel,
angle_deg from the v axis counter-clockwise, d_m from the centre)."""
import csv
import math
import os
import sys


def read_layout(csv_dir):
    """[(wheel, angle [deg], distance [m])]; [] without the file. A value that is not a number,
    or a column missing: exit 1 with one line naming the file and the line."""
    path = os.path.join(csv_dir, "layout.csv")
    if not os.path.exists(path):
        return []
    out = []
    with open(path, newline="") as f:
        for k, r in enumerate(csv.DictReader(f), start=2):
            try:
                w = (int(r["wheel"]), float(r["angle_deg"]), float(r["d_m"]))
            except (KeyError, TypeError, ValueError) as e:
                sys.exit(f"omni4_report: {path} line {k}: wheel, angle_deg, d_m must be "
                         f"numbers ({e})")
            if not (math.isfinite(w[1]) and w[2] > 0 and math.isfinite(w[2])):
                sys.exit(f"omni4_report: {path} line {k}: angle and distance must be finite, "
                         "the distance > 0")
            out.append(w)
    return out


def layout_figure(plt, save, csv_dir, out_dir):
    """(figure name or None, Markdown lines): the wheels seen from above, v to the right, vn up;
    each wheel a bar across its radius with an arrow along its positive drive direction
    (eq 2: the radius turned by +90 deg)."""
    wheels = read_layout(csv_dir)
    if not wheels:
        return None, []
    fig, ax = plt.subplots(figsize=(4.6, 4.6))
    reach = max(d for _, _, d in wheels)
    ax.add_patch(plt.Circle((0, 0), reach, fill=False, color="0.7", ls="--"))
    ax.plot([0], [0], "k+")
    ax.annotate("", (0.5 * reach, 0), (0, 0), arrowprops={"arrowstyle": "->", "color": "0.5"})
    ax.text(0.52 * reach, 0.02 * reach, "v", color="0.5")
    ax.annotate("", (0, 0.5 * reach), (0, 0), arrowprops={"arrowstyle": "->", "color": "0.5"})
    ax.text(0.02 * reach, 0.52 * reach, "vn", color="0.5")
    half = 0.18 * reach
    lines = ["## Wheel layout", "", "| wheel | angle [deg] | distance [m] |", "|---|---|---|"]
    for j, a_deg, d in wheels:
        a = math.radians(a_deg)
        cx, cy = d * math.cos(a), d * math.sin(a)
        tx, ty = -math.sin(a), math.cos(a)  # the drive direction
        ax.plot([cx - half * tx, cx + half * tx], [cy - half * ty, cy + half * ty], lw=5,
                color="C0", solid_capstyle="butt")
        ax.annotate("", (cx + 1.6 * half * tx, cy + 1.6 * half * ty), (cx, cy),
                    arrowprops={"arrowstyle": "->", "color": "C3"})
        ax.text(1.25 * cx, 1.25 * cy, f"{j}", ha="center", va="center")
        lines.append(f"| {j} | {a_deg:g} | {d:g} |")
    ax.set_xlim(-1.5 * reach, 1.5 * reach)
    ax.set_ylim(-1.5 * reach, 1.5 * reach)
    ax.set_aspect("equal")
    ax.set_xlabel("v axis [m]")
    ax.set_ylabel("vn axis [m]")
    ax.set_title(f"{len(wheels)} wheels (red: positive drive)")
    name = save(fig, out_dir, "layout.png")
    return name, lines + [""]
