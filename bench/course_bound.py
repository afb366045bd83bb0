#!/usr/bin/env python3
"""Arrival on the course against the numerically computed time-optimal bound (docs/goal.md).

For each single-pose goal of course_bench's run (its --times CSV: start, goal, each peer's
arrival), the direct method of bench/traj_optimal.py (imported, unchanged) computes the
shortest time from rest to rest for the robot INI's model and limits: each drive's own r, Kv,
Kt, R ([model] r_j ...; a drive without them takes the scalar), the supply less the feedback's
margin ([goal] margin_v), the floor's traction ([limits] traction_mu, 0: [goal] floor_mu; less
[limits] traction_margin; com_height's load transfer), the motor speed limit ([goal]
motor_speed_max); a key the INI leaves out takes the key table's default (omni4-config-keys
--json). Prints one line per goal, the arrival
of the goal mode and of the fixed-limits peer over the bound, and the worst ratio.

    python bench/course_bound.py build/bench/course_times.csv bench/course.ini \
        --traj-plan build/bin/traj_plan --config-keys build/bin/omni4-config-keys
"""
import argparse
import configparser
import csv
import json
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import traj_optimal as topt  # noqa: E402

def key_defaults(tool):
    """{(section, key): default} of the key table (omni4-config-keys --json)."""
    out = subprocess.run([tool, "--json"], check=True, capture_output=True, text=True,
                         timeout=30).stdout
    return {(k["section"], k["key"]): k["default"] for k in map(json.loads, out.splitlines())}


def robot(path, defaults):
    """The drives (b, e, rim_max per wheel) and the limits of the robot INI."""
    ini = configparser.ConfigParser(inline_comment_prefixes=(";", "#"))
    ini.optionxform = str
    ini.read_string("[top]\n" + open(path, encoding="utf-8").read())
    model = ini["model"] if ini.has_section("model") else {}
    key = lambda sec, k: float(ini[sec][k] if ini.has_section(sec) and k in ini[sec]
                               else defaults[(sec, k)])
    get = lambda sec, k, d: float(sec.get(k, d)) if sec else d
    scal = dict(r=topt.RW, Kv=topt.KV, Kt=topt.KT, R=topt.R)
    w = {q: np.array([get(model, f"{q}_{j}", get(model, q, scal[q])) for j in range(4)])
         for q in scal}
    mu = key("limits", "traction_mu")
    mu = mu if mu > 0 else key("goal", "floor_mu")
    supply, motor_max = key("limits", "supply_v"), key("goal", "motor_speed_max")
    b = topt.L * w["Kt"] / (w["R"] * w["r"])
    e = topt.L ** 2 * w["Kt"] * w["Kv"] / (w["R"] * w["r"] ** 2)
    return b, e, motor_max * w["r"] / topt.L, dict(
        supply=supply, margin=min(key("goal", "margin_v"), 0.25 * supply), mu=mu,
        traction_margin=key("limits", "traction_margin"), motor_max=motor_max,
        com_height=key("limits", "com_height"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("times", help="course_bench --times CSV")
    ap.add_argument("ini", help="the robot INI course_bench ran with")
    ap.add_argument("--nodes", type=int, default=20, help="collocation intervals")
    ap.add_argument("--restarts", type=int, default=2,
                    help="solves resumed after the iteration limit (default 2)")
    ap.add_argument("--traj-plan", help="the planner's CLI (build/bin/traj_plan): its "
                    "reference warm-starts the solver (the optimum is the solver's)")
    ap.add_argument("--config-keys", default="build/bin/omni4-config-keys",
                    help="omni4-config-keys: the defaults of the keys the INI leaves out")
    ap.add_argument("--share", choices=("free", "feedforward"), default="free",
                    help="the wheel forces: free (the robot's bound) or shared as the "
                    "feedforward shares them (this controller's bound)")
    ap.add_argument("--plans", action="store_true",
                    help="also the planner's own plan from rest (its duration, no settling) "
                    "against the bound (needs --traj-plan)")
    args = ap.parse_args()
    topt.SHARE = args.share
    b, e, rim, limits = robot(args.ini, key_defaults(args.config_keys))
    topt.LIMITS.update(limits)
    u_max = limits["supply"] - limits["margin"]
    f_max = limits["mu"] * topt.M * 9.80665 / 4.0 * (1.0 - limits["traction_margin"])
    topt.drive = lambda: (b, e, u_max, f_max, rim)  # per wheel: the arrays broadcast
    worst = {"model": 0.0, "fixed": 0.0}
    for row in csv.DictReader(open(args.times, encoding="utf-8")):
        start = [float(row[k]) for k in ("x0", "y0", "th0")] + [0.0, 0.0, 0.0]
        goal = [float(row[k]) for k in ("x", "y", "th")]
        t_m, t_f = float(row["model_s"]), float(row["fixed_s"])
        t0, guess = min(t_m, 30.0), None
        if args.traj_plan:
            t0, guess = topt.planner(args.traj_plan, start, goal, args.nodes)
        prob = topt.Problem(start, goal, args.nodes)
        t_o, viol, res = prob.solve(t0, guess)
        for _ in range(args.restarts):  # the solver's iteration limit: on from where it got
            if res.success:
                break
            z, _, t_end = prob.unpack(res.x)
            t_o, viol, res = prob.solve(t_end, z)
        ok = res.success and viol < 1e-4
        r_m, r_f = t_m / t_o, t_f / t_o
        if ok:
            worst["model"] = max(worst["model"], r_m)
            worst["fixed"] = max(worst["fixed"], r_f)
        plan = f", plan {t0:.3f} s ({t0 / t_o:.3f}x)" if args.plans and args.traj_plan else ""
        if ok and plan:
            worst["plan"] = max(worst.get("plan", 0.0), t0 / t_o)
        print(f"goal {row['leg']}: bound {t_o:.3f} s, model {t_m:.3f} s ({r_m:.3f}x), "
              f"fixed {t_f:.3f} s ({r_f:.3f}x){plan}"
              f"{'' if ok else '  (no bound: ' + res.message + ')'}")
    print(f"worst arrival / bound: model {worst['model']:.3f}x, fixed {worst['fixed']:.3f}x")
    if "plan" in worst:
        print(f"worst plan / bound: {worst['plan']:.3f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
