#!/usr/bin/env python3
"""Plots and a one-page Markdown report from the CSV exports of omni4-ident.

usage: omni4_report.py CSV_DIR OUT_DIR [--json VALIDATION.json] [--log LOG...] [--params INI]

CSV_DIR holds what `omni4-ident identify --csv DIR` and `omni4-ident validate --csv DIR` wrote.
Figures follow the paper: T vs w (exp 1, fig 4a), coast-down with its fit (exp 2, fig 4b),
u/i vs w_m/i per motor (motor test, fig 5), measured vs simulated v, vn, w (figs 6-7), and,
when `identify --bootstrap N` ran, the bootstrap distribution of every final parameter.

--log LOG...: the raw time series of each event log (wheel speeds, currents, voltages, the
experiment segments shaded) and what was read from it, through the omni4 Python package
(omni4.read_log; `pip install ./python`, or the project's .venv/bin/python). A split log is
given as its parts or as FILE when only FILE.00, FILE.01, ... exist. A log with the
controller's state estimate (OMNI4_STATE) also gets a figure of the paths: the estimate, the
camera (OMNI4_POSE), wheel odometry (eqs 3-5 integrated, d and r of --params, default Table III)
and, from a simulator, the true path (OMNI4_SIM_TRUTH), with each one's error over time. A log
with the adapted motor constants (OMNI4_ADAPT) gets a drift section: per motor the identified
R_j (the log's start notice on OMNI4_PARAM_CHANGED, else --params, else its first adapt_t when
nothing was adapted yet), the last R_j in use, its change in %, the last estimate, and a figure
of each R_j in use and its estimate over time; a log without OMNI4_ADAPT gets the report it got
before (byte for byte).

OUT_DIR is made if missing (an existing file there is refused); each file in it is written as
every omni4 output is (omni4.outfile: a temporary beside it and a rename, a symbolic link's
target replaced, a FIFO or device in place); a file that cannot be written ends the report with
one line naming it and status 1. Needs the omni4 package for that too.
"""
import argparse
import csv
import json
import os
import sys
from collections import defaultdict

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_layout import layout_figure  # noqa: E402
from report_traction import traction_figure  # noqa: E402
from report_wheels import wheels_section  # noqa: E402

LOG_PLOT_POINTS = 4000  # min/max pairs per line in a log figure: extremes kept, size bounded
SEGMENT_COLORS = {"steady_rotation": "C0", "coast": "C1", "motor": "C2", "step": "C3"}


def save(fig, out, name, rect=None):
    """Lays fig out (inside rect), writes it to out/name at 110 dpi and closes it; returns name."""
    from omni4.outfile import OutError, OutFile
    fig.tight_layout(rect=rect)
    path = os.path.join(out, name)
    try:
        with OutFile(path, binary=True) as f:
            fig.savefig(f, dpi=110, format="png")
    except OSError as e:  # a write into it failed (the file is left as it was)
        raise OutError(path, e) from None
    plt.close(fig)
    return name


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def params_table(rows):
    table = defaultdict(dict)
    for r in rows:
        table[r["param"]][r["method"]] = (float(r["value"]), r["se"])
    return table


