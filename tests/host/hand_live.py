#!/usr/bin/env python3
"""Live test of `omni4-ident run --hand` (the paper's experiment 2 pushed by hand) over real LCM.

A fake robot (this file) publishes OMNI4_MOTORS at 1 kHz on a udpm URL of its own (ttl=0). Its
physics is the independent plant of tests/indep/plant.py (imported read-only) for a robot with
known parameters, its wheel speeds come from quantised encoders. It answers each "coast" mark on
OMNI4_EXPERIMENT by a simulated hand push after a random 0.3-1.5 s: a half-sine external force
of 0.2-0.5 s along the mark's direction (10-15 N, or 0.8-1.2 N m about w), a few per cent leaking
into the other axes. The very first push goes sideways on purpose: the runner must close that
run, not count it, and ask again. Any OMNI4_CMD asking for VOLTAGE or VELOCITY fails the test,
and so does a keep-alive period (the median gap of the runner's own stamps) of 100 ms or more
(half the controller's 200 ms watchdog). How late a loaded machine lets a keep-alive out (the
longest gap received, and how often a 200 ms watchdog would have tripped) is the machine's:
printed, not asserted. The fake keeps its own time (its samples' utime) and may fall behind the
wall clock on a loaded machine: the runner's waits for a push are sized for that.

Checks: the runner's exit status and summary; the marks in the log (coast/end pairs per
direction, each coast mark before its push); then `omni4-ident identify` on the log: partial (no
motor test: it says what is missing) and Bv, Cv, Bvn, Cvn within 2 % of the fake robot's truth.

Usage: hand_live.py BIN_DIR LCM_PYTHONPATH [--seed N] [--port P]
Prints 'N passed, M failed'; exit status 1 on any failure. Every wait is bounded.
"""
import argparse
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "indep"))
import plant  # noqa: E402  (read-only: the colleague's independent plant)

RATE_HZ = 1000.0
CPR = 8192                      # encoder counts per wheel revolution
CMD_TIMEOUT_S = 0.2             # the controller's default watchdog (cmd_timeout_ms = 200)
PUSHES = 2
PUSH_TIMEOUT_S = 20             # the fake pushes within 1.5 s of a mark, in its own time
RUNNER_TIMEOUT_S = 70           # measured ~17 s; CTest's TIMEOUT (90 s) covers the whole script
IDENT_TIMEOUT_S = 8
TOL_PCT = 2.0
CHECKED = ("Bv", "Cv", "Bvn", "Cvn")
WRONG_AXIS = {"v": "vn", "vn": "v", "w": "v"}   # the deliberate first push goes here


def import_lcm(pythonpath):
    """The PyPI lcm module and the lcm-gen omni4 types."""
    sys.path.insert(0, os.path.abspath(pythonpath))
    import lcm
    import omni4
    return lcm, omni4


