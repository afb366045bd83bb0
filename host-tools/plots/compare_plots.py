#!/usr/bin/env python3
"""The figures of omni4-compare (docs/compare.md) from its --out folder:

usage: compare_plots.py DIR

  - envelope.png: the acceleration envelope from rest of every robot on one polar figure (the
    largest acceleration [m/s^2] per heading in the v-vn plane, envelope.csv) and beside it the
    top steady speed per heading [m/s] (speed.csv);
  - layouts.png: each robot's wheels drawn from wheels.csv (position, drive direction
    counter-clockwise, the traction margin at the envelope's weakest heading).
Both written into DIR (omni4.outfile: a temporary and a rename) and linked from DIR/compare.md's
end if not yet there. A file missing or a value that is not a number: one line, status 1.
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FIGURES = ("envelope.png", "layouts.png")


def read(dir_, name, numbers):
    """Rows of dir_/name with the columns in numbers as floats; exits with one line if not."""
    path = os.path.join(dir_, name)
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        for i, r in enumerate(rows):
            for c in numbers:
                try:
                    r[c] = float(r[c])
                except (TypeError, ValueError, KeyError):
                    sys.exit(f"compare_plots: {path}:{i + 2}: column {c}: not a number")
                if not math.isfinite(r[c]):
                    sys.exit(f"compare_plots: {path}:{i + 2}: column {c}: not finite")
    except OSError as e:
        sys.exit(f"compare_plots: {path}: {e.strerror}")
    return rows


def by_robot(rows):
    out = {}
    for r in rows:
        out.setdefault(r["robot"], []).append(r)
    return out


def polar(ax, rows, column, title):
    for name, rs in by_robot(rows).items():
        th = [math.radians(r["heading_deg"]) for r in rs] + [math.radians(rs[0]["heading_deg"])]
        ax.plot(th, [r[column] for r in rs] + [rs[0][column]], label=name)
    ax.set_title(title)
    ax.set_theta_zero_location("N")  # v ahead, vn to the left (counter-clockwise)
    ax.set_theta_direction(1)


def envelope_figure(dir_):
    env = read(dir_, "envelope.csv", ("heading_deg", "acc_max_m_s2"))
    speed = read(dir_, "speed.csv", ("heading_deg", "top_speed_m_s"))
    fig = plt.figure(figsize=(10, 5))
    a = fig.add_subplot(1, 2, 1, projection="polar")
    polar(a, env, "acc_max_m_s2", "largest acceleration from rest [m/s^2]")
    b = fig.add_subplot(1, 2, 2, projection="polar")
    polar(b, speed, "top_speed_m_s", "top steady speed [m/s]")
    b.legend(loc="lower right", bbox_to_anchor=(1.3, -0.1))
    return fig


def layouts_figure(dir_):
    rows = by_robot(read(dir_, "wheels.csv", ("angle_deg", "d_m", "traction_margin")))
    fig, axes = plt.subplots(1, len(rows), figsize=(3.6 * len(rows), 3.8), squeeze=False)
    for ax, (name, ws) in zip(axes[0], rows.items()):
        reach = max(w["d_m"] for w in ws) * 1.5
        for j, w in enumerate(ws):
            a = math.radians(w["angle_deg"])
            # the robot frame drawn with v up and vn to the left
            px, py = -w["d_m"] * math.sin(a), w["d_m"] * math.cos(a)
            dx, dy = -math.cos(a), -math.sin(a)  # the drive: (-sin a, cos a) in (v, vn)
            ax.plot([0, px], [0, py], color="0.7")
            ax.plot([px - 0.3 * reach * dx, px + 0.3 * reach * dx],
                    [py - 0.3 * reach * dy, py + 0.3 * reach * dy], lw=4)
            m = 0.0 if abs(w["traction_margin"]) < 1e-9 else w["traction_margin"]
            ax.annotate(f"{j}: margin {m:.2f}", (px, py), fontsize=8,
                        xytext=(4, 4), textcoords="offset points")
        ax.arrow(0, 0, 0, 0.5 * reach, width=0.004, color="k")
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.set_title(f"{name} (arrow: v)")
        ax.set_xlabel("-vn [m]")
    return fig


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", help="omni4-compare's --out folder")
    a = ap.parse_args()
    if not os.path.isdir(a.dir):
        sys.exit(f"compare_plots: {a.dir}: no such folder")
    try:
        from omni4.outfile import OutError, OutFile
    except ImportError as e:
        sys.exit(f"compare_plots: needs the omni4 package ({e}): pip install ./python")
    try:
        for name, fig in zip(FIGURES, (envelope_figure(a.dir), layouts_figure(a.dir))):
            fig.tight_layout()
            path = os.path.join(a.dir, name)
            try:
                with OutFile(path, binary=True) as f:
                    fig.savefig(f, dpi=110, format="png")
            except OSError as e:
                raise OutError(path, e) from None
            plt.close(fig)
        md = os.path.join(a.dir, "compare.md")
        with open(md) as f:
            text = f.read()
        links = "".join(f"\n![{n}]({n})\n" for n in FIGURES if f"]({n})" not in text)
        if links:
            with OutFile(md) as f:
                f.write(text + links)
    except OutError as e:
        sys.exit(f"compare_plots: {e}")
    except OSError as e:
        sys.exit(f"compare_plots: {e.filename}: {e.strerror}")
    print(f"compare_plots: wrote {', '.join(FIGURES)} to {a.dir}")


if __name__ == "__main__":
    main()