def fig_rotation(rows, params, out):
    if not rows:
        return None
    w = [float(r["omega_enc_rad_s"]) for r in rows]
    wc = [float(r["omega_cam_rad_s"]) for r in rows]
    T = [float(r["torque_Nm"]) for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(w, T, "o", label="encoders")
    ax.plot(wc, T, "x", label="camera")
    if "Bw" in params and "final" in params["Bw"]:
        Bw, Cw = params["Bw"]["final"][0], params["Cw"]["final"][0]
        xs = [0, max(w) * 1.05]
        ax.plot(xs, [Bw * x + Cw for x in xs], "-", label=f"T = {Bw:.4f} w + {Cw:.4f}")
    ax.set_xlabel("w [rad/s]")
    ax.set_ylabel("T [N m]")
    ax.set_title("Experiment 1: steady rotation (eq 16)")
    ax.grid(True)
    ax.legend()
    return save(fig, out, "exp1_torque.png")


def fig_coast(rows, out):
    names = []
    by_dir = defaultdict(lambda: defaultdict(list))
    for r in rows:
        by_dir[r["direction"]][r["segment"]].append(
            (float(r["t_s"]), float(r["measured"]), float(r["fitted"])))
    for d, segs in by_dir.items():
        fig, ax = plt.subplots(figsize=(6, 4))
        for seg, pts in segs.items():
            t = [p[0] for p in pts]
            ax.plot(t, [p[1] for p in pts], ".", ms=2, label=f"run {seg} measured")
            ax.plot(t, [p[2] for p in pts], "-", lw=1, label=f"run {seg} fit")
        unit = "rad/s" if d == "w" else "m/s"
        ax.set_xlabel("t since null traction [s]")
        ax.set_ylabel(f"{d} [{unit}]")
        ax.set_title(f"Experiment 2: coast-down along {d} (eqs 17-19)")
        ax.grid(True)
        ax.legend(fontsize=7)
        name = f"exp2_coast_{d}.png"
        save(fig, out, name)
        names.append(name)
    return names


def fig_motor(rows, params, out):
    if not rows:
        return None
    fig, ax = plt.subplots(figsize=(6, 4))
    for m in sorted({r["motor"] for r in rows}):
        pts = [r for r in rows if r["motor"] == m]
        x = [float(r["wm_rad_s"]) / float(r["i_A"]) for r in pts]
        y = [float(r["u_V"]) / float(r["i_A"]) for r in pts]
        ax.plot(x, y, "o", label=f"motor {m}")
    if "Kv" in params and "motor" in params["Kv"]:
        Kv, R = params["Kv"]["motor"][0], params["R"]["motor"][0]
        xs = sorted(float(r["wm_rad_s"]) / float(r["i_A"]) for r in rows)
        ax.plot([xs[0], xs[-1]], [Kv * xs[0] + R, Kv * xs[-1] + R], "-",
                label=f"u/i = {Kv:.4f} w/i + {R:.3f}")
    ax.set_xlabel("w_m / i [rad/(s A)]")
    ax.set_ylabel("u / i [ohm]")
    ax.set_title("Motor test (eq 22)")
    ax.grid(True)
    ax.legend(fontsize=8)
    return save(fig, out, "motor_test.png")


PARAMS = ["Kv", "R", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw"]


def fig_bootstrap(samples, summary, out):
    """Histogram of the bootstrap replicates per parameter, final value and 95 % interval."""
    if not samples:
        return None
    by_param = defaultdict(list)
    for r in samples:
        by_param[r["param"]].append(float(r["value"]))
    info = {r["param"]: r for r in summary}
    fig, axes = plt.subplots(3, 3, figsize=(9, 7))
    for ax, p in zip(axes.flat, PARAMS):
        x = by_param.get(p)
        if not x:
            ax.set_axis_off()
            continue
        ax.hist(x, bins=20, color="0.7")
        if p in info:
            ax.axvline(float(info[p]["final"]), color="C3", label="final")
            for edge in ("lo95", "hi95"):
                ax.axvline(float(info[p][edge]), color="C0", ls="--", lw=1)
        ax.set_title(p, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.locator_params(axis="x", nbins=4)
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
    fig.suptitle("Bootstrap over runs: replicates, final value (red), 95 % interval (dashed)",
                 fontsize=10)
    return save(fig, out, "bootstrap.png")


def fig_windows(rows, out):
    """One line per segment: the windows used (green) and rejected (red), from the mark."""
    if not rows:
        return None
    segs = sorted({int(r["segment"]) for r in rows})
    fig, ax = plt.subplots(figsize=(7, max(2.5, 0.18 * len(segs) + 1)))
    labels = {}
    for r in rows:
        y = segs.index(int(r["segment"]))
        labels[y] = f"{r['segment']} {r['kind']} {r['direction']}"
        t0, t1 = float(r["t0_s"]), float(r["t1_s"])
        used = r["used"] == "1"
        ax.plot([t0, max(t1, t0 + 0.02)], [y, y], "-", lw=5 if used else 3,
                color="C2" if used else "C3", solid_capstyle="butt")
    ax.set_yticks(list(labels))
    ax.set_yticklabels([labels[k] for k in labels], fontsize=6)
    ax.invert_yaxis()
    ax.set_xlabel("t since the segment's mark [s]")
    ax.set_title("Windows found in the data: used (green), rejected (red)")
    ax.grid(True, axis="x")
    return save(fig, out, "windows.png")


def fig_validation(rows, out):
    names = []
    by_dir = defaultdict(lambda: defaultdict(list))
    for r in rows:
        by_dir[r["direction"]][(r["segment"], r["level_V"])].append(r)
    labels = {"v": ("v", "m/s"), "vn": ("vn", "m/s"), "w": ("w", "rad/s")}
    for d, runs in by_dir.items():
        fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        for (seg, level), pts in runs.items():
            t = [float(p["t_s"]) for p in pts]
            meas = [float(p[d]) for p in pts]
            sim = [float(p[d + "_sim"]) for p in pts]
            axes[0].plot(t, meas, "-", lw=1, label=f"{float(level):.0f} V measured")
            axes[0].plot(t, sim, "--", lw=1, label=f"{float(level):.0f} V simulated")
            axes[1].plot(t, [a - b for a, b in zip(meas, sim)], "-", lw=1,
                         label=f"{float(level):.0f} V")
        name_, unit = labels.get(d, (d, ""))
        axes[0].set_ylabel(f"{name_} [{unit}]")
        axes[0].set_title(f"Validation: ramped steps along {d} (figs 6-7)")
        axes[0].grid(True)
        axes[0].legend(fontsize=7, ncol=2)
        axes[1].set_ylabel("measured - simulated")
        axes[1].set_xlabel("t [s]")
        axes[1].grid(True)
        name = f"validation_{d}.png"
        save(fig, out, name)
        names.append(name)
    return names


def envelope(t, y, bins=LOG_PLOT_POINTS):
    """Per bin of samples the min and max of each column of y, in time order: a line through
    them shows every extreme of a long series with 2 x bins points."""
    import numpy as np
    n = len(t)
    if n <= 2 * bins:
        return t, y
    edges = np.linspace(0, n, bins + 1).astype(int)
    lo = np.minimum.reduceat(y, edges[:-1], axis=0)
    hi = np.maximum.reduceat(y, edges[:-1], axis=0)
    tt = np.repeat(t[edges[:-1]], 2)
    yy = np.empty((2 * bins,) + y.shape[1:], y.dtype)
    yy[0::2], yy[1::2] = lo, hi
    return tt, yy


def fig_log(path, index, out):
    """The raw series of one event log; returns (figure name, summary lines)."""
    try:
        import omni4
    except ImportError as e:
        sys.exit(f"omni4_report: --log needs the omni4 Python package ({e}); "
                 "pip install ./python, or run with the project's .venv/bin/python")
    try:
        log = omni4.read_log(path)
    except (OSError, omni4.LogError) as e:
        sys.exit(f"omni4_report: {e}")
    m = log.motors
    if not len(m):
        return None, [f"{path}: no OMNI4_MOTORS samples", ""] + log.summary().splitlines(), None
    t0 = m.utime[0]
    t = (m.utime - t0) * 1e-6
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    series = [(m.wheel_speed, "wheel speed [rad/s]"), (m.current, "current [A]"),
              (m.voltage, "applied voltage [V]")]
    for ax, (y, label) in zip(axes, series):
        tt, yy = envelope(t, y)
        for j in range(4):
            ax.plot(tt, yy[:, j], "-", lw=0.6, label=f"wheel {j}")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.3)
    # Experiment segments: from a mark to the next mark (or the end of the log).
    e = log.experiment
    ends = list((e.utime[1:] - t0) * 1e-6) + [t[-1]]
    seen = set()
    for kind, direction, a, b in zip(e.kind, e.direction, (e.utime - t0) * 1e-6, ends):
        if kind == omni4.MARK_END:
            continue
        color = SEGMENT_COLORS.get(kind, "0.6")
        for ax in axes:
            ax.axvspan(a, b, color=color, alpha=0.12, lw=0,
                       label=kind if ax is axes[0] and kind not in seen else None)
        seen.add(kind)
        axes[0].text(a, 1.0, direction, transform=axes[0].get_xaxis_transform(), fontsize=6,
                     va="bottom")
    axes[-1].set_xlabel(f"t since the first OMNI4_MOTORS sample [s] ({len(m)} samples)")
    axes[0].set_title(f"Log {os.path.basename(path)}: raw series, experiment segments shaded",
                      pad=14)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, ncol=len(labels), loc="lower center")
    name = f"log_{index}_{os.path.basename(path).replace('.', '_')}.png"
    save(fig, out, name, rect=(0, 0.03, 1, 1))
    lines = [f"`{path}`: {t[-1]:.1f} s of OMNI4_MOTORS, {len(e)} experiment marks, "
             f"{len(log.pose)} poses, {len(log.cmd)} commands.", "", "```"]
    return name, lines + log.summary().splitlines() + ["```", ""], log


def wheel_odometry(m, d, r, start):
    """Eqs 3-5 (omni4.ros.core.forward_kinematics, on the columns) from the wheel speeds, the
    pose integrated at the mid-step heading from start (x, y, theta) -> (n, 3)."""
    from omni4.ros.core import forward_kinematics
    v, vn, w = forward_kinematics(m.wheel_speed.T, d, r)
    dt = np.diff(m.utime, prepend=m.utime[0]) * 1e-6
    th = start[2] + np.cumsum(w * dt)
    mid = th - 0.5 * w * dt
    x = start[0] + np.cumsum(dt * (np.cos(mid) * v - np.sin(mid) * vn))
    y = start[1] + np.cumsum(dt * (np.sin(mid) * v + np.cos(mid) * vn))
    return np.column_stack([x, y, th])


def path_error(ut, xy, truth):
    """|xy - truth| at the times ut, the truth interpolated [m]."""
    tx = np.interp(ut, truth.utime, truth.pose[:, 0])
    ty = np.interp(ut, truth.utime, truth.pose[:, 1])
    return np.hypot(xy[:, 0] - tx, xy[:, 1] - ty)


def fig_paths(log, index, name_of_log, out, d, r):
    """The paths of one log with a state estimate; returns (figure name, summary lines)."""
    import omni4
    st, cam, m = log.state, log.pose, log.motors
    truth = log.channels.get(omni4.CHANNEL_SIM_TRUTH)
    have_truth = truth is not None and len(truth) > 1
    start = truth.pose[0] if have_truth else st.pose[0]
    odo = wheel_odometry(m, d, r, start)
    cam_xy = np.column_stack([cam.x, cam.y]) if len(cam) else np.zeros((0, 2))
    series = [("estimate (OMNI4_STATE)", st.utime, st.pose, "C0"),
              ("camera (OMNI4_POSE)", cam.utime if len(cam) else np.zeros(0), cam_xy, "C1"),
              ("wheel odometry", m.utime, odo, "C2")]
    fig, axes = plt.subplots(1, 2 if have_truth else 1, figsize=(13 if have_truth else 7, 6),
                             squeeze=False)
    ax = axes[0][0]
    if have_truth:
        ax.plot(truth.pose[:, 0], truth.pose[:, 1], "k-", lw=1.2, label="true (OMNI4_SIM_TRUTH)")
    for label, _, xy, c in series:
        ax.plot(xy[:, 0], xy[:, 1], "." if "camera" in label else "-", color=c, ms=1.5,
                lw=0.8, label=label)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Paths, {name_of_log}")
    lines = []
    if have_truth:
        ax = axes[0][1]
        t0 = m.utime[0]
        for label, ut, xy, c in series:
            if not len(ut):
                continue
            err = path_error(ut, xy, truth)
            ax.semilogy((ut - t0) * 1e-6, np.maximum(err * 1e3, 1e-2),
                        "." if "camera" in label else "-", color=c, lw=0.6, ms=1.0, label=label)
            lines.append(f"- {label}: position RMS against the truth "
                         f"{1e3 * np.sqrt(np.mean(err ** 2)):.2f} mm, max {1e3 * err.max():.1f} mm")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("position error against the truth [mm]")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    name = f"paths_{index}_{name_of_log.replace('.', '_')}.png"
    save(fig, out, name)
    return name, (["Paths (estimate, camera, wheel odometry against the simulator's truth):", ""]
                  + lines + [""] if lines else [])


def identified_r(log, params_path):
    """Each motor's identified R_j [ohm] and where it came from: the log's first
    OMNI4_PARAM_CHANGED with source start (the [model] the controller started with), else the
    --params INI, else the log's first adapt_t when nothing was adapted yet; (None, why not)."""
    import omni4
    from omni4 import adapt
    for _, data in log.unknown.get(omni4.CHANNEL_PARAM_CHANGED, []):
        try:
            m = omni4.param_changed_t.decode(data)
        except ValueError:
            continue
        if m.source == "start":
            r = adapt.identified_r(dict(zip(m.keys, m.values)))
            if r is not None:
                return r, "the log's start notice (OMNI4_PARAM_CHANGED)"
    if params_path:
        from omni4.foxglove import model
        p = model.params_or_exit("omni4_report", params_path)
        return adapt.identified_r({k: repr(v) for k, v in p.items()}), f"--params {params_path}"
    a = log.channels[omni4.CHANNEL_ADAPT]
    if not a.flags[0] & omni4.adapt_t.FLAG_ADAPTED:
        return [float(x) for x in a.R[0]], "the log's first OMNI4_ADAPT (nothing adapted yet)"
    return None, "not known (no start notice, no --params, adapted from the first OMNI4_ADAPT)"


def fig_drift(log, index, name_of_log, out, params_path):
    """What the online estimation learned in one log with OMNI4_ADAPT: per motor the identified
    R_j, the last R_j in use and its change in %, the estimate's last value and the acceptances
    and reverts (flags); the figure of each R_j in use and its estimate over time. Returns
    (figure name, lines)."""
    import omni4
    from omni4 import adapt
    a = log.channels[omni4.CHANNEL_ADAPT]
    ident, source = identified_r(log, params_path)
    t = (a.utime - a.utime[0]) * 1e-6
    fig, ax = plt.subplots(figsize=(10, 5))
    for j in range(4):
        ax.plot(t, a.R[:, j], "-", color=f"C{j}", lw=1.2, label=f"R_{j} in use")
        ax.plot(t, a.R_estimate[:, j], "--", color=f"C{j}", lw=0.6, label=f"R_{j} estimate")
        if ident is not None:
            ax.axhline(ident[j], color=f"C{j}", lw=0.5, ls=":")
    ax.set_xlabel(f"t since the first OMNI4_ADAPT [s] ({len(a)} reports)")
    ax.set_ylabel("R [ohm] (dotted: identified)")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, ncol=4)
    ax.set_title(f"Motor resistances learned online, {name_of_log}")
    name = f"drift_{index}_{name_of_log.replace('.', '_')}.png"
    save(fig, out, name)
    last = a.R[-1]
    pct = adapt.percent(last, ident) if ident is not None else [None] * 4
    seen = int(np.bitwise_or.reduce(a.flags))
    accepted = int(np.count_nonzero(a.flags & omni4.adapt_t.FLAG_ACCEPTED))
    reverted = int(np.count_nonzero(a.flags & omni4.adapt_t.FLAG_REVERTED))
    lines = [f"Drift of `{name_of_log}` ({t[-1]:.1f} s of OMNI4_ADAPT; identified R_j from "
             f"{source}; {accepted} reports with an acceptance, {reverted} with a revert; "
             f"flags seen: {' '.join(adapt.flag_names(seen)) or 'none'}):", "",
             "| motor | identified R [ohm] | last R in use [ohm] | change [%] | "
             "last estimate [ohm] |", "|---|---|---|---|---|"]
    for j in range(4):
        idv = "unknown" if ident is None else f"{ident[j]:.4f}"
        pc = "unknown" if pct[j] is None else f"{pct[j]:+.2f}"
        lines.append(f"| {j} | {idv} | {last[j]:.4f} | {pc} | {a.R_estimate[-1][j]:.4f} |")
    return name, lines + [""]


