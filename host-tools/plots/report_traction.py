"""The report's traction section: per direction of the traction experiment, the acceleration
each level reached against the slip measured (the encoders' velocity against what the currents
give a gripping robot: `traction_runs.csv` of `omni4-ident identify --csv`), with the largest
acceleration held and the slip tolerance marked, and the floor's coefficient per direction
(`traction.csv`)."""
import csv
import os

SLIP_TOLERANCE = 0.02  # m/s: ident_traction's runaway test (at rest; + 3 % of the speed)
UNITS = {"w": "rad/s^2"}


def read_rows(csv_dir, name):
    path = os.path.join(csv_dir, name)
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def traction_figure(plt, save, csv_dir, out_dir):
    """The figure's file name (None without traction runs) and the section's Markdown lines."""
    runs = read_rows(csv_dir, "traction_runs.csv")
    dirs = read_rows(csv_dir, "traction.csv")
    if not runs:
        return None, []
    order = [d["direction"] for d in dirs] or sorted({r["direction"] for r in runs})
    fig, axes = plt.subplots(1, len(order), figsize=(3.2 * len(order), 3.4), squeeze=False)
    for ax, name in zip(axes[0], order):
        rs = [r for r in runs if r["direction"] == name]
        for slipped, style, label in (("0", "o", "held"), ("1", "x", "slipped")):
            sel = [r for r in rs if r["slipped"] == slipped]
            ax.plot([float(r["slip_m_s"]) for r in sel], [float(r["acc"]) for r in sel],
                    style, color="C0" if slipped == "0" else "C3", label=label)
        limit = next((d for d in dirs if d["direction"] == name), None)
        if limit is not None and float(limit["acc"]) > 0:
            ax.axhline(float(limit["acc"]), color="k", ls="--", lw=0.8,
                       label=f"held {float(limit['acc']):.3g}")
        ax.axvline(SLIP_TOLERANCE, color="0.5", ls=":", lw=0.8)
        ax.set_xscale("symlog", linthresh=0.01)
        ax.set_xlabel("slip [m/s]")
        ax.set_ylabel(f"acceleration [{UNITS.get(name, 'm/s^2')}]")
        ax.set_title(name)
        ax.grid(True)
        ax.legend(fontsize=7)
    fig.suptitle("Traction: acceleration reached against slip per level")
    lines = ["## Traction (the floor)", "",
             "| direction | runs | held to [V] | slips at [V] | mu ± SE | largest held "
             "acceleration ± SE |", "|---|---|---|---|---|---|"]
    for d in dirs:
        mu = ("" if d["reached"] == "1" else ">= ") + f"{float(d['mu']):.4f} ± " \
            f"{float(d['mu_se']):.4f}"
        lines.append(f"| {d['direction']} | {d['runs']} | {float(d['level_held_v']):.2f} | "
                     f"{float(d['level_slip_v']):.2f} | {mu} | {float(d['acc']):.3f} ± "
                     f"{float(d['acc_se']):.3f} {UNITS.get(d['direction'], 'm/s^2')} |")
    return save(fig, out_dir, "traction.png"), lines + [""]
