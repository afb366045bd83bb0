#!/usr/bin/env python3
"""Draws docs/kinematics.png: the robot frame, the wheel numbering, each wheel's positive rim
direction and which CAN node and channel drives it (docs/kinematics.md).

The wheel geometry is stated once here (wheel j at angle 90 j degrees from the v axis, its
positive rim direction counter-clockwise) and checked against the inverse kinematics of eq 2
as the controller implements it (model/src/kinematics.c: rows [0 1 d], [-1 0 d], [0 -1 d],
[1 0 d]) before anything is drawn.

    python3 docs/kinematics_figure.py [OUT.png]
"""
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, FancyArrowPatch, Rectangle  # noqa: E402

D = 0.089  # centre to wheel [m] (Table III)
IK_ROWS = ((0, 1, D), (-1, 0, D), (0, -1, D), (1, 0, D))  # eq 2, model/src/kinematics.c
CAN = {0: "node 0 ch 0", 1: "node 0 ch 1", 2: "node 1 ch 2", 3: "node 1 ch 3"}
PLACE = {0: "front", 1: "left", 2: "rear", 3: "right"}


def wheel(j):
    """Position (x, y) [m] in the robot frame and unit positive rim direction of wheel j."""
    phi = math.radians(90 * j)
    return (D * math.cos(phi), D * math.sin(phi)), (-math.sin(phi), math.cos(phi))


def check_against_ik():
    """The rim speed of wheel j is t_j . (v, vn) + d w: its IK row is (t_x, t_y, d)."""
    for j, row in enumerate(IK_ROWS):
        _, t = wheel(j)
        got = (round(t[0], 12), round(t[1], 12), D)
        if any(abs(a - b) > 1e-12 for a, b in zip(got, row)):
            raise SystemExit(f"kinematics_figure: wheel {j}: rim direction gives IK row {got}, "
                             f"eq 2 says {row}")


def draw(out):
    fig, ax = plt.subplots(figsize=(6.4, 6.4))
    ax.add_patch(Circle((0, 0), D, fill=False, lw=1.5, ls="--", color="0.5"))
    ax.annotate("", xy=(0.07, 0), xytext=(0, 0),
                arrowprops=dict(arrowstyle="-|>", lw=2, color="tab:red"))
    ax.text(0.045, -0.008, "v (forward)", color="tab:red", va="top", ha="center")
    ax.annotate("", xy=(0, 0.07), xytext=(0, 0),
                arrowprops=dict(arrowstyle="-|>", lw=2, color="tab:green"))
    ax.text(-0.008, 0.06, "vn", color="tab:green", ha="right")
    ax.add_patch(FancyArrowPatch((0.035, 0.0), (0.0, 0.035), connectionstyle="arc3,rad=0.45",
                                 arrowstyle="-|>", mutation_scale=14, lw=1.5, color="tab:blue"))
    ax.text(0.03, 0.03, "ω", color="tab:blue", fontsize=13)
    for j in range(4):
        (x, y), (tx, ty) = wheel(j)
        w, h = 0.05, 0.018  # drawn wheel: long side along the rim direction
        angle = math.degrees(math.atan2(ty, tx))
        rect = Rectangle((x - w / 2, y - h / 2), w, h, angle=angle, rotation_point="center",
                         color="0.25")
        ax.add_patch(rect)
        ax.annotate("", xy=(x + 0.045 * tx, y + 0.045 * ty), xytext=(x, y),
                    arrowprops=dict(arrowstyle="-|>", lw=1.8, color="tab:orange"))
        lx, ly = 2.3 * x, 2.3 * y
        ax.text(lx, ly, f"wheel {j} ({PLACE[j]})\nmotor {j}, CAN {CAN[j]}\n"
                        f"v{j} = {fmt_row(IK_ROWS[j])}",
                ha="center", va="center", fontsize=9,
                bbox=dict(boxstyle="round", fc="white", ec="0.7"))
    ax.set_xlim(-0.3, 0.3)
    ax.set_ylim(-0.3, 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("robot frame x [m] (v)")
    ax.set_ylabel("robot frame y [m] (vn)")
    ax.set_title("omni4 wheel numbering (d = 89 mm)\norange: positive rim speed v_j, "
                 "counter-clockwise", fontsize=11)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def fmt_row(row):
    terms = []
    for c, name in zip(row[:2], ("v", "vn")):
        if c:
            terms.append(("+" if c > 0 else "-") + name)
    terms.append("+d ω")
    s = " ".join(terms)
    return s[1:] if s.startswith("+") else s


if __name__ == "__main__":
    check_against_ik()
    draw(sys.argv[1] if len(sys.argv) > 1 else "docs/kinematics.png")