def robot_geometry(params_path):
    """d and r [m] of the robot INI's [model] (all 14 keys, as omni4-ident writes it), or of
    Table III."""
    from omni4.foxglove import model
    p = model.params_or_exit("omni4_report", params_path)
    return p["d"], p["r"]


def draw_figures(a):
    """Every figure of the CSV folder (and of the logs); returns (figure names, the logs' lines,
    the parameter table, the windows and the bootstrap rows)."""
    params = params_table(read_csv(os.path.join(a.csv_dir, "params.csv")))
    figs = []
    figs.append(fig_motor(read_csv(os.path.join(a.csv_dir, "motor_points.csv")), params, a.out_dir))
    figs.append(fig_rotation(read_csv(os.path.join(a.csv_dir, "rotation_points.csv")), params,
                             a.out_dir))
    figs += fig_coast(read_csv(os.path.join(a.csv_dir, "coast_curves.csv")), a.out_dir)
    figs += fig_validation(read_csv(os.path.join(a.csv_dir, "validation.csv")), a.out_dir)
    boot = read_csv(os.path.join(a.csv_dir, "bootstrap.csv"))
    figs.append(fig_bootstrap(read_csv(os.path.join(a.csv_dir, "bootstrap_samples.csv")), boot,
                              a.out_dir))
    windows = read_csv(os.path.join(a.csv_dir, "windows.csv"))
    figs.append(fig_windows(windows, a.out_dir))
    log_lines = []
    for k, path in enumerate(a.log):
        name, lines, log = fig_log(path, k, a.out_dir)
        figs.append(name)
        log_lines += lines
        if log is not None and len(log.state) and len(log.motors):
            d, r = robot_geometry(a.params)
            name, lines = fig_paths(log, k, os.path.basename(path), a.out_dir, d, r)
            figs.append(name)
            log_lines += lines
        if log is not None and len(log.channels[omni4_channel_adapt()]):
            name, lines = fig_drift(log, k, os.path.basename(path), a.out_dir, a.params)
            figs.append(name)
            log_lines += lines
    return [f for f in figs if f], log_lines, params, windows, boot


