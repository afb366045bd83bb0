#!/usr/bin/env python3
"""omni4-sim --goals and --drive against the plant's truth in the log they write.

usage: sim_scenarios.py BIN_DIR

--goals: a file of four goals (a header row, a speed cap, a turn in place) is replayed in
lockstep; each goal is REACHED (its goal_status_t in the log), the truth (OMNI4_SIM_TRUTH) is
within 1 cm and 1 deg of it when REACHED comes, never faster than a goal's speed_max while that
goal is in force (5 % over for the tracking), and the summary's line for each goal names REACHED;
each goal is sent within 0.1 s of the one before it ending; the same file run twice gives the same truth, sample for sample (a scenario is replayed the same
on any machine). --drive: each row's velocity is the truth's (robot frame) over the last 0.3 s
before the next row, within 2 % and 1 cm/s (0.02 rad/s), and the robot is at rest before the
first row's time. Malformed files: one line "omni4-sim: FILE:LINE:COLUMN: ...", status 2, no log
written. Prints one line per check; exit status 0 when all pass, 1 otherwise.
"""
import math
import os
import sys
import tempfile

import lcm

import omni4
from script_checks import check, failures, run  # (this script's folder)

GOALS = """x,y,theta,speed_max
1.0,0.5,1.57
0.0,0.0,0.0,0.5
0.0,0.0,1.5
-0.6,0.4,-2.0
"""
DRIVE = """t_s,v,vn,w
# at rest until 0.5 s
0.5,0.5,0,0
2.0,0,-0.3,1.0
3.5,-0.2,0.2,-0.5
5.0,0,0,0
"""


def events(path, channel, typ):
    """[(event timestamp [us], decoded message)] of one channel of an LCM log."""
    out = []
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == channel:
            out.append((ev.timestamp, typ.decode(ev.data)))
    return out


def truth_at(truth, utime):
    """The OMNI4_SIM_TRUTH sample of the tick utime (or the last before it)."""
    best = None
    for _, t in truth:
        if t.utime > utime:
            break
        best = t
    return best


def check_goals(bin_dir, d):
    path = os.path.join(d, "goals.csv")
    with open(path, "w") as f:
        f.write(GOALS)
    logs = [os.path.join(d, f"goals{i}.lcmlog") for i in (1, 2)]
    out = run([os.path.join(bin_dir, "omni4-sim"), "--goals", path, "--out", logs[0], "-q"], d)
    lines = [ln for ln in out.splitlines() if " goal " in ln]
    check(len(lines) == 4 and all("REACHED" in ln for ln in lines),
          f"--goals: four goals, each REACHED in the summary: {lines}")
    goals = [[float(v) for v in row.split(",")] for row in GOALS.splitlines()[1:]]
    truth = events(logs[0], "OMNI4_SIM_TRUTH", omni4.sim_truth_t)
    status = [m for _, m in events(logs[0], "OMNI4_GOAL_STATUS", omni4.goal_status_t)]
    S = omni4.goal_status_t
    for k, g in enumerate(goals):
        ids = [m.goal_id for m in status if m.status == S.STATUS_ACTIVE]
        mine = sorted(set(ids))[k] if len(set(ids)) > k else None
        reached = [m for m in status if m.goal_id == mine and m.status == S.STATUS_REACHED]
        check(bool(reached), f"--goals: goal {k + 1} REACHED in the log")
        if not reached:
            continue
        t = truth_at(truth, reached[0].utime)
        e = math.hypot(t.pose[0] - g[0], t.pose[1] - g[1])
        a = abs(math.remainder(t.pose[2] - g[2], 2 * math.pi))
        check(e < 0.01 and a < math.radians(1.0),
              f"--goals: goal {k + 1}: the truth {e * 1e3:.1f} mm, {math.degrees(a):.2f} deg "
              "from it at REACHED (<= 1 cm, 1 deg)")
        if len(g) > 3:
            t0 = min(m.utime for m in status if m.goal_id == mine)
            fast = max(math.hypot(s.vel[0], s.vel[1]) for _, s in truth
                       if t0 <= s.utime <= reached[0].utime)
            check(fast <= 1.05 * g[3],
                  f"--goals: goal {k + 1}: the truth's top speed {fast:.3f} m/s within its "
                  f"speed_max {g[3]} (+5 %)")
    # each goal sent as soon as the one before ended: its first goal_t within 0.1 s of that
    sent = [m for _, m in events(logs[0], "OMNI4_GOAL", omni4.goal_t)
            if m.action == omni4.goal_t.ACTION_GO]
    ids = sorted({m.goal_id for m in sent})
    for a, b in zip(ids, ids[1:]):
        end = min((m.utime for m in status if m.goal_id == a and m.status != S.STATUS_ACTIVE),
                  default=None)
        first = min(m.utime for m in sent if m.goal_id == b)
        check(end is not None and 0 <= first - end <= 100000,
              f"--goals: goal {b} sent {(first - (end or 0)) / 1e3:.0f} ms after goal {a} "
              "ended (<= 100 ms)")
    run([os.path.join(bin_dir, "omni4-sim"), "--goals", path, "--out", logs[1], "-q"], d)
    again = events(logs[1], "OMNI4_SIM_TRUTH", omni4.sim_truth_t)
    same = len(again) == len(truth) and all(
        a.pose == b.pose and a.vel == b.vel for (_, a), (_, b) in zip(truth, again))
    check(same, f"--goals: the same file twice, the same truth ({len(truth)} samples)")