class FakeRobot(threading.Thread):
    """A robot on the bus: OMNI4_MOTORS at RATE_HZ in wall-clock lockstep; pushed by 'hand'."""

    def __init__(self, lcm, omni4, url, params, seed):
        super().__init__(daemon=True)
        self.omni4 = omni4
        self.lc = lcm.LCM(url)
        self.p = plant.stack_params([params])
        self.model = plant.axis_model(self.p)
        self.rng = np.random.default_rng(seed)
        self.dt = 1.0 / RATE_HZ
        self.x = np.zeros((1, 3))                 # robot velocity [m/s, m/s, rad/s]
        self.angle = np.zeros((1, 4))             # wheel angles at the present tick [rad]
        self.prev_angle = np.zeros((1, 4))        # ... at the previous tick [rad]
        self.angle0 = self.rng.uniform(0, 2 * np.pi, size=(1, 4))
        self.n = 0                                # ticks simulated
        self.utime0 = int(time.time() * 1e6)
        self.mode = plant.MODE_IDLE
        self.pushes = []       # (t0 [s], width [s], force (3,) [N, N, N m], asked, axis pushed)
        self.marks = []        # (utime, kind, direction) as received
        self.errors = []
        self.cmd_t = []        # receive times of OMNI4_CMD [s, monotonic]
        self.cmd_utime = []    # their utime (the runner's clock at sending) [us]
        self.cmd_modes = []
        self.watchdog_trips = 0
        self.tripped = False      # the present gap has been counted
        self.coast_marks = 0
        self.stop = threading.Event()
        self.lc.subscribe("OMNI4_CMD", self._on_cmd)
        self.lc.subscribe("OMNI4_EXPERIMENT", self._on_mark)

    def _on_cmd(self, _channel, data):
        c = self.omni4.command_t.decode(data)
        self.cmd_t.append(time.monotonic())
        self.tripped = False
        self.cmd_utime.append(c.utime)
        self.cmd_modes.append(c.mode)
        if c.mode in (plant.MODE_VOLTAGE, plant.MODE_VELOCITY):
            self.errors.append(f"OMNI4_CMD asked for mode {c.mode} (VOLTAGE/VELOCITY) at seq "
                               f"{c.seq}: the bridges must stay disabled")
        self.mode = plant.MODE_COAST if c.mode == plant.MODE_COAST else plant.MODE_IDLE

    def _on_mark(self, _channel, data):
        e = self.omni4.experiment_t.decode(data)
        self.marks.append((e.utime, e.kind, e.direction))
        if e.kind != "coast":
            return
        self.coast_marks += 1
        asked = e.direction
        pushed = WRONG_AXIS[asked] if self.coast_marks == 1 else asked
        self._schedule_push(asked, pushed)

    def _schedule_push(self, asked, pushed):
        axis = plant.AXES.index(pushed)
        strong = sum(1 for q in self.pushes if q[3] == asked) % 2 == 1  # alternate the speeds
        width = self.rng.uniform(0.4, 0.5) if strong else self.rng.uniform(0.2, 0.3)
        peak = (self.rng.uniform(13, 15) if strong else self.rng.uniform(10, 12))
        if axis == 2:
            peak = self.rng.uniform(0.8, 1.2)
        d = self.p["d"][0]
        f = np.zeros(3)
        f[axis] = peak
        for ax in range(3):  # a hand is not exact: 1-3 % into the other axes
            if ax != axis:
                conv = d if ax == 2 else (1.0 / d if axis == 2 else 1.0)
                f[ax] = peak * self.rng.uniform(0.01, 0.03) * conv
        t0 = self.n * self.dt + self.rng.uniform(0.3, 1.5)
        self.pushes.append((t0, width, f, asked, pushed))

    def _force(self, tm):
        """External force (T,1,3) at the tick midpoints tm (T,) [s]."""
        fext = np.zeros((len(tm), 1, 3))
        for t0, width, f, _, _ in self.pushes:
            on = (tm >= t0) & (tm < t0 + width)
            if on.any():
                fext[on, 0, :] += np.sin(np.pi * (tm[on] - t0) / width)[:, None] * f[None]
        return fext

    def _step(self, ticks):
        """Advance `ticks` ticks; returns wheel speeds (T,4) [rad/s] and currents (T,4) [A]."""
        tm = (self.n + np.arange(ticks) + 0.5) * self.dt
        u = np.zeros((ticks, 1, 4))
        driven = np.zeros((ticks, 1), bool)
        x_all, X = plant.integrate(self.model, u, driven, self._force(tm), self.dt, x0=self.x)
        ang = plant.wheel_angles(self.p, X) + self.angle[None]
        chained = np.concatenate([self.prev_angle[None], ang])
        speeds = plant.encoder_speeds(chained, CPR, self.dt, self.angle0)[1:]
        current = plant.motor_currents(self.p, u, driven, x_all[:-1], self.rng)
        self.x, self.prev_angle, self.angle = x_all[-1], ang[-2], ang[-1]
        return speeds[:, 0, :], current[:, 0, :]

    def _publish(self, speeds, current):
        m = self.omni4.motors_t()
        for k in range(len(speeds)):
            m.utime = self.utime0 + int(round((self.n + k) * self.dt * 1e6))
            m.seq = self.n + k
            m.mode = self.mode
            m.faults = 0
            m.voltage = [0.0] * 4
            m.current = [float(c) for c in current[k]]
            m.wheel_speed = [float(w) for w in speeds[k]]
            self.lc.publish("OMNI4_MOTORS", m.encode())

    def _watchdog(self):
        """Counts (prints) the gaps a 200 ms watchdog would have tripped on; the fake stays in
        COAST (its bridges are off either way)."""
        if self.mode == plant.MODE_COAST and self.cmd_t and not self.tripped and \
                time.monotonic() - self.cmd_t[-1] > CMD_TIMEOUT_S:
            self.watchdog_trips += 1
            self.tripped = True

    def run(self):
        start = time.monotonic()
        fd = self.lc.fileno()
        while not self.stop.is_set():
            due = int((time.monotonic() - start) / self.dt) - self.n
            if due > 0:
                speeds, current = self._step(min(due, 100))
                self._publish(speeds, current)
                self.n += len(speeds)
            while select.select([fd], [], [], 0)[0]:
                self.lc.handle()
            self._watchdog()
            select.select([fd], [], [], 0.004)

    def utime_of(self, t):
        return self.utime0 + int(round(t * 1e6))