def params_section(params, agreement):
    """The methods' estimates of every parameter, with the methods' agreement."""
    methods = ["motor", "exp1", "exp2", "exp3_ls", "exp3_iv", "final", "true"]
    present = [m for m in methods if any(m in params[p] for p in params)]
    lines = ["| param | " + " | ".join(present) + " | methods |",
             "|---" * (len(present) + 2) + "|"]
    for p in PARAMS + (["M"] if "M" in params else []):  # M: a current drive's fit
        cells = []
        for m in present:
            v = params.get(p, {}).get(m)
            cells.append("" if v is None else f"{v[0]:.4g}")
        ag = agreement.get(p)
        note = ""
        if "drive" in params.get(p, {}):  # identify --drive current: not fitted
            note = "the drive's (the robot file's, not fitted)"
        elif ag and int(ag["methods"]) >= 2:
            note = ("agree" if ag["agree"] == "1" else "**DISAGREE**") + \
                f" (p = {float(ag['p']):.2g})"
            if ag["agree"] != "1":
                note += f", {ag['rule']}"
        lines.append(f"| {p} | " + " | ".join(cells) + f" | {note} |")
    return lines + ["", "Final: each method's SE raised to at least 0.5 % of its value; if the "
                    "methods agree (chi-square p >= 0.01) their inverse-variance weighted mean, "
                    "otherwise the better-determined one (smallest SE), its SE scaled by "
                    "sqrt(chi2 / dof).", ""]


