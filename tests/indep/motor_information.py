#!/usr/bin/env python3
"""How much the motor tests of kept logs say about each motor's R_j (information, not bias).

Reads a test_ident_indep.py --keep folder of per-wheel robots (robotK_truth.ini with R_j, and
robotK_LAYOUT_encoder_csv/motor_points.csv from identify --csv), refits each motor's eq 22
(i = u / R_j - (Kv_j / R_j) w_m, least squares, no intercept) and takes its standard error from
the residual variance pooled over the robot's four motors (they share the current noise; each
motor alone has only 6-7 degrees of freedom). If the errors against the truth are that noise,
their z = error / SE are standard normal: the spread is 1 and the largest |z| of N motors is
where N normal draws put it (printed beside it, from a simulation of N normals).

example:
  .venv/bin/python tests/indep/test_ident_indep.py build/bin build/lcmtypes/gen/python \\
      --layouts sensors --wheel-spread 5,5,1 --keep /tmp/w
  .venv/bin/python tests/indep/motor_information.py /tmp/w/sensors
"""
import argparse
import csv
import glob
import os
import re
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from logio import read_ini  # noqa: E402


def motor_fits(points):
    """Per motor with points: (motor, 1/R, (X^T X)^-1, residual sum of squares, dof)."""
    out = []
    for j in range(4):
        P = np.array([(float(p["u_V"]), float(p["i_A"]), float(p["wm_rad_s"]))
                      for p in points if int(p["motor"]) == j])
        if len(P) < 3:
            continue
        X, y = P[:, [0, 2]], P[:, 1]
        th = np.linalg.lstsq(X, y, rcond=None)[0]
        r = y - X @ th
        out.append((j, th[0], np.linalg.inv(X.T @ X), float(r @ r), len(y) - 2))
    return out


def robot_errors(csv_dir, truth):
    """(error %, SE %, z) of each motor's R_j with the robot's pooled residual variance."""
    with open(os.path.join(csv_dir, "motor_points.csv")) as f:
        fits = motor_fits(list(csv.DictReader(f)))
    dof = sum(f[4] for f in fits)
    if not fits or dof < 1 or f"R_{fits[0][0]}" not in truth:
        return []
    s2 = sum(f[3] for f in fits) / dof
    rows = []
    for j, cu, xtxi, _, _ in fits:
        R, se, Rt = 1 / cu, np.sqrt(s2 * xtxi[0, 0]) / cu ** 2, truth[f"R_{j}"]
        rows.append((100 * (R / Rt - 1), 100 * se / Rt, (R - Rt) / se))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", help="a --keep folder's layout folder (e.g. /tmp/w/sensors)")
    a = ap.parse_args(argv)
    rows = []
    for d in sorted(glob.glob(os.path.join(a.folder, "robot*_encoder_csv"))):
        k = re.match(r"robot(\d+)_", os.path.basename(d)).group(1)
        truth = read_ini(os.path.join(a.folder, f"robot{k}_truth.ini"))
        rows += robot_errors(d, truth)
    if not rows:
        print(f"motor_information: no per-wheel robots with motor points under {a.folder}",
              file=sys.stderr)
        return 2
    err, se, z = (np.array(c) for c in zip(*rows))
    i = int(np.argmax(np.abs(err)))
    mx = np.abs(np.random.default_rng(0).standard_normal((20000, len(z)))).max(axis=1)
    print(f"{len(z)} motors: R_j error rms {np.sqrt(np.mean(err ** 2)):.2f} %, worst "
          f"{err[i]:+.2f} % ({z[i]:+.1f} SE); SE median {np.median(se):.2f} %, "
          f"{se.min():.2f}-{se.max():.2f} %")
    print(f"z spread {z.std():.2f}, max |z| {np.abs(z).max():.1f}; max |z| of {len(z)} normal "
          f"draws: median {np.median(mx):.2f}, 95th percentile {np.quantile(mx, 0.95):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