def write_base(path, p):
    with open(path, "w") as f:
        f.write("[model]\n" + "".join(f"{k} = {p[k]!r}\n" for k in ("d", "r", "l", "M")))


def read_ini(path):
    out = {}
    for line in open(path):
        line = line.split(";")[0].strip()
        if "=" in line:
            k, v = line.split("=", 1)
            out[k.strip()] = float(v)
    return out


def log_events(lcm, omni4, path):
    """(channel, decoded message) of the marks and commands in an event log."""
    out = []
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == "OMNI4_EXPERIMENT":
            out.append((ev.channel, omni4.experiment_t.decode(ev.data)))
        elif ev.channel == "OMNI4_CMD":
            out.append((ev.channel, omni4.command_t.decode(ev.data)))
        elif ev.channel == "OMNI4_MOTORS":
            out.append((ev.channel, None))
    return out


class Checks:
    def __init__(self):
        self.passed = self.failed = 0

    def __call__(self, ok, what):
        print(("ok: " if ok else "FAIL: ") + what)
        if ok:
            self.passed += 1
        else:
            self.failed += 1
        return ok


def check_fake(check, fake):
    check(not fake.errors, "no VOLTAGE/VELOCITY command" + (": " + fake.errors[0] if fake.errors
                                                           else ""))
    gaps = np.diff(fake.cmd_t) if len(fake.cmd_t) > 1 else np.array([np.inf])
    stamped = np.diff(fake.cmd_utime) * 1e-6 if len(fake.cmd_utime) > 1 else np.array([np.inf])
    period = float(np.median(stamped))
    check(len(fake.cmd_t) > 20 and period < CMD_TIMEOUT_S / 2,
          f"COAST keep-alives: {len(fake.cmd_t)} commands every {period * 1e3:.0f} ms (median of "
          f"the runner's stamps; < {CMD_TIMEOUT_S * 1e3 / 2:.0f} ms), longest gap received "
          f"{gaps.max() * 1e3:.0f} ms, {fake.watchdog_trips} gap(s) over "
          f"{CMD_TIMEOUT_S * 1e3:.0f} ms (the machine's; not asserted)")
    modes = set(fake.cmd_modes[:-1])
    check(modes == {plant.MODE_COAST} and fake.cmd_modes[-1:] == [plant.MODE_IDLE],
          f"commands: COAST only, IDLE last (modes seen {sorted(set(fake.cmd_modes))})")


def check_marks(check, fake, events):
    marks = [m for ch, m in events if ch == "OMNI4_EXPERIMENT"]
    kinds = [m.kind for m in marks]
    paired = len(kinds) % 2 == 0 and all(
        kinds[i] == "coast" and kinds[i + 1] == "end" for i in range(0, len(kinds), 2))
    check(paired, f"marks in the log alternate coast/end ({len(kinds)} marks)")
    per_dir = {d: sum(1 for m in marks if m.kind == "coast" and m.direction == d)
               for d in plant.AXES}
    # v: one run closed for the sideways push, then the two counted ones.
    check(per_dir == {"v": PUSHES + 1, "vn": PUSHES, "w": PUSHES},
          f"coast runs per direction {per_dir} (v: one extra for the wrong-axis push)")
    coast = [m for m in marks if m.kind == "coast"]
    before = len(coast) == len(fake.pushes) and all(
        m.utime < fake.utime_of(p[0]) and m.direction == p[3] for m, p in zip(coast, fake.pushes))
    check(before, "every coast mark precedes its push, in the motors' clock")
    cmds = {m.mode for ch, m in events if ch == "OMNI4_CMD"}
    n_motors = sum(1 for ch, _ in events if ch == "OMNI4_MOTORS")
    # (most of the samples: a receiver held back on a loaded machine loses datagrams in the
    # kernel's socket buffer; 0.9 of them measured on an idle one was the old bound)
    check(cmds <= {plant.MODE_COAST, plant.MODE_IDLE} and n_motors > 0.5 * fake.n,
          f"the log holds the bus: {n_motors} of {fake.n} motors samples, command modes "
          f"{sorted(cmds)}")