def windows_section(windows):
    """How many windows of each kind were used, and every rejected one with its reason."""
    used = defaultdict(int)
    rejected = []
    for r in windows:
        if r["used"] == "1":
            used[f"{r['what']} ({r['kind']})"] += 1
        else:
            rejected.append(r)
    lines = ["## Windows found in the data", "",
             ", ".join(f"{n} {k}" for k, n in sorted(used.items())) +
             f"; {len(rejected)} rejected.", ""]
    if rejected:
        lines += ["| segment | kind | dir | what | from [s] | to [s] | reason |",
                  "|---|---|---|---|---|---|---|"]
        for r in rejected:
            lines.append(f"| {r['segment']} | {r['kind']} | {r['direction']} | {r['what']} | "
                         f"{float(r['t0_s']):.2f} | {float(r['t1_s']):.2f} | {r['reason']} |")
        lines.append("")
    return lines


def bootstrap_section(boot):
    """The final values' analytic and bootstrap standard errors."""
    lines = ["## Uncertainty of the final values", "",
             "Analytic: from the regression residuals. Bootstrap: whole runs resampled "
             "within each experiment kind and direction (the motor test's also within the "
             "motors they drive).", "",
             "| param | final | SE analytic | SE bootstrap | 95 % interval (bootstrap) |",
             "|---|---|---|---|---|"]
    for r in boot:
        lines.append(f"| {r['param']} | {float(r['final']):.5g} | "
                     f"{float(r['se_analytic']):.2g} | {float(r['se_bootstrap']):.2g} | "
                     f"[{float(r['lo95']):.5g}, {float(r['hi95']):.5g}] |")
    return lines + [""]


