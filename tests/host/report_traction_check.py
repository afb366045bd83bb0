#!/usr/bin/env python3
"""The report's traction section (host-tools/plots/report_traction.py) against the log.

usage: report_traction_check.py BIN_DIR [--keep DIR]

omni4-sim runs the traction experiment on a floor of hidden mu 0.4 (with the plant's truth in
the log), omni4-ident identifies it (--csv), omni4_report.py writes the report. The report's
traction table is read back from report.md and compared with what this script counts in the
log itself (omni4.read_log: the experiment marks and the simulator's truth), no CSV read:
  - runs per direction = the log's "traction" segments along it;
  - "held to" and "slips at" are two consecutive levels of the direction's ladder in the log,
    and "slips at" within 20 % of the first level at which the truth says a wheel slipped
    (the runaway test and the truth's limit differ by a level or two: 5 % each);
  - mu within 10 % of the floor's 0.4 (the simulator's hidden coefficient);
  - along v, vn and w the largest held acceleration within 3 of its SEs and 5 % of the
    truth's steepest 25-tick slope in the highest run the truth says held (the diagonal's held
    run is the highest the runaway test let pass, which the truth may call slipping);
  - the figure is written (a PNG of some size) and report.md shows it.
Bad input: traction.csv or traction_runs.csv with a value that is not a number or a column
missing ends the report with exit status 1 and one line on stderr naming the file, the line
and the column (no traceback).
Prints one line per check; exit status 0 when all pass, 1 otherwise.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

import omni4
from script_checks import check, failures  # (this script's folder)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
REPORT = os.path.join(ROOT, "host-tools", "plots", "omni4_report.py")
FLOOR_MU = 0.4
BASE = ("[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\nKv = 0.0259\nKt = 0.0259\n"
        "R = 4.3111\nJ = 0.0228\nBv = 0.4978\nBvn = 0.6763\nBw = 0.0141\nCv = 1.8738\n"
        "Cvn = 2.2198\nCw = 0.1385\n")  # the paper's Table III, the simulated robot
TIMEOUT_S = 120
SLOPE_N = 25

def run(cmd, cwd):
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT_S)


def must(cmd, cwd):
    p = run(cmd, cwd)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()[-400:]}")
    return p.stdout


def steepest(t, y):
    """The steepest SLOPE_N-sample least-squares slope of y(t), in magnitude."""
    best = 0.0
    for k in range(len(t) - SLOPE_N + 1):
        tt = t[k:k + SLOPE_N] - t[k]
        best = max(best, abs(np.polyfit(tt, y[k:k + SLOPE_N], 1)[0]))
    return best


def along(direction, vel):
    return {"v": vel[:, 0], "vn": vel[:, 1], "w": vel[:, 2],
            "diag": (vel[:, 0] + vel[:, 1]) / np.sqrt(2.0)}[direction]


def count_log(path):
    """Per direction: its levels in order, the first level the truth slips at, and the truth's
    steepest slope in the highest level before it."""
    log = omni4.read_log(path)
    ex, tr = log.experiment, log.channels[omni4.CHANNEL_SIM_TRUTH]
    out = {}
    for i, kind in enumerate(ex.kind):
        if kind != "traction":
            continue
        d = out.setdefault(ex.direction[i], {"levels": [], "slip": None, "acc": None})
        end = next(j for j in range(i + 1, len(ex.kind)) if ex.kind[j] == "end")
        d["levels"].append(float(ex.level[i]))
        m = (tr.utime >= ex.utime[i]) & (tr.utime < ex.utime[end])
        if d["slip"] is None and np.any(tr.flags[m] & 0x0f):
            d["slip"] = float(ex.level[i])
        elif d["slip"] is None:
            d["acc"] = steepest(tr.utime[m] * 1e-6, along(ex.direction[i], tr.vel[m]))
    return out


def report_table(md):
    """The traction table of report.md: direction -> (runs, held, slips, mu, acc, acc_se)."""
    rows = {}
    num = r"([0-9.]+)"
    pat = re.compile(rf"\| (\w+) \| (\d+) \| {num} \| {num} \| (?:>= )?{num} ± {num} \| "
                     rf"{num} ± {num} ")
    for line in md.splitlines():
        m = pat.match(line)
        if m:
            g = m.groups()
            rows[g[0]] = (int(g[1]), float(g[2]), float(g[3]), float(g[4]), float(g[6]),
                          float(g[7]))
    return rows


def check_direction(name, row, log):
    runs, held, slips, mu, acc, acc_se = row
    levels = log["levels"]
    check(runs == len(levels), f"{name}: runs {runs}, the log's traction segments {len(levels)}")
    pair = any(abs(a - held) < 0.006 and abs(b - slips) < 0.006
               for a, b in zip(levels, levels[1:]))
    check(pair, f"{name}: held to {held} V and slips at {slips} V are consecutive levels")
    truth = log["slip"]
    check(truth is not None and abs(slips / truth - 1) <= 0.2,
          f"{name}: slips at {slips} V, the truth's first slip at {truth} V")
    check(abs(mu / FLOOR_MU - 1) <= 0.1, f"{name}: mu {mu} against the floor's {FLOOR_MU}")
    if name != "diag":
        t = log["acc"]
        check(t is not None and abs(acc - t) <= 3 * acc_se + 0.05 * t,
              f"{name}: largest held acceleration {acc} ± {acc_se}, the truth's {t:.4g}")


def spoilt(text, col, value):
    """The CSV text with column col of its second data row set to value (None: the column
    dropped from every row)."""
    lines = text.splitlines()
    k = lines[0].split(",").index(col)
    if value is None:
        return "\n".join(",".join(c for n, c in enumerate(row.split(",")) if n != k)
                         for row in lines) + "\n"
    cells = lines[2].split(",")
    cells[k] = value
    return "\n".join(lines[:2] + [",".join(cells)] + lines[3:]) + "\n"


def check_bad_input(d, csv_dir):
    """A bad value and a missing column: exit 1, one line on stderr, no report."""
    cases = (("traction.csv", "mu", "abc", "a value that is not a number"),
             ("traction.csv", "mu", None, "a column missing"),
             ("traction_runs.csv", "slipped", "2", "a flag that is not 0 or 1"),
             ("traction_runs.csv", "acc", "nan", "a value that is not finite"))
    for name, col, value, what in cases:
        path = os.path.join(csv_dir, name)
        good = open(path).read()
        with open(path, "w") as f:
            f.write(spoilt(good, col, value))
        p = run([sys.executable, REPORT, csv_dir, os.path.join(d, "bad")], d)
        with open(path, "w") as f:
            f.write(good)
        err = p.stderr.strip().splitlines()
        check(p.returncode == 1 and len(err) == 1 and name in err[0] and f"'{col}'" in err[0]
              and "Traceback" not in p.stderr, f"bad {name} ({what}): exit {p.returncode}, "
              f"stderr {err}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin_dir")
    ap.add_argument("--keep", help="work in this folder and keep it")
    a = ap.parse_args()
    b = os.path.abspath(a.bin_dir)
    with tempfile.TemporaryDirectory() as tmp:
        d = os.path.abspath(a.keep) if a.keep else tmp
        os.makedirs(os.path.join(d, "csv"), exist_ok=True)
        with open(os.path.join(d, "floor.ini"), "w") as f:
            f.write(f"[sim]\ntraction_mu = {FLOOR_MU}\nseed = 3\n")
        with open(os.path.join(d, "robot.ini"), "w") as f:
            f.write(BASE)
        must([os.path.join(b, "omni4-sim"), "--params", "floor.ini", "--only", "traction",
              "--speed", "max", "-q", "--out", "traction.lcmlog"], d)
        must([os.path.join(b, "omni4-ident"), "identify", "--robot", "robot.ini", "--out",
              "params.ini", "--csv", "csv", "traction.lcmlog"], d)
        must([sys.executable, REPORT, "csv", "report"], d)
        md = open(os.path.join(d, "report", "report.md")).read()
        png = os.path.join(d, "report", "traction.png")
        check(os.path.exists(png) and os.path.getsize(png) > 20000 and
              open(png, "rb").read(8) == b"\x89PNG\r\n\x1a\n", "traction.png written")
        check("![traction.png](traction.png)" in md, "report.md shows the figure")
        table, log = report_table(md), count_log(os.path.join(d, "traction.lcmlog"))
        check(sorted(table) == sorted(log) == ["diag", "v", "vn", "w"],
              f"directions in the report {sorted(table)}, in the log {sorted(log)}")
        for name in sorted(set(table) & set(log)):
            check_direction(name, table[name], log[name])
        check_bad_input(d, os.path.join(d, "csv"))
    print(f"report_traction: {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