def check_drive(bin_dir, d):
    path = os.path.join(d, "drive.csv")
    with open(path, "w") as f:
        f.write(DRIVE)
    log = os.path.join(d, "drive.lcmlog")
    run([os.path.join(bin_dir, "omni4-sim"), "--drive", path, "--out", log, "-q"], d)
    truth = events(log, "OMNI4_SIM_TRUTH", omni4.sim_truth_t)
    t0 = truth[0][1].utime - 1000  # the first tick is 1 ms after the run's start
    rows = [[float(v) for v in r.split(",")] for r in DRIVE.splitlines()
            if r and r[0].isdigit()]
    still = [s for _, s in truth if s.utime - t0 < rows[0][0] * 1e6]
    check(bool(still) and max(max(abs(v) for v in s.vel) for s in still) < 1e-3,
          f"--drive: at rest before {rows[0][0]} s")
    ends = [r[0] for r in rows[1:]] + [rows[-1][0] + 1.0]
    for r, end in zip(rows, ends):
        win = [s for _, s in truth if (end - 0.3) * 1e6 <= s.utime - t0 < end * 1e6]
        mean = [sum(s.vel[i] for s in win) / len(win) for i in range(3)]
        tol = [0.02 * abs(r[1 + i]) + (0.02 if i == 2 else 0.01) for i in range(3)]
        ok = all(abs(mean[i] - r[1 + i]) <= tol[i] for i in range(3))
        check(ok, f"--drive: from {r[0]} s: truth {[round(m, 4) for m in mean]} against "
                  f"{r[1:]} over the 0.3 s before {end} s")


BAD = [  # (file, drive?, where the line must point: LINE:COLUMN, words)
    ("x,y,theta\n1,2\n", False, "2:1", "2 fields"),
    ("1,2,3\n1,2,x\n", False, "2:5", "theta 'x' is not a finite number"),
    ("1,2,3,-1\n", False, "1:7", "speed_max must be >= 0"),
    ("1,200,3\n", False, "1:3", "beyond 100 m"),
    ("t_s,v,vn,w\n1,0,0,0\n0.5,0,0,0\n", True, "3:1", "not below the row before"),
    ("0,0,0,nan\n", True, "1:7", "'nan' is not a finite number"),
    ("0,9,0,0\n", True, "1:3", "beyond [limits] vel_lin_max 3"),
    ("0,0,0,0,0\n", True, "1:9", "5 fields"),
    ("t_s,v,vn,w\n", True, "", "no rows"),
]


def check_bad(bin_dir, d):
    import subprocess
    for i, (text, drive, at, words) in enumerate(BAD):
        path = os.path.join(d, f"bad{i}.csv")
        with open(path, "w") as f:
            f.write(text)
        log = os.path.join(d, f"bad{i}.lcmlog")
        p = subprocess.run([os.path.join(bin_dir, "omni4-sim"), "--drive" if drive else "--goals",
                            path, "--out", log], capture_output=True, text=True, timeout=60)
        err = p.stderr.strip().splitlines()
        want = f"omni4-sim: {path}:{at}: " if at else f"omni4-sim: {path}: "
        check(p.returncode == 2 and len(err) == 1 and err[0].startswith(want) and
              words in err[0] and not os.path.exists(log),
              f"malformed {'--drive' if drive else '--goals'} file {text!r}: {p.returncode} "
              f"{err}")


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as d:
        check_goals(argv[1], d)
        check_drive(argv[1], d)
        check_bad(argv[1], d)
    print(f"sim_scenarios: {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