def validation_section(path):
    """The validation JSON's errors per axis beside the paper's Table IV."""
    with open(path) as f:
        val = json.load(f)
    paper = {"v": (0.061, 0.008, 0.024), "vn": (0.068, -0.009, 0.026),
             "w": (2.504, -0.452, 0.732)}
    lines = ["## Validation (eqs 28-30) beside the paper's Table IV (final)", "",
             "| vel [m/s, m/s, rad/s] | e_max | mean | sigma | paper e_max | paper mean | "
             "paper sigma |",
             "|---|---|---|---|---|---|---|"]
    for k in ["v", "vn", "w"]:
        e = val[k]
        p = paper[k]
        if e.get("e_max") is None:  # no step run along this axis
            lines.append(f"| {k} | no data | | | {p[0]} | {p[1]} | {p[2]} |")
            continue
        lines.append(f"| {k} | {e['e_max']:.4f} | {e['e_mean']:.4f} | {e['sigma']:.4f} | "
                     f"{p[0]} | {p[1]} | {p[2]} |")
    return lines + [""]


def omni4_channel_adapt():
    import omni4
    return omni4.CHANNEL_ADAPT


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--json", help="validation JSON of omni4-ident validate")
    ap.add_argument("--log", nargs="+", default=[], metavar="LOG",
                    help="event logs whose raw series to draw (needs the omni4 package)")
    ap.add_argument("--params", metavar="INI",
                    help="robot INI whose [model] d and r the wheel odometry of the paths "
                         "figure uses (default: Table III)")
    a = ap.parse_args()
    if not os.path.isdir(a.csv_dir):
        sys.exit(f"omni4_report: {a.csv_dir}: no such folder")
    try:
        from omni4.outfile import OutError
    except ImportError as e:
        sys.exit(f"omni4_report: needs the omni4 package ({e}): pip install ./python")
    if os.path.exists(a.out_dir) and not os.path.isdir(a.out_dir):
        sys.exit(f"omni4_report: {a.out_dir}: exists and is not a folder (OUT_DIR is a folder; "
                 "nothing replaced)")
    try:
        os.makedirs(a.out_dir, exist_ok=True)
    except OSError as e:
        sys.exit(f"omni4_report: {a.out_dir}: {e.strerror} (OUT_DIR is a folder; nothing replaced)")
    try:
        write_report(a)
    except OutError as e:
        sys.exit(f"omni4_report: {e}")


