#!/usr/bin/env python3
"""Identification through a current drive: J, B, C and M from the measured currents.

usage: ident_current.py BIN_DIR [--keep DIR]

A simulated robot behind a current drive ([sim] current_drive = true: the controller's
voltages become currents with the model's R and Kv, an ideal current loop holds the windings at
them) whose body is not Table III's (M, J, B, C below) and whose motors' resistance is 20 %
above the model's (motor_R_error_j): omni4-sim --experiments runs the paper's experiments, then
  1. omni4-ident identify --drive current recovers the simulated robot's M, J, Bv, Bvn, Bw, Cv,
     Cvn, Cw within TOL (each 2-3x the worst of seeds 1, 2, 4, 5, 6 on this robot, never above
     the 1 % the requirement asks); R and Kv in the file are the robot file's, said to be the
     drive's;
  2. the voltage form (no --drive) on the same log is not claimed: its R is the model's own
     (the controller's voltages are the model's), not the motors' 20 % higher one;
  3. --drive with another word: one line, status 2.
Exit status 0 when every check passes, 1 otherwise.
"""
import argparse
import csv
import os
import subprocess
import sys

from script_checks import check, failures, run, read_ini, workdir, write  # (this script's folder)

# The simulated robot: Table III's geometry and motors, its own body.
MODEL = {"d": 0.089, "r": 0.0325, "l": 5, "Kv": 0.0259, "Kt": 0.0259, "R": 4.3111, "M": 3.1,
         "J": 0.031, "Bv": 0.62, "Bvn": 0.81, "Bw": 0.019, "Cv": 2.3, "Cvn": 2.6, "Cw": 0.17}
R_ERROR = 0.2  # the motors' resistance over the model's
# Relative bounds; worst of the 5 seeds [%]: M 0.090, J 0.196, Bv 0.045, Bvn 0.030, Bw 0.468,
# Cv 0.054, Cvn 0.050, Cw 0.471 (Bw and Cw: 2.1x to the 1 % cap).
TOL = {"M": 0.0025, "J": 0.005, "Bv": 0.0015, "Bvn": 0.001, "Bw": 0.01, "Cv": 0.0015,
       "Cvn": 0.0015, "Cw": 0.01}
SEED = 1




def robot_ini():
    model = "".join(f"{k} = {v}\n" for k, v in MODEL.items())
    errors = "".join(f"motor_R_error_{j} = {R_ERROR}\n" for j in range(4))
    return f"[model]\n{model}[sim]\ncurrent_drive = true\nseed = {SEED}\n{errors}"


def identify(bin_dir, d, out, extra):
    return run([os.path.join(bin_dir, "omni4-ident"), "identify", "--robot", "base.ini",
                "--out", out, *extra, "cur.lcmlog"], d)


def final_mass(path):
    """M's final value in identify's params.csv (None: not identified)."""
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["param"] == "M" and r["method"] == "final"]
    return float(rows[0]["value"]) if rows else None


def check_current_form(bin_dir, d):
    text = identify(bin_dir, d, "cur.params.ini", ["--drive", "current", "--csv", "csv"])
    got = read_ini(os.path.join(d, "cur.params.ini"), "model")
    # M identified, not the robot file's (which gives the true M): the fit's, and the file's.
    m = final_mass(os.path.join(d, "csv", "params.csv"))
    check(m is not None and abs(m / got["M"] - 1) < 1e-5, f"current form: M identified ({m}), in the file")
    for p, tol in TOL.items():
        err = got[p] / MODEL[p] - 1
        check(abs(err) <= tol, f"current form: {p} {got[p]:.6g} against the robot's "
              f"{MODEL[p]:g}: {100 * err:+.3f} % (bound {100 * tol:g} %)")
    for p in ("R", "Kv", "Kt"):
        check(got[p] == MODEL[p], f"current form: {p} = {got[p]:g} is the robot file's")
    check("R = 4.3111 ohm and Kv = 0.0259 V s/rad are the drive's" in text,
          "current form: the report says R and Kv are the drive's")


def check_voltage_form(bin_dir, d):
    identify(bin_dir, d, "volt.params.ini", [])
    R = read_ini(os.path.join(d, "volt.params.ini"), "model")["R"]
    true_R = MODEL["R"] * (1 + R_ERROR)
    print(f"voltage form on the current drive's log: R {R:.5g} ohm (the model's "
          f"{MODEL['R']:g}: {100 * (R / MODEL['R'] - 1):+.2f} %; the motors' {true_R:.5g}: "
          f"{100 * (R / true_R - 1):+.2f} %)")
    check(abs(R / MODEL["R"] - 1) < 0.01 and abs(R / true_R - 1) > 0.1,
          "voltage form: R is the model's own, not the motors' (circular: not claimed)")


def check_bad_drive(bin_dir, d):
    p = subprocess.run([os.path.join(bin_dir, "omni4-ident"), "identify", "--robot", "base.ini",
                        "--out", "x.ini", "--drive", "torque", "cur.lcmlog"], cwd=d,
                       capture_output=True, text=True, timeout=30)
    lines = p.stderr.strip().splitlines()
    check(p.returncode == 2 and len(lines) == 1 and "--drive" in lines[0],
          f"--drive torque: one line, status 2 (got {p.returncode}: {p.stderr.strip()})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin_dir")
    ap.add_argument("--keep", help="work in this folder and keep it")
    a = ap.parse_args()
    bin_dir = os.path.abspath(a.bin_dir)
    with workdir(a.keep) as d:
        write(d, "robot.ini", robot_ini())
        write(d, "base.ini", "[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 3.1\n")
        run([os.path.join(bin_dir, "omni4-sim"), "--params", "robot.ini", "--experiments",
             "--speed", "max", "-q", "--out", "cur.lcmlog"], d)
        check_current_form(bin_dir, d)
        check_voltage_form(bin_dir, d)
        check_bad_drive(bin_dir, d)
    print(f"ident_current: {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
