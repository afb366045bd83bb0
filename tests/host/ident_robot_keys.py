#!/usr/bin/env python3
"""omni4-ident identify keeps the robot file's per-wheel [model] keys in its PARAMS file.

usage: ident_robot_keys.py BIN_DIR [--keep DIR]

A robot file with per-wheel keys (docs/configuration.md "Per-wheel drives": r_1, Kv_2, Kt_2,
R_0) and:
  1. a log of the traction experiment only (omni4-sim --only traction): nothing of [model] is
     identified, so the PARAMS file holds every key of the robot file's [model] with its value
     (the wheel keys too), marked as taken from the robot file;
  2. a log of the paper's experiments (omni4-sim --experiments, a uniform robot): the wheels
     are identified (the motor test per motor, the radii from the wheels' consistency) and do
     not differ, so each wheel key of the robot file is written with the identified value,
     the scalar in force (R_0 = R, Kv_2 = Kt_2 = Kv, r_1 = r), marked as identified, with the
     robot file's value named.
Exit status 0 when every check passes, 1 otherwise.
"""
import argparse
import configparser
import os
import sys
import tempfile

from script_checks import check, failures, run  # (this script's folder)

WHEEL_KEYS = {"R_0": 4.4, "Kv_2": 0.026, "Kt_2": 0.026, "r_1": 0.0326}
TABLE3 = ("[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\nKv = 0.0259\nKt = 0.0259\n"
          "R = 4.3111\nJ = 0.0228\nBv = 0.4978\nBvn = 0.6763\nBw = 0.0141\nCv = 1.8738\n"
          "Cvn = 2.2198\nCw = 0.1385\n")
MEASURED = "[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\n"

def model_of(path):
    """[model] as {key: (value, comment)}."""
    keys = {}
    section = None
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith("["):
                section = line
                continue
            if section != "[model]" or not line or line.startswith(";"):
                continue
            key, rest = line.split("=", 1)
            value, _, comment = rest.partition(";")
            keys[key.strip()] = (float(value), comment.strip())
    return keys


def robot_file(d, name, text):
    with open(os.path.join(d, name), "w") as f:
        f.write(text + "".join(f"{k} = {v}\n" for k, v in WHEEL_KEYS.items()))
    return name


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin_dir")
    ap.add_argument("--keep", help="work in this folder and keep it")
    a = ap.parse_args()
    sim = os.path.join(os.path.abspath(a.bin_dir), "omni4-sim")
    ident = os.path.join(os.path.abspath(a.bin_dir), "omni4-ident")
    with tempfile.TemporaryDirectory() as tmp:
        d = os.path.abspath(a.keep) if a.keep else tmp
        os.makedirs(d, exist_ok=True)
        with open(os.path.join(d, "sim.ini"), "w") as f:
            f.write("[sim]\ntraction_mu = 0.5\nseed = 1\n")

        # 1. traction only: [model] from the robot file, all of it
        run([sim, "--params", "sim.ini", "--only", "traction", "--speed", "max", "-q", "--out",
             "traction.lcmlog"], d)
        base = robot_file(d, "robot.ini", TABLE3)
        run([ident, "identify", "--robot", base, "--out", "traction.params.ini",
             "traction.lcmlog"], d)
        got = model_of(os.path.join(d, "traction.params.ini"))
        given = configparser.ConfigParser()
        given.optionxform = str
        given.read(os.path.join(d, base))
        for key, value in given["model"].items():
            v, comment = got.get(key, (None, ""))
            check(v is not None and abs(v - float(value)) <= 1e-12 * abs(float(value)),
                  f"traction only: {key} = {value} kept (got {v})")
            if key in WHEEL_KEYS:
                check("from the robot file" in comment,
                      f"traction only: {key} marked as from the robot file ({comment!r})")

        # 2. the paper's experiments: the wheels identified, the wheel keys with their values
        run([sim, "--params", "sim.ini", "--experiments", "--speed", "max", "-q", "--out",
             "experiments.lcmlog"], d)
        base = robot_file(d, "measured.ini", MEASURED)
        run([ident, "identify", "--robot", base, "--out", "experiments.params.ini",
             "experiments.lcmlog"], d)
        got = model_of(os.path.join(d, "experiments.params.ini"))
        scalar = {"R_0": "R", "Kv_2": "Kv", "Kt_2": "Kt", "r_1": "r"}
        for key, given_value in WHEEL_KEYS.items():
            v, comment = got.get(key, (None, ""))
            s = got.get(scalar[key], (None, ""))[0]
            check(v is not None and s is not None and v == s,
                  f"experiments: {key} = {v}, the identified {scalar[key]} = {s} (uniform "
                  "wheels)")
            check("identified" in comment and f"{given_value:g}" in comment,
                  f"experiments: {key} marked identified, the robot file's {given_value:g} "
                  f"named ({comment!r})")
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