def write_report(a):
    from omni4.outfile import OutFile
    figs, log_lines, params, windows, boot = draw_figures(a)
    agreement = {r["param"]: r for r in read_csv(os.path.join(a.csv_dir, "agreement.csv"))}

    lines = ["# omni4 identification report", ""]
    if params:
        lines += params_section(params, agreement)
    layout_fig, layout_lines = layout_figure(plt, save, a.csv_dir, a.out_dir)
    lines += layout_lines
    figs += [layout_fig] if layout_fig else []
    lines += wheels_section(a.csv_dir)
    traction_fig, traction_lines = traction_figure(plt, save, a.csv_dir, a.out_dir)
    lines += traction_lines
    figs += [traction_fig] if traction_fig else []
    if windows:
        lines += windows_section(windows)
    if boot:
        lines += bootstrap_section(boot)
    if a.json and os.path.exists(a.json):
        try:
            lines += validation_section(a.json)
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.exit(f"omni4_report: {a.json}: {getattr(e, 'strerror', None) or e} (--json is "
                     "omni4-ident validate's JSON)")
    if log_lines:
        lines += ["## Logs", ""] + log_lines
    lines += ["## Figures", ""]
    for f in figs:
        lines += [f"![{f}]({f})", ""]
    with OutFile(os.path.join(a.out_dir, "report.md")) as f:
        f.write("\n".join(lines))
    print(f"omni4_report: wrote {len(figs)} figures and report.md to {a.out_dir}")


if __name__ == "__main__":
    main()