def check_identify(check, bin_dir, tmp, log, base, truth):
    out_ini = os.path.join(tmp, "P.ini")
    r = subprocess.run([os.path.join(bin_dir, "omni4-ident"), "identify", "--robot", base,
                        "--out", out_ini, log], capture_output=True, text=True,
                       timeout=IDENT_TIMEOUT_S)
    print(r.stdout + r.stderr)
    if not check(r.returncode == 0 and os.path.exists(out_ini),
                 f"identify exit {r.returncode}, wrote P.ini"):
        return
    check("partial identification" in r.stdout and "missing:" in r.stdout,
          "identification is partial and says what is missing")
    got = read_ini(out_ini)
    for k in CHECKED:
        if k not in got:
            check(False, f"{k} not in P.ini")
            continue
        err = 100 * (got[k] - truth[k]) / truth[k]
        check(abs(err) <= TOL_PCT, f"{k} = {got[k]:.5g}, truth {truth[k]:.5g}, error "
                                   f"{err:+.2f} % (bound {TOL_PCT:.0f} %)")


def run_runner(check, bin_dir, url, log, base):
    cmd = [os.path.join(bin_dir, "omni4-ident"), "run", "--hand", "--pushes", str(PUSHES),
           "--out", log, "--lcm", url, "--robot", base, "--push-timeout", str(PUSH_TIMEOUT_S)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=RUNNER_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate(timeout=5)
        print(out)
        check(False, f"omni4-ident run --hand did not finish within {RUNNER_TIMEOUT_S} s")
        return False
    finally:
        if proc.poll() is None:  # interrupted (SIGTERM): never leave the runner behind
            proc.kill()
            proc.wait(timeout=5)
    print(out)
    ok = check(proc.returncode == 0, f"omni4-ident run --hand exit {proc.returncode}")
    check(re.search(r"went mostly along vn .* not v: run closed, not counted", out) is not None,
          "the sideways push is reported and not counted")
    check(f"runs v {PUSHES}/{PUSHES}, vn {PUSHES}/{PUSHES}, w {PUSHES}/{PUSHES} "
          "(1 along the wrong axis, 0 missed)" in out, "summary: every run recorded")
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bin_dir")
    ap.add_argument("lcm_python")
    ap.add_argument("--seed", type=int, default=20240611)
    ap.add_argument("--port", type=int, help="udpm port (default: one of livebus.TEST_PORTS)")
    a = ap.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # run the cleanups
    lcm, omni4 = import_lcm(a.lcm_python)
    sys.path.insert(0, os.path.join(HERE, "..", "firmware"))
    import livebus  # noqa: E402  (the tests' URL: after import_lcm, which sets the path)
    url = livebus.test_url(a.port)
    truth = plant.robot_params(a.seed, 0)
    check = Checks()
    t_start = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        base, log = os.path.join(tmp, "base.ini"), os.path.join(tmp, "hand.lcmlog")
        write_base(base, truth)
        fake = FakeRobot(lcm, omni4, url, truth, a.seed)
        fake.start()
        try:
            ran = run_runner(check, a.bin_dir, url, log, base)
        finally:
            fake.stop.set()
            fake.join(timeout=5)
        check(not fake.is_alive(), "the fake robot stopped")
        check_fake(check, fake)
        if ran and os.path.exists(log):
            check_marks(check, fake, log_events(lcm, omni4, log))
            check_identify(check, a.bin_dir, tmp, log, base, truth)
    print(f"hand_live: {time.monotonic() - t_start:.1f} s, seed {a.seed}, {url}")
    print(f"{check.passed} passed, {check.failed} failed")
    return 1 if check.failed else 0


if __name__ == "__main__":
    sys.exit(main())
